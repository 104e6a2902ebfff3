//! Limits mode: the time-optimal profile of N steps under vmax, amax (and jmax, smax).
//!
//! A move is accel → cruise → decel. Each velocity change is done in minimum time with
//! zero acceleration (and jerk) at its ends, so its velocity is point-symmetric about its
//! midpoint and it covers `(v0 + v1)/2 · T` steps. The peak speed is the largest one whose
//! accel and decel fit in N steps: closed form for the trapezoid, bisection on the
//! monotone distance function otherwise (Biagiotti & Melchiorri, *Trajectory Planning for
//! Automatic Machines and Robots*, 2008, §3.4, generalised to snap limits).

use crate::builder::{planned, schedule_end, Builder};
use crate::dd::Dd;
use crate::edges::MAX_TICKS;
use crate::error::{non_negative, positive, PlanError};
use crate::moves::{Family, LimitsMove, Order, PhaseMove, MAX_STEPS};
use crate::phase;
use crate::profile::Profile;
use crate::real::fm;

#[derive(Clone, Copy, Debug)]
pub(crate) struct Limits {
    pub amax: f64,
    pub jmax: f64,
    pub smax: f64,
    pub order: u8,
}

/// A minimum-time velocity change: pieces `(duration, highest derivative)` and total time.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Change {
    pub entries: [(f64, f64); 7],
    pub len: usize,
    pub time: f64,
}

impl Change {
    /// Its pieces.
    #[inline(always)]
    fn run(&self) -> &[(f64, f64)] {
        &self.entries[..self.len]
    }

    fn distance(&self, v0: f64, v1: f64) -> f64 {
        0.5 * (v0 + v1) * self.time
    }
}

/// Time to ramp a quantity from 0 to `peak` and back under a rate limit `r1` and a
/// rate-of-rate limit `r2` (the classic jerk-limited ramp): `(t_edge, t_flat)`.
fn ramp(peak: f64, r1: f64, r2: f64) -> (f64, f64) {
    if peak * r2 >= r1 * r1 {
        (r1 / r2, peak / r1 - r1 / r2)
    } else {
        (fm::sqrt(peak / r2), 0.0)
    }
}

/// Minimum-time change from v0 to v1 (either direction). Inlined: where only its time is
/// used the entries are not written.
#[inline(always)]
pub(crate) fn change(l: &Limits, v0: f64, v1: f64) -> Change {
    let dv = (v1 - v0).abs();
    let sg = if v1 >= v0 { 1.0 } else { -1.0 };
    let mut entries = [(0.0, 0.0); 7];
    if dv == 0.0 {
        return Change {
            entries,
            len: 0,
            time: 0.0,
        };
    }
    match l.order {
        2 => {
            entries[0] = (dv / l.amax, sg * l.amax);
            Change {
                entries,
                len: 1,
                time: dv / l.amax,
            }
        }
        3 => {
            let (tj, ta) = ramp(dv, l.amax, l.jmax);
            entries[0] = (tj, sg * l.jmax);
            entries[1] = (ta, 0.0);
            entries[2] = (tj, -sg * l.jmax);
            Change {
                entries,
                len: 3,
                time: 2.0 * tj + ta,
            }
        }
        _ => {
            // Peak acceleration a: the acceleration ramp is itself jerk/snap limited with
            // rise time Tr(a); Δv = a·(Tr(a) + t_const).
            let rise = |a: f64| {
                let (ts, tj) = ramp(a, l.jmax, l.smax);
                (ts, tj, 2.0 * ts + tj)
            };
            let (_, _, tr_max) = rise(l.amax);
            let a = if dv >= l.amax * tr_max {
                l.amax
            } else {
                let (j, s) = (l.jmax, l.smax);
                // a·(a/J + J/S) = Δv when the jerk limit is reached, else 2a^{3/2}/√S = Δv
                let a1 = 2.0 * dv / (j / s + fm::sqrt((j / s) * (j / s) + 4.0 * dv / j));
                if a1 * s >= j * j {
                    a1
                } else {
                    let x = dv * fm::sqrt(s) / 2.0;
                    fm::cbrt(x * x)
                }
            };
            let a = a.min(l.amax);
            let (ts, tj, tr) = rise(a);
            let tc = (dv / a - tr).max(0.0);
            let s = sg * l.smax;
            entries = [
                (ts, s),
                (tj, 0.0),
                (ts, -s),
                (tc, 0.0),
                (ts, -s),
                (tj, 0.0),
                (ts, s),
            ];
            Change {
                entries,
                len: 7,
                time: 2.0 * tr + tc,
            }
        }
    }
}

fn check_limit(name: &'static str, v: Option<f64>, family: &'static str) -> Result<f64, PlanError> {
    match v {
        Some(x) => positive(name, x),
        None => Err(PlanError::MissingLimit {
            family,
            missing: if name == "jmax" {
                "--jmax"
            } else {
                "--jmax and --smax"
            },
        }),
    }
}

/// Steps covered by `vs → vp → ve` with no cruise.
fn distance(l: &Limits, vs: f64, vp: f64, ve: f64) -> f64 {
    change(l, vs, vp).distance(vs, vp) + change(l, vp, ve).distance(vp, ve)
}

/// Largest `x` in `[lo, hi]` with `below(x)`, given `below(lo)` and not `below(hi)`.
fn bisect(mut lo: f64, mut hi: f64, below: impl Fn(f64) -> bool) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if below(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// The largest `x / 2^k` (k ≥ 1) with `below`, or 0 if none is above f64's smallest.
fn halve_until(x: f64, below: impl Fn(f64) -> bool) -> f64 {
    let mut v = x;
    while v > 0.0 {
        v *= 0.5;
        if below(v) {
            return v;
        }
    }
    0.0
}

/// Grid points tried when looking for a dip below both end speeds.
const DIP_GRID: usize = 256;

/// The peak (or valley) speed of the time-optimal move `vs → vp → (cruise) → ve` in `n`
/// steps, or the fewest steps any such move needs.
///
/// With `vp ≥ max(vs, ve)` the covered distance grows with `vp`, and the fastest move is
/// the largest `vp` that fits. When even the direct change `vs → ve` needs more than `n`
/// steps, a jerk-limited move can still fit by slowing below both end speeds first: a
/// change from a lower speed covers fewer steps while jerk, not acceleration, dominates
/// it. The distance is not monotone below `min(vs, ve)`, so the valley is found on a grid
/// (refining every grid minimum) and the largest valley speed that fits is kept: the
/// highest valley is the fastest one (higher speed everywhere, no cruise).
fn peak_speed(l: &Limits, n: f64, vs: f64, ve: f64, vmax: f64) -> Result<f64, f64> {
    let dist = |vp: f64| distance(l, vs, vp, ve);
    let vlo = vs.max(ve);
    if dist(vmax) <= n {
        return Ok(vmax);
    }
    let direct = dist(vlo);
    if direct <= n {
        if l.order == 2 {
            // vp² − vs² + vp² − ve² = 2·amax·N
            let vp = fm::sqrt((2.0 * l.amax * n + vs * vs + ve * ve) / 2.0);
            return Ok(vp.clamp(vlo, vmax));
        }
        if vlo > 0.0 {
            return Ok(bisect(vlo, vmax, |v| dist(v) <= n));
        }
        // From rest, a tiny jerk or snap puts the peak far below vmax: 200 halvings of
        // [0, vmax] would end at 0 (no move), so bracket it by powers of two first.
        let lo = halve_until(vmax, |v| dist(v) <= n);
        return Ok(bisect(lo, (2.0 * lo).min(vmax), |v| dist(v) <= n));
    }
    // A constant-acceleration change covers (v0² − v1²)/2a whatever the path: no dip helps.
    let vmin = vs.min(ve);
    if l.order == 2 || vmin <= 0.0 {
        return Err(direct);
    }
    // Scan down from vmin; the first grid point that fits bounds the highest fitting valley.
    let at = |k: usize| vmin * (DIP_GRID - k) as f64 / DIP_GRID as f64;
    let mut fewest = direct;
    let mut prev = direct;
    for k in 1..=DIP_GRID {
        let v = at(k);
        let d = dist(v);
        if d <= n {
            return Ok(bisect(v, at(k - 1), |x| dist(x) <= n));
        }
        // a grid minimum (d below both neighbours) may hide a narrow window that fits
        let next = if k < DIP_GRID {
            dist(at(k + 1))
        } else {
            f64::INFINITY
        };
        if d <= prev && d <= next {
            let (v_best, d_best) = golden_min(&dist, at((k + 1).min(DIP_GRID)), at(k - 1));
            fewest = fewest.min(d_best);
            if d_best <= n {
                return Ok(bisect(v_best, at(k - 1), |x| dist(x) <= n));
            }
        }
        fewest = fewest.min(d);
        prev = d;
    }
    Err(fewest)
}

/// Golden-section search for the minimum of `f` on `[a, b]`: `(argmin, min)`.
fn golden_min(f: &impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> (f64, f64) {
    const R: f64 = 0.618_033_988_749_894_8;
    let mut c = b - R * (b - a);
    let mut d = a + R * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..80 {
        if fc <= fd {
            b = d;
            d = c;
            fd = fc;
            c = b - R * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + R * (b - a);
            fd = f(d);
        }
        if b - a <= 1e-15 * b {
            break;
        }
    }
    if fc <= fd {
        (c, fc)
    } else {
        (d, fd)
    }
}

pub(crate) fn plan<const N: usize>(m: &LimitsMove) -> Result<Profile<N>, PlanError> {
    planned(|prof| plan_into(m, prof))
}

/// [`plan`] into `prof`'s storage, replacing its pieces (none left on an error).
pub(crate) fn plan_into<const N: usize>(
    m: &LimitsMove,
    prof: &mut Profile<N>,
) -> Result<(), PlanError> {
    prepare(m, |p, up, down| {
        build(p.l.order, p.n, p.vs, p.vp, up, down, m.steps, prof).map_err(|e| {
            // pieces that long overflow f64 (s·T⁴): the limits, not the pieces, are the problem
            if up.time + down.time < SLOWEST_CHANGE_S {
                e
            } else {
                PlanError::LimitsTooSmall {
                    steps: m.steps,
                    seconds: SLOWEST_CHANGE_S,
                }
            }
        })
    })
    .inspect_err(|_| prof.clear())
}

/// A limits move checked, with its peak speed: `vs → vp → (cruise) → ve` in `n` steps
/// (the two changes are handed beside it).
struct Prepared {
    l: Limits,
    n: f64,
    vs: f64,
    vp: f64,
}

impl Prepared {
    /// The duration of the pieces [`build`] makes, bit for bit, without making them: the
    /// changes' pieces and the cruise summed in the builder's order (a piece of no
    /// duration is not pushed).
    fn duration(&self, up: &Change, down: &Change) -> f64 {
        let order = self.l.order;
        let add = |t: f64, d: f64| if d > 0.0 { t + d } else { t };
        let t = up.run().iter().fold(0.0, |t, &(d, _)| add(t, d));
        let cruise = if self.vp > 0.0 {
            let at = schedule_end(order, self.vs, up.run());
            let tail = schedule_end(order, self.vp, down.run());
            ((self.n - at - tail) / self.vp).max(0.0)
        } else {
            0.0
        };
        down.run()
            .iter()
            .fold(add(t, cruise), |t, &(d, _)| add(t, d))
    }
}

/// Checks `m`, finds its peak speed and speed changes, and hands them to `then` (in place:
/// the changes are not copied out).
#[inline(always)]
fn prepare<R>(
    m: &LimitsMove,
    then: impl FnOnce(&Prepared, &Change, &Change) -> Result<R, PlanError>,
) -> Result<R, PlanError> {
    if m.steps == 0 {
        return Err(PlanError::NoSteps);
    }
    if m.steps > MAX_STEPS {
        return Err(PlanError::TooManySteps {
            steps: m.steps,
            max: MAX_STEPS,
        });
    }
    let vmax = positive("vmax", m.vmax)?;
    let amax = positive("amax", m.amax)?;
    let vs = non_negative("start speed", m.start_speed)?;
    let ve = non_negative("end speed", m.end_speed)?;
    let (order, jmax, smax) = match m.order {
        Order::Trapezoid => (2, f64::INFINITY, f64::INFINITY),
        Order::SCurve => (3, check_limit("jmax", m.jmax, "scurve")?, f64::INFINITY),
        Order::SCurve4 => {
            if m.jmax.is_none() || m.smax.is_none() {
                return Err(PlanError::MissingLimit {
                    family: "scurve4",
                    missing: "--jmax and --smax",
                });
            }
            (
                4,
                check_limit("jmax", m.jmax, "scurve4")?,
                check_limit("smax", m.smax, "scurve4")?,
            )
        }
    };
    for (name, v) in [("start speed", vs), ("end speed", ve)] {
        if v > vmax {
            return Err(PlanError::SpeedAboveLimit {
                name,
                value: v,
                vmax,
            });
        }
    }
    let l = Limits {
        amax,
        jmax,
        smax,
        order,
    };
    let n = m.steps as f64;
    // the changes to and from vmax, kept when it is the peak (as a cruise makes it)
    let (up, down) = (change(&l, vs, vmax), change(&l, vmax, ve));
    let vp = if up.distance(vs, vmax) + down.distance(vmax, ve) <= n {
        vmax
    } else {
        peak_speed(&l, n, vs, ve, vmax).map_err(|needed| PlanError::TooShortForLimits {
            steps: m.steps,
            start_speed: vs,
            end_speed: ve,
            needed,
        })?
    };
    let too_small = PlanError::LimitsTooSmall {
        steps: m.steps,
        seconds: SLOWEST_CHANGE_S,
    };
    if vp == 0.0 && vs == 0.0 && ve == 0.0 {
        // no speed above f64's smallest fits the steps within the limits
        return Err(too_small);
    }
    let p = Prepared { l, n, vs, vp };
    if vp == vmax {
        then(&p, &up, &down)
    } else {
        then(&p, &change(&l, vs, vp), &change(&l, vp, ve))
    }
}

/// A speed change longer than this (s) is no move: it exceeds 2^50 ticks of any clock
/// above 10⁻¹⁵ Hz, and its pieces' positions may overflow f64.
const SLOWEST_CHANGE_S: f64 = 1e30;

/// The pieces of `vs → vp → (cruise) → ve`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn build<const N: usize>(
    order: u8,
    n: f64,
    vs: f64,
    vp: f64,
    up: &Change,
    down: &Change,
    steps: u64,
    prof: &mut Profile<N>,
) -> Result<(), PlanError> {
    // the cruise covers what the changes' pieces leave (as summed in f64, so the move
    // ends on N to the rounding of its pieces, not of the closed-form distances)
    let mut b = Builder::new(prof);
    b.push_schedule(order, vs, up.run())?;
    let tail = schedule_end(order, vp, down.run());
    let cruise = if vp > 0.0 {
        ((n - b.position() - tail) / vp).max(0.0)
    } else {
        0.0
    };
    b.cruise(vp, cruise)?;
    b.push_schedule(order, vp, down.run())?;
    b.finish(steps)
}

/// The smallest whole number `t ≥ 0` with `ok(t)`, searched from an estimate (`ok` is
/// monotone: false below the answer, true from it on).
/// `None` if the estimate is off by more than a few ticks (only when the squares overflow).
fn least(estimate: f64, ok: impl Fn(f64) -> bool) -> Option<f64> {
    if !(estimate.is_finite() && estimate <= MAX_TICKS) {
        return None;
    }
    let mut t = fm::floor(estimate.max(0.0));
    let mut budget = 64;
    while !ok(t) {
        t += 1.0;
        budget -= 1;
        if budget == 0 {
            return None;
        }
    }
    while t > 0.0 && ok(t - 1.0) {
        t -= 1.0;
        budget -= 1;
        if budget == 0 {
            return None;
        }
    }
    Some(t)
}

/// `X ≥ Y` for `X` and `Y` within a few ulps of `x` and `y` (non-negative), decided in f64
/// where they are far apart and by `exact` where they are not.
#[inline(always)]
fn at_least(x: f64, y: f64, exact: impl FnOnce() -> bool) -> bool {
    const MARGIN: f64 = 1e-9;
    if x > y * (1.0 + MARGIN) {
        true
    } else if x < y * (1.0 - MARGIN) {
        false
    } else {
        exact()
    }
}

/// Limits mode on a clock, trapezoid: the time-optimal accel and decel times rounded *up*
/// to whole ticks, the cruise time rounded up so the cruise speed stays at or below the
/// peak, and the cruise speed then following from N (phase mode). Neither limit is ever
/// exceeded, and these are exactly the ticks [`crate::int::limits_to_phase`] computes with
/// integers: every comparison is of squares (`√` never rounded), in double-double.
///
/// Returns `(accel, cruise, decel)` ticks.
pub(crate) fn whole_ticks(m: &LimitsMove, clock: f64) -> Result<(f64, f64, f64), PlanError> {
    let f = positive("clock", clock)?;
    // validates the move, with the float planner's errors; its time-optimal duration
    let ideal = prepare(
        &LimitsMove {
            order: Order::Trapezoid,
            ..*m
        },
        |p, up, down| Ok(p.duration(up, down)),
    )?;
    let ticks = ideal * f;
    let too_long = PlanError::TooManyTicks {
        ticks,
        max: MAX_TICKS,
    };
    if !(ticks <= MAX_TICKS) {
        return Err(too_long);
    }
    let (n, vmax, amax) = (m.steps as f64, m.vmax, m.amax);
    let (vs, ve) = (m.start_speed, m.end_speed);
    let sq = |x: f64| Dd::mul_f64(x, x);
    // a move from rest to rest (the common one) skips the end speeds' exact terms
    let at_rest = vs == 0.0 && ve == 0.0;
    let ends = if at_rest { Dd::ZERO } else { sq(vs) + sq(ve) };
    // vp² = vmax² if reaching vmax fits in N (2vmax² − vs² − ve² ≤ 2·amax·N), else
    // amax·N + (vs² + ve²)/2
    let two_an = Dd::mul_f64(2.0 * amax, n);
    let reach = sq(vmax) * Dd::new(2.0) - ends;
    let vp2 = if reach <= two_an {
        sq(vmax)
    } else {
        (two_an + ends) * Dd::new(0.5)
    };
    let vp = fm::sqrt(vp2.hi);
    let f2vp2 = Dd::mul_f64(f, f) * vp2;
    // t ticks are enough to change from v to vp at amax: t·amax + f·v ≥ f·vp
    let ramp = |v: f64| {
        least(f * (vp - v) / amax, |t| {
            let x = t * amax + f * v;
            at_least(x * x, f2vp2.hi, || {
                let x = Dd::mul_f64(t, amax) + Dd::mul_f64(f, v);
                x * x >= f2vp2
            })
        })
    };
    // the ramps' squares overflow only for a peak far beyond any clock: say so
    let unreachable = || match vp.min(vmax) {
        peak if peak > f => PlanError::FasterThanClock { peak, clock_hz: f },
        _ => too_long.clone(),
    };
    // from rest to rest (or any equal end speeds) the two ramps are one search
    let up = ramp(vs);
    let down = if ve == vs { up } else { ramp(ve) };
    let (ta, tc) = match (up, down) {
        (Some(a), Some(c)) => (a, c),
        _ => return Err(unreachable()),
    };
    // cruise: vp·(2Tb + Ta + Tc) ≥ K = 2N·f − vs·Ta − ve·Tc
    let k = match Dd::mul_f64(2.0 * n, f) {
        k if at_rest => k,
        k => k - Dd::mul_f64(vs, ta) - Dd::mul_f64(ve, tc),
    };
    let tb = if !(k.hi > 0.0) {
        0.0
    } else {
        least((k.hi / vp - ta - tc) / 2.0, |tb| {
            // vp·w ≥ K (both ≥ 0) in f64 where it is clear, else vp²·w² ≥ K² exactly
            let w = 2.0 * tb + ta + tc;
            at_least(vp * w, k.hi, || {
                let w = Dd::new(w);
                vp2 * w * w >= k * k
            })
        })
        .ok_or_else(unreachable)?
    };
    Ok((ta, tb, tc))
}

/// [`whole_ticks`] planned: a phase-mode trapezoid of whole-tick phases.
pub(crate) fn plan_on_clock_into<const N: usize>(
    m: &LimitsMove,
    clock: f64,
    prof: &mut Profile<N>,
) -> Result<(), PlanError> {
    if m.order != Order::Trapezoid {
        return plan_into(m, prof);
    }
    let (ta, tb, tc) = whole_ticks(m, clock)?;
    phase::plan_into(
        &PhaseMove {
            steps: m.steps,
            accel_time: ta / clock,
            cruise_time: tb / clock,
            decel_time: tc / clock,
            start_speed: m.start_speed,
            end_speed: m.end_speed,
            family: Family::Trapezoid,
        },
        prof,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whole-tick planning ends with a profile or a typed error, however large the values.
    #[test]
    fn whole_ticks_terminate_on_extreme_values() {
        for (n, v, a, vs) in [
            (10u64, 1e300, 1e300, 0.0),
            (1 << 40, 1e200, 1e-200, 0.0),
            (3, 1e150, 1e150, 1e150),
            (7, 1e-300, 1e-300, 0.0),
            (1000, 3.0, 1e308, 1.0),
        ] {
            let m = LimitsMove::trapezoid(n, v, a).with_speeds(vs, 0.0);
            for clock in [1.0, 50e6, 1e18] {
                match Profile::limits_on_clock(&m, clock) {
                    Ok(p) => assert!(p.duration() > 0.0 && p.duration().is_finite()),
                    Err(e) => assert!(!e.to_string().is_empty()),
                }
            }
        }
    }

    proptest::proptest! {
        /// The duration found without pieces is the built profile's, bit for bit.
        #[test]
        fn prepared_durations_are_the_planned_ones(
            order in 0usize..3, steps in 1u64..100_000_000,
            vmax in 1e-3f64..1e7, amax in 1e-3f64..1e9, jmax in 1e-3f64..1e12, smax in 1e-3f64..1e15,
            vs in 0.0f64..1.0, ve in 0.0f64..1.0,
        ) {
            let m = crate::moves::limits_of_order(order, steps, [vmax, amax, jmax, smax], [vs, ve]);
            if let Ok(p) = plan::<15>(&m) {
                let d = prepare(&m, |p, up, down| Ok(p.duration(up, down))).unwrap();
                proptest::prop_assert_eq!(d.to_bits(), p.duration().to_bits(), "{:?}", m);
            }
        }
    }

    /// Huge or tiny limits give the error that names the real problem.
    #[test]
    fn extreme_limits_name_what_is_wrong() {
        let e =
            Profile::limits_on_clock(&LimitsMove::trapezoid(1000, 1e308, 1e308), 50e6).unwrap_err();
        assert!(matches!(e, PlanError::FasterThanClock { .. }), "{e}");
        assert!(e.to_string().contains("1.000e308 steps/s"), "{e}");
        // a tiny jerk from rest: a long move, not "zero time"
        let mut m = LimitsMove::trapezoid(10, 100.0, 100.0);
        m.order = Order::SCurve;
        m.jmax = Some(1e-300);
        let p = plan::<15>(&m).unwrap();
        assert!(p.duration() > 1e90 && p.duration().is_finite());
        let p = Profile::plan_on_clock(&crate::Move::Limits(m), 50e6).unwrap();
        let e = crate::EdgeGenerator::new(p, 50e6).unwrap_err();
        assert!(e.to_string().contains("lasts 3.420e108 ticks"), "{e}");
        // a snap so small no speed fits in f64
        m.order = Order::SCurve4;
        m.jmax = Some(1.0);
        m.smax = Some(1e-300);
        let e = plan::<15>(&m).unwrap_err();
        assert!(
            matches!(e, PlanError::LimitsTooSmall { steps: 10, .. }),
            "{e}"
        );
        assert!(e.to_string().contains("more than 1e30 s"), "{e}");
    }
}
