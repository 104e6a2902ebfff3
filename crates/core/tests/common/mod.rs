//! References shared by the integration tests, written from the definitions (DESIGN.md §2).
#![allow(dead_code, clippy::needless_range_loop)]

pub mod limits_ref;
pub mod move_ref;
pub mod strategies;
