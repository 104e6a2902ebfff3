//! The least and greatest period of a constant-acceleration run without comparing every
//! period. Each edge is within ½ tick of its step's time `f·t_i`, so a period lies within
//! a tick of the exact one, `T_k = f·(t_k − t_{k−1})`, which is monotone on such a piece
//! (its speed is). Once `T` has moved two ticks away from the run's second period, no later
//! period passes that one on the side `T` left; the same holds backwards from the last
//! period. So the extremes need the periods of a head and a tail of the run only: the
//! steps between are generated and passed over.

use core::borrow::Borrow;

use super::{EdgeGenerator, Span, EPS};
use crate::profile::Profile;
use crate::real::fm;

/// (least period, greatest period, last edge).
type Extremes = (u64, u64, u64);

/// Runs shorter than this are compared period by period.
const MIN_SPLIT: u64 = 64;

impl<P: Borrow<Profile>> EdgeGenerator<P> {
    /// The next `n` steps of the current constant-acceleration piece (all inside it and
    /// before step N, as [`ramp_steps`](Self::ramp_steps) takes them) folded into `acc`.
    #[inline(always)]
    pub(super) fn ramp_extremes(&mut self, n: u64, acc: Extremes) -> Extremes {
        let both = |(lo, hi, last): Extremes, e: u64| (lo.min(e - last), hi.max(e - last), e);
        let Some((head, tail)) = self.head_and_tail(n) else {
            return self.ramp_steps(n, acc, both);
        };
        let acc = self.ramp_steps(head, acc, both);
        let acc = self.ramp_steps(n - head - tail, acc, |(lo, hi, _), e| (lo, hi, e));
        self.ramp_steps(tail, acc, both)
    }

    /// How many of the next `n` steps to compare at the start and at the end, or `None`
    /// to compare them all (a short run, or periods too coarse in f64 to tell apart).
    ///
    /// With the run's steps a..b and `T` falling (accelerating): every step from the first
    /// j ≥ a + 2 with `T_j ≤ T_{a+1} − 2` on has a period `≤ T_j + 1 ≤ T_{a+1} − 1`, at most
    /// step a + 1's (compared); every step up to the last j ≤ b − 1 with `T_j ≥ T_b + 2`
    /// has one `≥ T_b + 1`, at least step b's. Rising `T` (decelerating) swaps the sides.
    /// Each `T` is computed within `err` ticks; the two tests take it and the deviation of
    /// settled edges (settled on an integer move behind the profile) twice over.
    #[inline(never)]
    fn head_and_tail(&self, n: u64) -> Option<(u64, u64)> {
        if n < MIN_SPLIT {
            return None;
        }
        let ramp = &self.ramp;
        let span = Span::of(&self.cur);
        let f = self.clock;
        let (a, b) = (self.next_f, self.next_f + (n - 1) as f64);
        // local time by the merged closed form (no cancellation): steps a..b are inside
        // the piece, so is a step's predecessor from a + 1 on
        let time = |k: f64| 2.0 * (k - span.p0) / (ramp.c1 + ramp.root(span, k));
        let period = |k: f64| (time(k) - time(k - 1.0)) * f;
        let s_min = ramp.root(span, a).min(ramp.root(span, b));
        // the local times' rounding (a few ε of f·τ, and of the step number over the
        // speed), 64 times over
        let err = 64.0 * EPS * f * (span.dur + (b.abs() + span.p0.abs()) / s_min);
        let dev = ramp.dev / s_min;
        let gap = 2.0 + 2.0 * (err + dev);
        if !(err + dev <= 0.25) {
            return None;
        }
        let (first, last) = (period(a + 1.0), period(b));
        let rising = last > first;
        let past_head = |k: f64| {
            let t = period(k);
            if rising {
                t >= first + gap
            } else {
                t <= first - gap
            }
        };
        let before_tail = |k: f64| {
            let t = period(k);
            if rising {
                t <= last - gap
            } else {
                t >= last + gap
            }
        };
        let head_end = first_true(a + 2.0, b - 1.0, past_head)?;
        let tail_start = last_true(a + 2.0, b - 1.0, before_tail)?;
        if tail_start < head_end {
            return None;
        }
        Some(((head_end - a) as u64, (b - tail_start) as u64))
    }
}

/// The least whole k in [lo, hi] with `ok(k)`, by bisection (`ok` monotone: false, then
/// true); `None` if `ok(hi)` is false. The k returned has `ok(k)` true in any case.
fn first_true(mut lo: f64, mut hi: f64, ok: impl Fn(f64) -> bool) -> Option<f64> {
    if !(lo <= hi) || !ok(hi) {
        return None;
    }
    while lo < hi {
        let mid = lo + fm::floor((hi - lo) * 0.5);
        if ok(mid) {
            hi = mid;
        } else {
            lo = mid + 1.0;
        }
    }
    Some(hi)
}

/// The greatest whole k in [lo, hi] with `ok(k)` (`ok` monotone: true, then false); `None`
/// if `ok(lo)` is false. The k returned has `ok(k)` true in any case.
fn last_true(mut lo: f64, mut hi: f64, ok: impl Fn(f64) -> bool) -> Option<f64> {
    if !(lo <= hi) || !ok(lo) {
        return None;
    }
    while lo < hi {
        let mid = hi - fm::floor((hi - lo) * 0.5);
        if ok(mid) {
            lo = mid;
        } else {
            hi = mid - 1.0;
        }
    }
    Some(lo)
}
