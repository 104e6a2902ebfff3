//! References shared by the integration tests, written from the definitions (DESIGN.md §2).
#![allow(dead_code)]

pub mod limits_ref;
pub mod move_ref;
