//! # multistep-core
//!
//! Turns a stepper-motor move into the exact clock tick of every step pulse.
//!
//! A move ([`Move`], or [`MoveSpec`] by name) is planned into a [`Profile`]: a piecewise
//! position function p(t) built from the families of DESIGN.md §2. An [`EdgeGenerator`]
//! streams `edge_i = ceil(f·t_i − ½)` for every step with `t_i = min{t : p(t) = i}`: each
//! edge is the nearest tick to the exact step time, on every step, an exact half tick
//! going to the earlier tick.
//!
//! `no_std`, no allocation. The `std` feature (default) uses the platform's math library;
//! without it the pure-Rust `libm` crate is used.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]

pub mod dd;
pub mod edges;
pub mod error;
pub mod hal;
pub mod int;
mod limits;
pub mod piece;
pub mod profile;
pub mod real;
pub mod shape;
pub mod spec;
pub mod tdm;

pub use edges::{edges, EdgeGenerator, Periods, MAX_TICKS};
pub use error::PlanError;
pub use profile::{
    Family, LimitsMove, Move, Order, PhaseMove, Profile, Segment, MAX_PIECES, MAX_STEPS,
};
pub use shape::Shape;
pub use spec::MoveSpec;

/// Seed 000's clock: 50 MHz.
pub const DEFAULT_CLOCK_HZ: f64 = 50_000_000.0;
