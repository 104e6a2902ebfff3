//! Integer moves: phase-mode trapezoids, seed 000 segments and limits-mode trapezoids,
//! planned into exact [`IntPiece`]s. Every input is an integer (module docs).

use super::isqrt::isqrt_u128;
use super::piece::IntPiece;
use super::IntError;
use crate::profile::MAX_PIECES;
use crypto_bigint::U512;

/// Phase mode, trapezoid family: N steps in whole-tick accel, cruise and decel times.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntPhaseMove {
    /// Steps of the move.
    pub steps: u64,
    /// Accel time in ticks.
    pub accel_ticks: u64,
    /// Cruise time in ticks.
    pub cruise_ticks: u64,
    /// Decel time in ticks.
    pub decel_ticks: u64,
    /// Start and end speed in 1/`speed_scale` steps/s.
    pub start_speed: u64,
    /// End speed in 1/`speed_scale` steps/s.
    pub end_speed: u64,
}

/// One of seed 000's constant-acceleration segments `(v0, T, n)` with T in ticks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntSegment {
    /// Start speed in 1/`speed_scale` steps/s.
    pub v0: u64,
    /// Duration in ticks.
    pub ticks: u64,
    /// Steps of the move.
    pub steps: u64,
}

/// Limits mode, trapezoid: the fastest move under vmax and amax, phase times rounded up
/// to whole ticks (so neither limit is ever exceeded).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntLimitsMove {
    /// Steps of the move.
    pub steps: u64,
    /// In 1/`speed_scale` steps/s and 1/`speed_scale` steps/s².
    pub vmax: u64,
    /// Acceleration limit in 1/`speed_scale` steps/s².
    pub amax: u64,
    /// Start speed in 1/`speed_scale` steps/s.
    pub start_speed: u64,
    /// End speed in 1/`speed_scale` steps/s.
    pub end_speed: u64,
}

/// The clock and the unit of speeds: `clock_hz` ticks per second, speeds in
/// 1/`speed_scale` steps/s (1 = whole steps/s).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntClock {
    /// Ticks per second.
    pub clock_hz: u64,
    /// Speeds are in 1/`speed_scale` steps/s.
    pub speed_scale: u64,
}

impl IntClock {
    /// A clock of `clock_hz` with speeds in whole steps/s.
    pub const fn hz(clock_hz: u64) -> Self {
        IntClock {
            clock_hz,
            speed_scale: 1,
        }
    }

    /// Speeds are `x / F` steps/tick with `F = clock_hz · speed_scale`.
    fn f(&self) -> Result<u128, IntError> {
        if self.clock_hz == 0 || self.speed_scale == 0 {
            return Err(IntError::ZeroClock);
        }
        Ok(self.clock_hz as u128 * self.speed_scale as u128)
    }
}

/// A planned integer move: pieces chained in time and position, at most `N` of them.
///
/// The default capacity is [`MAX_PIECES`], enough for any move; a phase or limits move has
/// at most 3 pieces and a segment list one per segment, so firmware may plan into a smaller
/// profile with the `*_in` planners (`IntProfile::<3>::phase_in`): about 270 B a piece.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IntProfile<const N: usize = MAX_PIECES> {
    pieces: [IntPiece; N],
    len: usize,
    steps: u64,
    end_tick: u64,
}

fn checked(x: Option<u128>) -> Result<u128, IntError> {
    x.ok_or(IntError::TooWide)
}

impl IntProfile {
    /// Phase mode (see [`IntProfile::phase_in`]).
    pub fn phase(m: &IntPhaseMove, clock: IntClock) -> Result<Self, IntError> {
        Self::phase_in(m, clock)
    }

    /// Segment mode (see [`IntProfile::segments_in`]).
    pub fn segments(segs: &[IntSegment], clock: IntClock) -> Result<Self, IntError> {
        Self::segments_in(segs, clock)
    }

    /// Limits mode (see [`IntProfile::limits_in`]).
    pub fn limits(m: &IntLimitsMove, clock: IntClock) -> Result<Self, IntError> {
        Self::limits_in(m, clock)
    }
}

impl<const N: usize> IntProfile<N> {
    fn empty(steps: u64) -> Result<Self, IntError> {
        if steps == 0 {
            return Err(IntError::NoSteps);
        }
        Ok(IntProfile {
            pieces: [IntPiece::UNUSED; N],
            len: 0,
            steps,
            end_tick: 0,
        })
    }

    fn push(&mut self, dur: u64, g: u128, u: u128, w: u128, s: u128) -> Result<(), IntError> {
        if dur == 0 {
            return Ok(());
        }
        if self.len == N {
            return Err(IntError::TooManyPieces);
        }
        let p = IntPiece::new(self.end_tick, dur, g, u, w, s)?;
        self.pieces[self.len] = p;
        self.len += 1;
        self.end_tick = self.end_tick.checked_add(dur).ok_or(IntError::TooWide)?;
        Ok(())
    }

    /// Checks a planned profile (by reference: with 64 slots it is about 17 kB).
    fn check(&self) -> Result<(), IntError> {
        if self.len == 0 {
            return Err(IntError::ZeroDuration);
        }
        // every step must be reachable: the last piece ends exactly on step N
        let last = &self.pieces[self.len - 1];
        if last.target(self.steps).unwrap_or(0) != last.m_end {
            return Err(IntError::TooWide);
        }
        // Den·i stays in range for every step of every piece
        if self
            .pieces()
            .iter()
            .any(|p| p.den.checked_mul(self.steps as u128).is_none())
        {
            return Err(IntError::TooWide);
        }
        // the pieces' steps cover 1..=N once each (what the generator walks)
        if self.pieces().iter().map(|p| p.steps).sum::<u64>() != self.steps {
            return Err(IntError::TooWide);
        }
        Ok(())
    }

    /// Phase mode: `vm = (2N·F − vs·Ta − ve·Tc) / (F·W)` steps/tick, `W = Ta + 2Tb + Tc`.
    pub fn phase_in(m: &IntPhaseMove, clock: IntClock) -> Result<Self, IntError> {
        let mut p = Self::empty(m.steps)?;
        let f = clock.f()?;
        let (ta, tb, tc) = (
            m.accel_ticks as u128,
            m.cruise_ticks as u128,
            m.decel_ticks as u128,
        );
        let w = ta + 2 * tb + tc;
        if w == 0 {
            return Err(IntError::ZeroDuration);
        }
        // speeds in units of 1/G steps/tick, G = F·W
        let g = checked(f.checked_mul(w))?;
        let (vs, ve) = (m.start_speed as u128, m.end_speed as u128);
        let shed = checked(checked(vs.checked_mul(ta))?.checked_add(checked(ve.checked_mul(tc))?))?;
        let two_nf = checked(f.checked_mul(2 * m.steps as u128))?;
        let vm = two_nf.checked_sub(shed).ok_or(IntError::CannotShed)?;
        let (us, ue) = (checked(vs.checked_mul(w))?, checked(ve.checked_mul(w))?);
        // positions in units of 1/(2G) steps: a piece adds (u + w)·D
        let mut s = 0u128;
        for (dur, u0, u1) in [(ta, us, vm), (tb, vm, vm), (tc, vm, ue)] {
            p.push(dur as u64, g, u0, u1, s)?;
            let sum = checked(u0.checked_add(u1))?;
            s = checked(checked(sum.checked_mul(dur))?.checked_add(s))?;
        }
        p.check()?;
        Ok(p)
    }

    /// Segment mode (seed 000): `w = 2n/D − v0` ≥ 0, `a = 2(n − v0·D)/D²`.
    pub fn segments_in(segs: &[IntSegment], clock: IntClock) -> Result<Self, IntError> {
        let steps = segs
            .iter()
            .try_fold(0u64, |acc, s| acc.checked_add(s.steps));
        let mut p = Self::empty(steps.ok_or(IntError::TooWide)?)?;
        let f = clock.f()?;
        let mut p0 = 0u128;
        for (index, sg) in segs.iter().enumerate() {
            if sg.ticks == 0 {
                return Err(IntError::ZeroDuration);
            }
            let d = sg.ticks as u128;
            // speeds in units of 1/(F·D) steps/tick
            let g = checked(f.checked_mul(d))?;
            let u = checked((sg.v0 as u128).checked_mul(d))?;
            let two_nf = checked((2 * sg.steps as u128).checked_mul(f))?;
            let w = two_nf
                .checked_sub(u)
                .ok_or(IntError::SegmentReverses { index })?;
            let s = checked(checked(g.checked_mul(2))?.checked_mul(p0))?;
            p.push(sg.ticks, g, u, w, s)?;
            p0 += sg.steps as u128;
        }
        p.check()?;
        Ok(p)
    }

    /// Limits mode, trapezoid: peak speed vmax or, if the move is too short,
    /// `⌊√((2·amax·N + vs² + ve²)/2)⌋`; phase times rounded up to whole ticks and the
    /// cruise time set so the cruise speed never exceeds the peak.
    pub fn limits_in(m: &IntLimitsMove, clock: IntClock) -> Result<Self, IntError> {
        Self::phase_in(&limits_to_phase(m, clock)?, clock)
    }

    /// Steps of the move.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The tick of the last step.
    pub fn end_tick(&self) -> u64 {
        self.end_tick
    }

    /// The pieces, in order.
    #[inline(always)]
    pub fn pieces(&self) -> &[IntPiece] {
        &self.pieces[..self.len]
    }

    /// Exact test of DESIGN.md §1: is `e` the nearest tick to step i, i.e.
    /// `p((e − ½)) < i ≤ p((e + ½))` (times in ticks)?
    pub fn is_nearest_tick(&self, i: u64, e: u64) -> bool {
        let below = e == 0 || self.position_below(2 * e as u128 - 1, i);
        below && !self.position_below(2 * e as u128 + 1, i)
    }

    /// Whether p(t2/2 ticks) < i, exactly.
    fn position_below(&self, t2: u128, i: u64) -> bool {
        if t2 >= 2 * self.end_tick as u128 {
            return false; // p = N ≥ i past the end
        }
        let k = self.pieces().partition_point(|p| 2 * p.t0 as u128 <= t2) - 1;
        let p = &self.pieces[k];
        match p.target(i) {
            // i at or before p0: p(t) ≥ p0 ≥ i
            None => false,
            Some(m) => p.cmp_at_half_ticks(t2 - 2 * p.t0 as u128, m).is_lt(),
        }
    }
}

/// The least `t ≥ 0` with `ok(t)` (`ok` monotone: false below the answer, true from it
/// on), by galloping from an estimate and then bisecting.
fn least(estimate: u128, ok: impl Fn(u128) -> Result<bool, IntError>) -> Result<u128, IntError> {
    // (lo, hi]: ok(hi) holds, and ok(lo) fails unless lo is 0 and unchecked
    let (mut lo, mut hi);
    if ok(estimate)? {
        hi = estimate;
        let mut step = 1u128;
        loop {
            let probe = hi.saturating_sub(step);
            if probe == hi || !ok(probe)? {
                lo = probe;
                break;
            }
            hi = probe;
            step = step.saturating_mul(2);
        }
        if hi == 0 {
            return Ok(0);
        }
    } else {
        lo = estimate;
        let mut step = 1u128;
        loop {
            let probe = checked(lo.checked_add(step))?;
            if ok(probe)? {
                hi = probe;
                break;
            }
            lo = probe;
            step = step.saturating_mul(2);
        }
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if ok(mid)? {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok(hi)
}

/// Rounds a limits-mode trapezoid to whole-tick phase times (see [`IntProfile::limits`]).
pub fn limits_to_phase(m: &IntLimitsMove, clock: IntClock) -> Result<IntPhaseMove, IntError> {
    let f = clock.f()?;
    let q = clock.speed_scale as u128;
    let hz = clock.clock_hz as u128;
    let (n, vmax, amax) = (m.steps as u128, m.vmax as u128, m.amax as u128);
    let (vs, ve) = (m.start_speed as u128, m.end_speed as u128);
    if n == 0 {
        return Err(IntError::NoSteps);
    }
    if vmax == 0 || amax == 0 {
        return Err(IntError::ZeroLimit);
    }
    if vs > vmax || ve > vmax {
        return Err(IntError::SpeedAboveLimit);
    }
    let sq = |v: u128| checked(v.checked_mul(v));
    // distance to go vs → v → ve at amax, ×2·amax·Q: 2v² − vs² − ve²
    let two_aqn = checked(checked((2 * amax).checked_mul(q))?.checked_mul(n))?;
    let ends = checked(sq(vs)?.checked_add(sq(ve)?))?;
    let need = |v: u128| -> Result<u128, IntError> {
        checked(checked(sq(v)?.checked_mul(2))?.checked_sub(ends))
    };
    // vp² (×2) = 2·vmax² when reaching vmax fits, else 2·amax·Q·N + vs² + ve²; vp itself
    // is never rounded: every comparison below is of squares, exactly (as the float
    // planner's `Profile::limits_on_clock` decides them)
    let at_vmax = need(vmax)? <= two_aqn;
    let vp2x2 = if at_vmax {
        checked(sq(vmax)?.checked_mul(2))?
    } else {
        checked(two_aqn.checked_add(ends))?
    };
    if vp2x2 < checked(sq(vs.max(ve))?.checked_mul(2))? || vp2x2 == 0 {
        return Err(IntError::TooShortForLimits);
    }
    // products of values under 2^128, at most four factors (x²·2 < 2^257, w²·2vp² <
    // 2^384, hz²·2vp² < 2^234): 512 bits cannot wrap, whatever the inputs
    let wide = |x: u128| U512::from_u128(x);
    let hz2vp2x2 = wide(checked(hz.checked_mul(hz))?).wrapping_mul(&wide(vp2x2));
    let vp_est = isqrt_u128(vp2x2 / 2);
    // the least t with t·amax + hz·v ≥ hz·vp, i.e. 2(t·amax + hz·v)² ≥ hz²·2vp²
    let ramp = |v: u128| -> Result<u128, IntError> {
        let ok = |t: u128| -> Result<bool, IntError> {
            let x = wide(checked(
                checked(t.checked_mul(amax))?.checked_add(checked(hz.checked_mul(v))?),
            )?);
            Ok(x.wrapping_mul(&x).wrapping_mul(&wide(2)) >= hz2vp2x2)
        };
        least(
            checked(hz.checked_mul(vp_est.saturating_sub(v)))? / amax,
            ok,
        )
    };
    let (ta, tc) = (ramp(vs)?, ramp(ve)?);
    // cruise: vp·(2Tb + Ta + Tc) ≥ K = 2N·F − vs·Ta − ve·Tc, i.e. 2vp²·W² ≥ 2K²
    let two_nf = checked((2 * n).checked_mul(f))?;
    let shed = checked(checked(vs.checked_mul(ta))?.checked_add(checked(ve.checked_mul(tc))?))?;
    let tb = match two_nf.checked_sub(shed) {
        None | Some(0) => 0,
        Some(k) => {
            let k2x2 = wide(k).wrapping_mul(&wide(k)).wrapping_mul(&wide(2));
            let ok = |tb: u128| -> Result<bool, IntError> {
                let w = wide(checked(
                    checked(tb.checked_mul(2))?.checked_add(checked(ta.checked_add(tc))?),
                )?);
                Ok(w.wrapping_mul(&w).wrapping_mul(&wide(vp2x2)) >= k2x2)
            };
            let est = (k / vp_est.max(1)).saturating_sub(ta.saturating_add(tc)) / 2;
            least(est, ok)?
        }
    };
    let tick = |x: u128| u64::try_from(x).map_err(|_| IntError::TooWide);
    Ok(IntPhaseMove {
        steps: m.steps,
        accel_ticks: tick(ta)?,
        cruise_ticks: tick(tb)?,
        decel_ticks: tick(tc)?,
        start_speed: m.start_speed,
        end_speed: m.end_speed,
    })
}
