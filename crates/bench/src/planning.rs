//! One move planned: multistep's limits-mode planner against Ruckig (the online trajectory
//! generator of Berscheid and Kröger, "Jerk-limited Real-time Trajectory Generation with
//! Arbitrary Target States", RSS 2021) on the same single-axis move from rest to rest,
//! natively and through each one's Python package. Ruckig covers the trapezoid (its jerk
//! limit infinite) and the jerk-limited S-curve, so those are the cases.

use multistep_core::{LimitsMove, PlanError, Profile, MAX_PHASE_PIECES};
use serde::Serialize;
use std::hint::black_box;
use std::time::Instant;

/// A single-axis move from rest to rest under limits (steps, steps/s, steps/s², steps/s³).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PlanCase {
    pub name: &'static str,
    pub steps: u64,
    pub vmax: f64,
    pub amax: f64,
    /// None: a trapezoid.
    pub jmax: Option<f64>,
}

/// 100 000 steps at 20 000 steps/s, 100 000 steps/s² (and 10⁶ steps/s³): 5.2 s and 5.3 s.
pub const PLAN_CASES: [PlanCase; 2] = [
    PlanCase {
        name: "trapezoid-100k",
        steps: 100_000,
        vmax: 20_000.0,
        amax: 100_000.0,
        jmax: None,
    },
    PlanCase {
        name: "scurve-100k",
        steps: 100_000,
        vmax: 20_000.0,
        amax: 100_000.0,
        jmax: Some(1e6),
    },
];

impl PlanCase {
    pub fn limits(&self) -> LimitsMove {
        match self.jmax {
            Some(j) => LimitsMove::scurve(self.steps, self.vmax, self.amax, j),
            None => LimitsMove::trapezoid(self.steps, self.vmax, self.amax),
        }
    }

    pub fn by_name(name: &str) -> Option<&'static PlanCase> {
        PLAN_CASES.iter().find(|c| c.name == name)
    }
}

/// Plans the case `n` times into one profile sized for a limits move
/// (`Profile::<MAX_PHASE_PIECES>::replan_limits`), as Ruckig's `calculate` writes into one
/// `Trajectory` sized for its move; returns the sum of the durations (so nothing is
/// optimised away).
pub fn plan_n(case: &PlanCase, n: u64) -> Result<f64, PlanError> {
    let m = case.limits();
    let mut p = Profile::<MAX_PHASE_PIECES>::default();
    let mut sum = 0.0;
    for _ in 0..n {
        p.replan_limits(black_box(&m))?;
        sum += black_box(&p).duration();
    }
    Ok(sum)
}

/// Nanoseconds per plan: the median of `rounds` rounds of `per_round` plans.
pub fn time_native(case: &PlanCase, rounds: usize, per_round: u64) -> Result<f64, PlanError> {
    let mut t = Vec::with_capacity(rounds);
    for _ in 0..rounds {
        let t0 = Instant::now();
        black_box(plan_n(case, per_round)?);
        t.push(t0.elapsed().as_secs_f64() * 1e9 / per_round as f64);
    }
    Ok(median(&mut t))
}

pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// The Python side, run by the interpreter given: `count IMPL CASE N` makes N calls (for
/// callgrind: both packages are imported and set up whatever IMPL is, so N = 0 is the
/// floor), `time CASE ROUNDS N` alternates rounds of N calls of each and prints the median
/// µs per call of each as JSON. The case's numbers come as JSON after the mode's.
pub const PY_DRIVER: &str = r#"
import json, sys, time
import multistep
from ruckig import InputParameter, Ruckig, Trajectory

mode, impl, case, rounds, n = sys.argv[1], sys.argv[2], json.loads(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
otg, inp, traj = Ruckig(1), InputParameter(1), Trajectory(1)
inp.current_position, inp.target_position = [0.0], [float(case["steps"])]
inp.max_velocity, inp.max_acceleration = [case["vmax"]], [case["amax"]]
inp.max_jerk = [case["jmax"] if case["jmax"] is not None else float("inf")]
steps, vmax, amax, jmax = case["steps"], case["vmax"], case["amax"], case["jmax"]
plan = multistep.plan

# the call as a program writes it: its keywords named at the call (a `**dict` would have
# the caller build and unpack a dictionary every time)
if jmax is None:
    def ms():
        for _ in range(n):
            plan(steps=steps, vmax=vmax, amax=amax)
    def one():
        return plan(steps=steps, vmax=vmax, amax=amax)
else:
    def ms():
        for _ in range(n):
            plan(steps=steps, vmax=vmax, amax=amax, profile="scurve", jmax=jmax)
    def one():
        return plan(steps=steps, vmax=vmax, amax=amax, profile="scurve", jmax=jmax)

def rk():
    for _ in range(n):
        otg.calculate(inp, traj)

# both give the move's duration
assert abs(one().duration_s - (otg.calculate(inp, traj), traj.duration)[1]) < 1e-6
if mode == "count":
    {"multistep": ms, "ruckig": rk}[impl]()
else:
    t = {"multistep": [], "ruckig": []}
    for _ in range(rounds):
        for name, f in (("multistep", ms), ("ruckig", rk)):
            t0 = time.perf_counter()
            f()
            t[name].append((time.perf_counter() - t0) / n * 1e6)
    print(json.dumps({k: sorted(v)[len(v) // 2] for k, v in t.items()}))
"#;

/// One row of the planning table. Counts are per plan or per call; `None` where not
/// measured (no valgrind, no Python package).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PlanRow {
    pub case: &'static str,
    #[serde(rename = "impl")]
    pub imp: &'static str,
    pub instructions: Option<f64>,
    pub us_per_call: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cases_plan_to_their_durations() {
        let d: Vec<f64> = PLAN_CASES.iter().map(|c| plan_n(c, 1).unwrap()).collect();
        // trapezoid: 0.2 s each way, 96 000 steps of cruise; S-curve: 0.1 s more
        assert!((d[0] - 5.2).abs() < 1e-9, "{d:?}");
        assert!((d[1] - 5.3).abs() < 1e-9, "{d:?}");
        assert_eq!(plan_n(&PLAN_CASES[0], 3).unwrap(), 3.0 * d[0]);
        assert!(PlanCase::by_name("scurve-100k").is_some_and(|c| c.jmax == Some(1e6)));
    }
}
