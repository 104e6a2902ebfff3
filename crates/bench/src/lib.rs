//! # multistep-bench
//!
//! The step-timing algorithms people use today, written from their papers, and the harness
//! that runs them side by side with multistep on the same moves (`multistep bench`, the
//! criterion group `compare`, docs/BENCHMARKS.md):
//!
//! | impl | what |
//! |---|---|
//! | `multistep-float` | [`multistep_core::EdgeGenerator`] (f64, settled to the nearest tick) |
//! | `multistep-int` | [`multistep_core::int::IntEdgeGenerator`] (integers only) |
//! | `seed000` | seed 000's eq. (10)/(11) difference of two roots, fixed point ([`seed000`]) |
//! | `austin` | D. Austin's recurrence, as in AccelStepper ([`austin`]) |
//! | `eiderman` | A. Eiderman's `p·(1 + m·p²)` update ([`eiderman`]) |
//! | `ramp-maker` | the `ramp-maker` crate's trapezoid ([`rampmaker`]) |
//!
//! [`planning`] plans one move against Ruckig, natively and through Python.

pub mod austin;
pub mod compare;
pub mod eiderman;
pub mod icount;
pub mod moves;
pub mod planning;
pub mod ramp;
pub mod rampmaker;
pub mod seed000;

pub use compare::{run, run_families, Case, FamilyCase, Impl, Options};
pub use moves::{BenchMove, FamilyMove, CLOCK_HZ, FAMILY_MOVES, MOVES};

/// Edges from inter-step delays in ticks: each delay is rounded to a whole tick (a timer
/// compare value), and the edges are their running sum — so rounding drifts.
pub fn tick_sum(delays: impl Iterator<Item = f64>) -> impl Iterator<Item = u64> {
    delays.scan(0u64, |t, d| {
        *t += (d + 0.5).floor().max(0.0) as u64;
        Some(*t)
    })
}
