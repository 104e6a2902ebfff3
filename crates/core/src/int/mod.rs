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
//! `Den, A, B` and `C = Den·p0`; step i has target `M = Den·i − C`, advanced by `M += Den`.
//!
//! # Per step (fixed sequence: 3 multiplies, 1 divide, 1 square root)
//! 1. `R = (4A² + 16·B·M) / 4^k` (1 multiply, 128 × 128 → 256 bits, of which a per-piece
//!    shift keeps the top; `4A²/4^k` is per piece) — `R = 4r/4^k`, `r = (Den·v)²` with v
//!    the speed at the step. k = 0 unless `2·Den·vmax ≥ 2^63`; R is rounded down;
//! 2. `s = ⌊√R⌋` (1 square root; [`isqrt`]: 126-bit radicand, 63-bit root);
//! 3. `q = ⌊(8M − 1) / (2A + s·2^k)⌋` (1 divide; quotient ≤ 2D + 1);
//! 4. correction: keep q iff `A + B·q ≥ 0` and `q·(2A + B·q) < 4M` (2 multiplies), else
//!    `q − 1`;
//! 5. `edge = t0 + ⌊(q + 1)/2⌋`.
//!
//! Why one correction suffices: with `τ* = 2M/(A + √r)` the exact step time and
//! `E = 8M/(2A + s·2^k)`, `s·2^k ≤ 2√r` gives `E ≥ 2τ*`; with k = 0,
//! `E − 2τ* < 4M / ((A + √r)·(2(A + √r) − 1))`, which with `4M = |r − A²| / |B|` and
//! `A + √r ≥ 2` is below `(2/3)/|B| < 1` for any integer `B ≠ 0` (0 for B = 0, where
//! `√(4A²)` is exact). With k > 0 the root is short by `Δ < 2.5·2^k` and planning checks
//! `A + √r ≥ 5·2^k` and `3|B| > 5·2^k` (`3A > 5D·2^k` when B = 0), which bound
//! `E − 2τ* < 5·2^k/(3|B|) < 1` the same way. So `q = ⌈E⌉ − 1` is `⌈2τ*⌉ − 1` or one more,
//! and step 4 is the exact test `p(q/2) < i` of DESIGN.md §1 on the rising branch. Step 5
//! is then `⌈τ* − ½⌉`: the nearest tick, with an exact half tick going to the earlier tick
//! as in the exactness test `p(e − ½) < i ≤ p(e + ½)` (and as the float generator settles
//! it). The last step of a piece that ends on a step (`M = A·D + B·D²`) is `t0 + D`.
//!
//! # Bit widths
//! Planning checks (typed error [`IntError::TooWide`] otherwise) that `8M < 2^124` and
//! `q·(2A + |B|q) < 2^124` for every step. The datapath needs one 128 × 128 → 256-bit
//! multiplier (B·M; a 128-bit one when k = 0), two multiplies with the narrow operand q
//! (⌈log2(2D + 2)⌉ bits, 33 for pieces under 2^32 ticks), a divider with a 124-bit
//! dividend whose quotient has only ⌈log2(2D + 2)⌉ bits (so a restoring divider takes that
//! many cycles), and a 126-bit-in, 63-bit-out square root. `Den` is the
//! product of the phase times (and, with nonzero start/end speeds, of `f·Q`) reduced by
//! their gcd; e.g. a 50 MHz trapezoid from rest with phases of 2^24 ticks and 10^6 steps
//! needs `M` of about 2^70.

mod gen;
pub mod isqrt;
mod piece;
mod plan;
mod wide;

pub use gen::IntEdgeGenerator;
pub use piece::IntPiece;
pub use plan::{limits_to_phase, IntClock, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment};

use thiserror::Error;

/// Why an integer move cannot be planned.
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
pub enum IntError {
    #[error("the move must have at least one step")]
    NoSteps,
    #[error("the clock and the speed scale must be greater than zero")]
    ZeroClock,
    #[error("the phases add up to zero ticks")]
    ZeroDuration,
    #[error("vmax and amax must be greater than zero")]
    ZeroLimit,
    #[error("the start or end speed is above vmax")]
    SpeedAboveLimit,
    #[error("too few steps for the start and end speeds within amax")]
    TooShortForLimits,
    #[error("too few steps for the start and end speeds in these phase times")]
    CannotShed,
    #[error("segment {index}: end speed 2n/T − v0 is negative; the motor would reverse")]
    SegmentReverses { index: usize },
    #[error("a move may have at most {} pieces", crate::profile::MAX_PIECES)]
    TooManyPieces,
    #[error("the move needs more than 128-bit intermediates (shorter phases or coarser speeds)")]
    TooWide,
}

#[cfg(test)]
mod tests;
