//! The integer-only exact datapath: the same edges as [`EdgeGenerator`](crate::EdgeGenerator)
//! for constant-acceleration moves, with no floating point anywhere on its path (u64/u128
//! and an integer square root). This is the algorithm the FPGA core implements.
//!
//! # Inputs (all integers)
//! - the clock `f` in Hz and a speed unit: speeds are in 1/Q steps/s ([`IntClock`]);
//! - phase mode trapezoid ([`IntPhaseMove`]): N steps, accel/cruise/decel times in whole
//!   ticks, start/end speeds; `vm = (2N·F − vs·Ta − ve·Tc)/(F·W)` steps/tick with
//!   `F = f·Q`, `W = Ta + 2Tb + Tc` is then an exact rational;
//! - segment mode ([`IntSegment`], seed 000's registers): `(v0, T in ticks, n)`;
//! - limits mode trapezoid ([`IntLimitsMove`]): vmax, amax, vs, ve; the peak speed is vmax
//!   or `⌊√((2·amax·N + vs² + ve²)/2)⌋`, and the phase times are rounded *up* to whole
//!   ticks so the move never exceeds a limit ([`limits_to_phase`]). When the ideal phase
//!   times are whole ticks this is the float planner's profile exactly.
//!
//! Every piece becomes `Den·(p(τ) − p0) = A·τ + B·τ²` (τ in local ticks) with integer
//! `Den, A, B` and `C = Den·p0`, reduced by their gcd; step i has target `M = Den·i − C`.
//!
//! # Per step (fixed sequence: 1 narrow multiply, 1 square root, 1 divide)
//! Planning turns each piece into a [`StepKernel`]; its j-th step is
//! 1. `Y = Y₀ ± j·ΔY` (1 multiply by the narrow j; `Y = A² + 4BM = (Den·v)²`, v the speed
//!    at the step);
//! 2. `r = ⌊√Y⌋` and whether `r² = Y` (1 square root with remainder, [`isqrt`]);
//! 3. `num = ⌈√Y⌉ + B − A − 1` (accelerating), `A + |B| − 1 − ⌊√Y⌋` (decelerating) or
//!    `2M + A − 1` (constant speed);
//! 4. `e = t0 + ⌊num / 2|B|⌋` (or `/ 2A`): 1 divide.
//!
//! That is the exact nearest tick `⌈τ* − ½⌉`, an exact half tick going to the earlier tick
//! as in the exactness test `p(e − ½) < i ≤ p(e + ½)`, with no correction step: the
//! remainder makes `⌈√Y⌉` exact and `⌈(x − y)/n⌉ = ⌈(⌈x⌉ − y)/n⌉` for integers y, n > 0
//! ([`IntPiece`] docs). The FPGA calculator (crates/hdl) runs the same kernel.
//!
//! # Bit widths
//! Planning checks (typed error [`IntError::TooWide`] otherwise) that `Den`, `A`, `|B|`,
//! `C` and `8M` stay below 2^124. Per step the datapath needs a multiplier with the narrow
//! operand j (⌈log2 steps⌉ bits), a square root of `Y` (`2·⌈log2(Den·vmax)⌉` bits; the root
//! has half as many) and a divider whose quotient has only ⌈log2(D + 1)⌉ bits (D the
//! piece's ticks). `Den` is the product of the phase times (and, with nonzero start/end
//! speeds, of `f·Q`) reduced by their gcd; e.g. a 20 ms segment at 50 MHz and 100 k
//! steps/s needs `Y` of about 2^113. Pieces whose `Y` needs more than 128 bits run the same
//! sequence on 256 bits in software ([`IntPiece::kernel`] is `None` for them; the RTL
//! rejects such moves).
//!
//! # Tracking ramps
//! [`IntTracker`] runs the float planner's ramps in integers ([`track`]): their
//! constant-acceleration pieces with the closed form above, and the constant-jerk pieces of
//! S-curve ramps by the exactness test evaluated exactly at half ticks (`cubic.rs`: the
//! position cubic by Horner on up to 512 bits, two evaluations a step).
//!
//! # Polynomial pieces a tick at a time
//! [`ChainEdges`] runs any profile of polynomial pieces (S-curves: cubic; scurve4:
//! quartic) as the board's per-axis chain does (`chain.rs`): the scaled position at each
//! tick's upper half tick by integer forward differences, a few wide additions a tick, and
//! the exactness test as the sign of one register. [`ChainPiece`] holds one piece's initial
//! values and the register widths it needs.
//!
//! # The float planner's integer moves
//! A trapezoid with whole speeds and whole-tick times planned by
//! [`Profile::plan_on_clock`](crate::Profile::plan_on_clock) keeps its integer move
//! ([`ExactMove`]): the float generator settles every step near a half tick on these
//! pieces with the exactness test above and runs its cruises on their cruise line, so it
//! gives this datapath's edges on every step, exact ties included.

// the kernel's items are described in the module docs above; item docs to follow
mod chain;
mod chain_recurrence;
mod cubic;
mod exact;
#[allow(missing_docs)]
mod gen;
pub mod isqrt;
#[allow(missing_docs)]
mod piece;
mod plan;
pub mod recurrence;
pub mod track;

pub use chain::{
    pieces as chain_pieces, ChainEdges, ChainError, ChainPiece, ChainValue, ChainWidths,
    CHAIN_LIMBS,
};
pub use exact::ExactMove;
pub use gen::IntEdgeGenerator;
pub use piece::{IntPiece, KernelMode, StepKernel};
pub use plan::{limits_to_phase, IntClock, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment};
pub use track::{IntRamp, IntTracker};

use thiserror::Error;

/// Why an integer move cannot be planned.
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
pub enum IntError {
    #[error("the move must have at least one step")]
    /// The move has no steps.
    NoSteps,
    #[error("the clock and the speed scale must be greater than zero")]
    /// The clock or the speed scale is zero.
    ZeroClock,
    #[error("the phases add up to zero ticks")]
    /// The phases add up to zero time.
    ZeroDuration,
    #[error("vmax and amax must be greater than zero")]
    /// vmax or amax is zero.
    ZeroLimit,
    #[error("the start or end speed is above vmax")]
    /// Limits mode: a start or end speed above vmax.
    SpeedAboveLimit,
    #[error("too few steps for the start and end speeds within amax")]
    /// Limits mode: too few steps for the end speeds within the limits.
    TooShortForLimits,
    #[error("too few steps for the start and end speeds in these phase times")]
    /// Phase mode: too few steps for the start and end speeds in these times.
    CannotShed,
    #[error("segment {index}: end speed 2n/T − v0 is negative; the motor would reverse")]
    /// Segment mode: a segment would end below zero speed.
    SegmentReverses {
        /// The segment (0-based).
        index: usize,
    },
    #[error("a move may have at most {} pieces", crate::profile::MAX_PIECES)]
    /// More pieces than a profile holds.
    TooManyPieces,
    #[error("the move needs more than 128-bit intermediates (shorter phases or coarser speeds)")]
    /// An intermediate needs more than the integer datapath's widths.
    TooWide,
}

#[cfg(test)]
mod chain_tests;
#[cfg(test)]
mod recurrence_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod track_tests;
