//! Limits mode with start/end speeds plans every feasible move of its family, dipping below
//! both end speeds when only that fits, and stays time-optimal and within every limit.
//!
//! The reference here is written from the definition of the family, not from the planner:
//! a move is `vs → vp → cruise at vp → ve`, each velocity change a minimum-time one that
//! starts and ends with zero acceleration (and jerk), so it covers `(v0 + v1)/2 · T` steps.
//! The reference finds the peak acceleration of a change by bisection and the best `vp` by
//! a brute-force search over a dense grid on `[0, vmax]`, refined around the best points.

use multistep_core::{LimitsMove, Order, PlanError, Profile};
use proptest::prelude::*;

#[derive(Clone, Copy, Debug)]
struct Lim {
    order: Order,
    amax: f64,
    jmax: f64,
    smax: f64,
}

impl Lim {
    /// Time to raise the acceleration from 0 to `a` (and, mirrored, lower it back).
    fn rise(&self, a: f64) -> f64 {
        match self.order {
            Order::Trapezoid => 0.0,
            Order::SCurve => a / self.jmax,
            // the acceleration ramp is jerk-limited with snap limit smax
            Order::SCurve4 => {
                if a * self.smax >= self.jmax * self.jmax {
                    a / self.jmax + self.jmax / self.smax
                } else {
                    2.0 * (a / self.smax).sqrt()
                }
            }
        }
    }

    /// Minimum time of a velocity change of `dv ≥ 0`: the highest peak acceleration `a`
    /// with `a · rise(a) ≤ dv` (the change covers `dv = a·(rise + plateau)`), found by bisection.
    fn change_time(&self, dv: f64) -> f64 {
        if dv <= 0.0 {
            return 0.0;
        }
        let fits = |a: f64| a * self.rise(a) <= dv;
        let a = if fits(self.amax) {
            self.amax
        } else {
            let (mut lo, mut hi) = (0.0, self.amax);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if fits(mid) {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            lo
        };
        dv / a + self.rise(a)
    }
}

/// `(steps covered without cruise, time without cruise)` of `vs → vp → ve`.
fn shape(l: &Lim, vs: f64, vp: f64, ve: f64) -> (f64, f64) {
    let (t1, t2) = (
        l.change_time((vp - vs).abs()),
        l.change_time((ve - vp).abs()),
    );
    (0.5 * (vs + vp) * t1 + 0.5 * (vp + ve) * t2, t1 + t2)
}

/// Duration of the move through `vp`, or None if it needs more than n steps.
fn duration(l: &Lim, n: f64, vs: f64, vp: f64, ve: f64) -> Option<f64> {
    let (d, t) = shape(l, vs, vp, ve);
    if d > n {
        return None;
    }
    if vp <= 0.0 {
        return (d >= n).then_some(t);
    }
    Some(t + (n - d) / vp)
}

/// The time-optimal duration over the family, or None when no `vp` fits.
fn reference(l: &Lim, n: f64, vs: f64, ve: f64, vmax: f64) -> Option<f64> {
    const K: usize = 1500;
    let at = |k: usize| vmax * k as f64 / K as f64;
    let mut best = f64::INFINITY;
    let consider = |best: &mut f64, v: f64| {
        if let Some(t) = duration(l, n, vs, v, ve) {
            *best = best.min(t);
        }
    };
    let feasible = |v: f64| shape(l, vs, v, ve).0 <= n;
    // the grid, with the end speeds as grid points: the distance has kinks there, and the
    // feasible set can be a narrow window next to one of them
    let mut grid: Vec<f64> = (0..=K).map(at).chain([vs, ve]).collect();
    grid.sort_by(f64::total_cmp);
    for w in grid.windows(2) {
        consider(&mut best, w[0]);
        // a feasibility boundary between two grid points: the optimum may sit on it
        if feasible(w[0]) != feasible(w[1]) {
            let (mut lo, mut hi) = (w[0], w[1]);
            let lo_ok = feasible(lo);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if feasible(mid) == lo_ok {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            consider(&mut best, if lo_ok { lo } else { hi });
        }
    }
    consider(&mut best, vmax);
    // zoom in around the best point found so far
    if best.is_finite() {
        let dur = |v: f64| duration(l, n, vs, v, ve).unwrap_or(f64::INFINITY);
        let mut c = (0..=K)
            .map(at)
            .min_by(|&a, &b| dur(a).total_cmp(&dur(b)))
            .unwrap();
        let mut w = vmax / K as f64;
        for _ in 0..12 {
            let (lo, hi) = ((c - w).max(0.0), (c + w).min(vmax));
            for k in 0..=64 {
                let v = lo + (hi - lo) * k as f64 / 64.0;
                if dur(v) < dur(c) {
                    c = v;
                }
            }
            consider(&mut best, c);
            w /= 8.0;
        }
    }
    best.is_finite().then_some(best)
}

fn lim_of(m: &LimitsMove) -> Lim {
    Lim {
        order: m.order,
        amax: m.amax,
        jmax: m.jmax.unwrap_or(f64::INFINITY),
        smax: m.smax.unwrap_or(f64::INFINITY),
    }
}

/// Velocity never above vmax nor below 0 (no reversal), acceleration, jerk and snap within
/// their limits, sampled densely; start and end at the requested speeds; N steps covered.
fn assert_feasible(p: &Profile, m: &LimitsMove) -> Result<(), TestCaseError> {
    let tol = 1.0 + 1e-9;
    let t_end = p.duration();
    const K: usize = 4000;
    let h = t_end / K as f64;
    let mut prev_a = p.acceleration(0.0);
    for k in 0..=K {
        let t = h * k as f64;
        let v = p.velocity(t);
        prop_assert!(v <= m.vmax * tol, "v({t}) = {v} > vmax");
        prop_assert!(
            v >= -1e-9 * m.vmax,
            "v({t}) = {v} < 0: the motor would reverse"
        );
        let a = p.acceleration(t);
        prop_assert!(a.abs() <= m.amax * tol, "a({t}) = {a}");
        if let (Some(j), true) = (m.jmax, k > 0) {
            // jerk as a difference quotient: within jmax (plus the sampling error)
            prop_assert!(
                (a - prev_a).abs() <= j * h * tol + 1e-9 * m.amax,
                "jerk at {t}"
            );
        }
        prev_a = a;
    }
    let vs = p.velocity(0.0);
    let ve = p.velocity(t_end);
    prop_assert!(
        (vs - m.start_speed).abs() <= 1e-9 * m.vmax,
        "start speed {vs}"
    );
    prop_assert!((ve - m.end_speed).abs() <= 1e-9 * m.vmax, "end speed {ve}");
    prop_assert!((p.position(t_end * (1.0 - 1e-15)) - m.steps as f64).abs() <= 1e-6);
    Ok(())
}

fn check_optimal(m: &LimitsMove) -> Result<Option<f64>, TestCaseError> {
    let l = lim_of(m);
    let n = m.steps as f64;
    let want = reference(&l, n, m.start_speed, m.end_speed, m.vmax);
    match (Profile::limits(m), want) {
        (Ok(p), Some(t)) => {
            assert_feasible(&p, m)?;
            let got = p.duration();
            prop_assert!(
                (got - t).abs() <= 1e-7 * t,
                "planned {got} s, reference {t} s"
            );
            Ok(Some(got))
        }
        (Err(PlanError::TooShortForLimits { needed, .. }), None) => {
            prop_assert!(needed > n);
            Ok(None)
        }
        (got, want) => Err(TestCaseError::fail(format!(
            "planner {got:?}, reference {want:?}"
        ))),
    }
}

#[test]
fn the_jerk_limited_dip_plans_the_move_the_old_planner_refused() {
    // refused before as "needs at least 278.73 steps"; a time-optimal solver finds 1.2314 s
    let m = LimitsMove {
        jmax: Some(2811.05),
        start_speed: 74.0277,
        end_speed: 581.794,
        ..LimitsMove::scurve(277, 1032.85, 2236.27, 2811.05)
    };
    let p = Profile::limits(&m).unwrap();
    assert!((p.duration() - 1.2314).abs() < 5e-5, "{}", p.duration());
    // it slows below the start speed first
    let vmin = (0..1000)
        .map(|k| p.velocity(p.duration() * k as f64 / 400.0))
        .fold(f64::INFINITY, f64::min);
    assert!(vmin < 74.0277 && vmin >= 0.0, "{vmin}");
    assert_eq!(check_optimal(&m).unwrap(), Some(p.duration()));
}

/// Dip-region moves: vs/ve (or ve/vs) in 0.03–0.15 and N just below what the direct change
/// `vs → ve` needs (the old planner's "needs at least").
fn dip_move(
    order: Order,
    vmax: f64,
    amax: f64,
    jmax: f64,
    smax: f64,
    fe: f64,
    ratio: f64,
    below: f64,
    swap: bool,
) -> Option<LimitsMove> {
    let hi = fe * vmax;
    let lo = ratio * hi;
    let (vs, ve) = if swap { (hi, lo) } else { (lo, hi) };
    let l = Lim {
        order,
        amax,
        jmax,
        smax,
    };
    let direct = shape(&l, vs, vs.max(ve), ve).0;
    let steps = (direct * (1.0 - below)).floor();
    if steps < 1.0 {
        return None;
    }
    Some(LimitsMove {
        steps: steps as u64,
        order,
        vmax,
        amax,
        jmax: Some(jmax),
        smax: (order == Order::SCurve4).then_some(smax),
        start_speed: vs,
        end_speed: ve,
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn dips_are_planned_time_optimal_and_within_limits(
        four in any::<bool>(), vmax in 200.0f64..5000.0, amax in 500.0f64..1e4,
        jmax in 500.0f64..2e4, smax in 500.0f64..1e5, fe in 0.3f64..1.0,
        ratio in 0.03f64..0.15, below in 0.0f64..0.1, swap in any::<bool>(),
    ) {
        let order = if four { Order::SCurve4 } else { Order::SCurve };
        let Some(m) = dip_move(order, vmax, amax, jmax, smax, fe, ratio, below, swap) else {
            return Ok(());
        };
        check_optimal(&m)?;
    }

    /// Everywhere else too: any start/end speeds, all three orders.
    #[test]
    fn limits_moves_with_end_speeds_are_time_optimal(
        order in prop_oneof![Just(Order::Trapezoid), Just(Order::SCurve), Just(Order::SCurve4)],
        steps in 1u64..5000, vmax in 100.0f64..1e4, amax in 100.0f64..1e5,
        jmax in 100.0f64..1e6, smax in 100.0f64..1e8, fs in 0.0f64..1.0, fe in 0.0f64..1.0,
    ) {
        let m = LimitsMove {
            steps, order, vmax, amax,
            jmax: (order != Order::Trapezoid).then_some(jmax),
            smax: (order == Order::SCurve4).then_some(smax),
            start_speed: fs * vmax, end_speed: fe * vmax,
        };
        check_optimal(&m)?;
    }
}
