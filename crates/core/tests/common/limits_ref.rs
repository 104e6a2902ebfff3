//! Limits mode from its definition, not from the planner: a move is
//! `vs → vp → cruise at vp → ve`, each velocity change a minimum-time one that starts and
//! ends with zero acceleration (and jerk), so it covers `(v0 + v1)/2 · T` steps. The peak
//! acceleration of a change is found by bisection, the best `vp` by a brute-force search
//! over a dense grid on `[0, vmax]`, refined around the best points.

use multistep_core::{LimitsMove, Order, Profile};
use proptest::prelude::*;

#[derive(Clone, Copy, Debug)]
pub struct Lim {
    pub order: Order,
    pub amax: f64,
    pub jmax: f64,
    pub smax: f64,
}

impl Lim {
    /// Time to raise the acceleration from 0 to `a` (and, mirrored, lower it back).
    pub fn rise(&self, a: f64) -> f64 {
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

    /// Minimum time of a velocity change of `dv ≥ 0`.
    pub fn change_time(&self, dv: f64) -> f64 {
        if dv <= 0.0 {
            return 0.0;
        }
        let a = self.peak_accel(dv);
        dv / a + self.rise(a)
    }

    /// The highest peak acceleration `a ≤ amax` of a change of `dv`, by bisection: the
    /// change covers `dv = a·(rise(a) + plateau)`, so `a·rise(a) ≤ dv`.
    pub fn peak_accel(&self, dv: f64) -> f64 {
        let fits = |a: f64| a * self.rise(a) <= dv;
        if fits(self.amax) {
            return self.amax;
        }
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
    }
}
/// `(steps covered without cruise, time without cruise)` of `vs → vp → ve`.
pub fn shape(l: &Lim, vs: f64, vp: f64, ve: f64) -> (f64, f64) {
    let (t1, t2) = (
        l.change_time((vp - vs).abs()),
        l.change_time((ve - vp).abs()),
    );
    (0.5 * (vs + vp) * t1 + 0.5 * (vp + ve) * t2, t1 + t2)
}

/// Duration of the move through `vp`, or None if it needs more than n steps.
pub fn duration(l: &Lim, n: f64, vs: f64, vp: f64, ve: f64) -> Option<f64> {
    let (d, t) = shape(l, vs, vp, ve);
    if d > n {
        return None;
    }
    if vp <= 0.0 {
        return (d >= n).then_some(t);
    }
    Some(t + (n - d) / vp)
}

/// The time-optimal `(duration, vp)` over the family, or None when no `vp` fits.
pub fn reference(l: &Lim, n: f64, vs: f64, ve: f64, vmax: f64) -> Option<(f64, f64)> {
    const K: usize = 1500;
    let at = |k: usize| vmax * k as f64 / K as f64;
    let mut best = (f64::INFINITY, 0.0);
    let consider = |best: &mut (f64, f64), v: f64| {
        if let Some(t) = duration(l, n, vs, v, ve) {
            if t < best.0 {
                *best = (t, v);
            }
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
    if best.0.is_finite() {
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
    best.0.is_finite().then_some(best)
}

pub fn lim_of(m: &LimitsMove) -> Lim {
    Lim {
        order: m.order,
        amax: m.amax,
        jmax: m.jmax.unwrap_or(f64::INFINITY),
        smax: m.smax.unwrap_or(f64::INFINITY),
    }
}

/// Velocity never above vmax nor below 0 (no reversal), acceleration, jerk and snap within
/// their limits, sampled densely; start and end at the requested speeds; N steps covered.
pub fn assert_feasible(p: &Profile, m: &LimitsMove) -> Result<(), TestCaseError> {
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
        if let (Some(j), true) = (m.jmax.filter(|_| m.order != Order::Trapezoid), k > 0) {
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
