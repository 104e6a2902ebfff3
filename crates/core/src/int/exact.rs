//! Moves the integer datapath plays, remembered by the float planner's profile
//! ([`Profile::plan_on_clock`]) so that the float generator gives the datapath's edges on
//! every step: where f64 cannot tell a step from a half tick (exact ties included), the
//! edge is settled by the exact test `p(e − ½) < i ≤ p(e + ½)` on the integer pieces, and
//! constant-speed runs use the integer cruise line.

use super::piece::IntPiece;
use super::plan::{limits_to_phase, IntClock, IntLimitsMove, IntPhaseMove, IntProfile};
use crate::accum::FloatCruise;
use crate::moves::{Family, Move, Order};
use crate::profile::Profile;
use crypto_bigint::U512;

/// The integer move behind a float profile on an integer clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExactMove {
    clock: IntClock,
    kind: Kind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Phase mode, or limits mode rounded to whole ticks: at most three pieces.
    Phase(IntPhaseMove),
    /// Segment mode: piece k is segment k, read back from the float piece (its start
    /// speed, whole ticks and whole steps are exact in f64).
    Segments,
}

/// `x` as an integer if it is one exactly (speeds).
fn whole(x: f64) -> Option<u64> {
    ((0.0..9.2e18).contains(&x) && x == libm::trunc(x)).then_some(x as u64)
}

/// `s` seconds as whole ticks, if `s` is the f64 nearest to that many ticks over the clock
/// (as `0.02` is for 10⁶ ticks at 50 MHz, and as the whole-tick planner writes them).
fn ticks(s: f64, clock: f64) -> Option<u64> {
    let r = libm::round(s * clock);
    let t = whole(r)?;
    (r / clock == s).then_some(t)
}

/// `Den·(p(τ) − p0) < m` at local time `tau2/2` ticks: `2A·tau2 + B·tau2² < 4m`, in 512
/// bits (A, |B| < 2^124 and tau2 < 2^65 make the terms up to 2^254).
fn below_at(p: &IntPiece, tau2: u128, m: u128) -> bool {
    let w = U512::from_u128;
    let lin = w(p.a).wrapping_mul(&w(tau2)).wrapping_mul(&w(2));
    let quad = w(p.b.unsigned_abs())
        .wrapping_mul(&w(tau2))
        .wrapping_mul(&w(tau2));
    let rhs = w(m).wrapping_mul(&w(4));
    if p.b >= 0 {
        lin.wrapping_add(&quad) < rhs
    } else {
        lin < rhs.wrapping_add(&quad)
    }
}

impl ExactMove {
    /// The integer move `m` is on a clock of `clock_hz`, if it has one (trapezoids with
    /// whole speeds and whole-tick times) and its pieces are `profile`'s, tick for tick.
    pub(crate) fn of<const N: usize>(
        m: &Move<'_>,
        clock_hz: f64,
        profile: &Profile<N>,
    ) -> Option<ExactMove> {
        let hz = whole(clock_hz).filter(|&h| h > 0)?;
        let clock = IntClock::hz(hz);
        let kind = match m {
            Move::Phase(p) if p.family == Family::Trapezoid => Kind::Phase(IntPhaseMove {
                steps: p.steps,
                accel_ticks: ticks(p.accel_time, clock_hz)?,
                cruise_ticks: ticks(p.cruise_time, clock_hz)?,
                decel_ticks: ticks(p.decel_time, clock_hz)?,
                start_speed: whole(p.start_speed)?,
                end_speed: whole(p.end_speed)?,
            }),
            Move::Limits(l) if l.order == Order::Trapezoid => {
                let im = IntLimitsMove {
                    steps: l.steps,
                    vmax: whole(l.vmax)?,
                    amax: whole(l.amax)?,
                    start_speed: whole(l.start_speed)?,
                    end_speed: whole(l.end_speed)?,
                };
                Kind::Phase(limits_to_phase(&im, clock).ok()?)
            }
            Move::Segments(segs) => {
                for s in segs.iter() {
                    whole(s.v0)?;
                    ticks(s.duration, clock_hz)?;
                }
                Kind::Segments
            }
            _ => return None,
        };
        let x = ExactMove { clock, kind };
        // the same pieces, tick for tick (so the same start ticks), each one plannable
        let phase = x.phase();
        for k in 0..profile.len() {
            let q = x.piece(profile, k, phase.as_ref())?;
            if ticks(profile.piece(k).dur, clock_hz) != Some(q.dur) {
                return None;
            }
        }
        if let (Some(ip), Kind::Phase(_)) = (&phase, x.kind) {
            if ip.pieces().len() != profile.len() {
                return None;
            }
        }
        Some(x)
    }

    fn phase(&self) -> Option<IntProfile<3>> {
        match self.kind {
            Kind::Phase(m) => IntProfile::<3>::phase_in(&m, self.clock).ok(),
            Kind::Segments => None,
        }
    }

    /// Integer piece k of `profile` (`phase`: [`ExactMove::phase`]).
    fn piece<const N: usize>(
        &self,
        profile: &Profile<N>,
        k: usize,
        phase: Option<&IntProfile<3>>,
    ) -> Option<IntPiece> {
        match self.kind {
            Kind::Phase(_) => phase?.pieces().get(k).copied(),
            Kind::Segments => {
                // seed 000's segment (v0, D, n) from position p0, as `IntProfile::segments`
                let hz = self.clock.clock_hz as f64;
                let ps = profile.pieces().get(..=k)?;
                let p = &ps[k];
                let t0 = ps[..k]
                    .iter()
                    .try_fold(0u64, |t, q| t.checked_add(ticks(q.dur, hz)?))?;
                let d = ticks(p.dur, hz)? as u128;
                let v0 = whole(p.quadratic()?.0)? as u128;
                let p0 = whole(p.p0)? as u128;
                let n = whole(profile.end_of(k))? as u128 - p0;
                let f = self.clock.clock_hz as u128;
                let g = f.checked_mul(d)?;
                let u = v0.checked_mul(d)?;
                let w = (2 * n).checked_mul(f)?.checked_sub(u)?;
                let s = g.checked_mul(2)?.checked_mul(p0)?;
                IntPiece::new(t0, d as u64, g, u, w, s).ok()
            }
        }
    }

    /// The nearest tick to step i (in piece k of `profile`), an exact half tick going to
    /// the earlier tick, searched from `guess`; `None` if the integer pieces cannot say.
    /// Whether this move's ticks are those of a `clock_hz` clock.
    pub(crate) fn on_clock(&self, clock_hz: f64) -> bool {
        self.clock.clock_hz as f64 == clock_hz
    }

    pub(crate) fn settle(&self, profile: &Profile, k: usize, i: u64, guess: u64) -> Option<u64> {
        let phase = self.phase();
        let phase = phase.as_ref();
        let end = {
            let last = self.piece(profile, profile.len() - 1, phase)?;
            last.t0 as u128 + last.dur as u128
        };
        let mut k = k;
        // p(t2/2 ticks) < i, exactly
        let mut below = |t2: u128| -> Option<bool> {
            if t2 >= 2 * end {
                return Some(false); // p = N ≥ i past the end
            }
            loop {
                let q = self.piece(profile, k, phase)?;
                let t0 = 2 * q.t0 as u128;
                if t2 < t0 && k > 0 {
                    k -= 1;
                } else if t2 >= t0 + 2 * q.dur as u128 && k + 1 < profile.len() {
                    k += 1;
                } else {
                    return Some(match q.target(i) {
                        None => false,
                        Some(m) => below_at(&q, t2.checked_sub(t0)?, m),
                    });
                }
            }
        };
        let mut e = guess as u128;
        for _ in 0..64 {
            if e > 0 && !below(2 * e - 1)? {
                e -= 1;
            } else if below(2 * e + 1)? {
                e += 1;
            } else {
                return u64::try_from(e).ok();
            }
        }
        None
    }

    /// The exact constant-speed edges of piece k of `profile`, if it is a cruise whose
    /// line fits the accumulator.
    pub(crate) fn cruise(&self, profile: &Profile, k: usize) -> Option<FloatCruise> {
        let q = self.piece(profile, k, self.phase().as_ref())?;
        let (y, dy, dv) = q.cruise_line()?;
        FloatCruise::from_line(y, dy, dv, q.first)
    }
}

#[cfg(test)]
mod tests {
    use crate::moves::{Family, LimitsMove, Move, PhaseMove, Segment};
    use crate::profile::Profile;

    fn exact(m: &Move<'_>, hz: f64) -> bool {
        Profile::plan_on_clock(m, hz).unwrap().exact.is_some()
    }

    /// Whole speeds and whole-tick times keep their integer move; anything else has none.
    #[test]
    fn integer_moves_are_recognised_and_others_are_not() {
        let hz = 50e6;
        let lm = LimitsMove::trapezoid(1170, 42102.0, 19_243_484.0);
        assert!(exact(&Move::Limits(lm), hz));
        let frac = LimitsMove {
            vmax: 42102.5,
            ..lm
        };
        assert!(!exact(&Move::Limits(frac), hz));
        let pm = PhaseMove::new(2400, Family::Trapezoid, 0.02, 0.01, 0.02).with_speeds(0.0, 7.0);
        assert!(exact(&Move::Phase(pm), hz));
        // not a whole number of ticks, and not a trapezoid
        let odd = PhaseMove {
            accel_time: 0.02 + 1e-12,
            ..pm
        };
        assert!(!exact(&Move::Phase(odd), hz));
        let sine = PhaseMove {
            family: Family::Sine,
            ..pm
        };
        assert!(!exact(&Move::Phase(sine), hz));
        let seg = |v0, duration, steps| Segment {
            v0,
            duration,
            steps,
        };
        let segs = [
            seg(0.0, 0.125, 2000),
            seg(32e3, 0.5, 16_000),
            seg(32e3, 0.125, 2000),
        ];
        assert!(exact(&Move::Segments(&segs), hz));
        assert!(!exact(&Move::Segments(&segs), 50e6 + 0.5));
        // the float planner alone (no clock) has no integer move
        assert!(Profile::plan(&Move::Limits(lm)).unwrap().exact.is_none());
    }
}
