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
//! ```
//! use multistep_core::{EdgeGenerator, LimitsMove, Profile};
//!
//! // 3200 steps from rest to rest: at most 4000 steps/s and 20 000 steps/s²
//! let profile = Profile::limits(&LimitsMove::trapezoid(3200, 4000.0, 20_000.0))?;
//! let mut edges = EdgeGenerator::new(profile, 1_000_000.0)?; // a 1 MHz timer
//! assert_eq!(edges.next(), Some(10_000)); // step 1 at √(2/20 000) s = 10 ms
//! // 0.2 s up to 4000 steps/s (400 steps), 0.6 s cruising, 0.2 s down: the last step at 1 s
//! assert_eq!(edges.last(), Some(1_000_000));
//! # Ok::<(), multistep_core::PlanError>(())
//! ```
//!
//! For firmware, [`hal::Stepper`] drives STEP/DIR pins from a timer interrupt.
//!
//! `no_std`, no allocation. The `std` feature (default) uses the platform's math library;
//! without it the pure-Rust `libm` crate is used.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![forbid(unsafe_code)]
#![warn(missing_docs)]
// `!(x <= y)` is how this crate rejects NaN along with the out-of-range values
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accum;
mod builder;
mod dd;
pub mod edges;
pub mod error;
pub mod hal;
pub mod int;
mod jet;
mod kinematics;
mod limits;
mod moves;
pub mod params;
mod phase;
mod piece;
mod plan;
pub mod profile;
mod real;
mod shape;
pub mod spec;
pub mod step_dir;
pub mod stream;
pub mod summary;
// the TDM model's own items are documented in its module docs; item docs to follow
#[allow(missing_docs)]
pub mod tdm;
pub mod track;

pub use edges::{edges, EdgeGenerator, Periods, MAX_TICKS};
pub use error::{Num, PlanError};
pub use kinematics::{stop_distance, time_scale};
pub use moves::{
    Family, LimitsMove, Move, Order, PhaseMove, Segment, DEFAULT_PHI, DEFAULT_PSI, DEFAULT_RHO,
    MAX_PHASE_PIECES, MAX_PIECES, MAX_STEPS,
};
pub use params::{MoveParams, Param, PARAMS};
pub use plan::ClockCheck;
pub use profile::Profile;
pub use shape::Shape;
pub use spec::MoveSpec;
pub use step_dir::{PulseShape, StepDirTiming};
pub use summary::{MoveName, PlanSummary};
pub use track::{Rate, TrackError, TrackLimits, TrackRun, Tracker, TrackerOf};

/// Seed 000's clock: 50 MHz.
pub const DEFAULT_CLOCK_HZ: f64 = 50_000_000.0;
