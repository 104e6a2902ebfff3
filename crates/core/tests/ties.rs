//! One truth on every edge: a move the integer datapath represents (a trapezoid with whole
//! speeds and whole-tick times, in phase, segment or limits mode) gives, through the float
//! planner's path (`Profile::plan_on_clock` and `EdgeGenerator`, as the command line, the
//! simulator, the TDM model and the Python package run it), exactly the edges of
//! `core::int` (the board's datapath), exact half-tick ties included, on every step.

use multistep_core::int::{
    IntClock, IntEdgeGenerator, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment,
};
use multistep_core::{EdgeGenerator, Family, LimitsMove, Move, PhaseMove, Profile, Segment};
use proptest::prelude::*;

/// The plan path's edges by `next`, checked against `fold` and `fill` (the generator's
/// three loops) on the way.
fn plan_edges(m: &Move<'_>, hz: u64) -> Vec<u64> {
    let p = Profile::plan_on_clock(m, hz as f64).expect("an integer move plans in f64");
    let g = || EdgeGenerator::new(&p, hz as f64).unwrap();
    let by_next: Vec<u64> = g().collect();
    let by_fold = g().fold(Vec::new(), |mut v, e| {
        v.push(e);
        v
    });
    assert_eq!(by_next, by_fold, "next and fold differ");
    let (mut gen, mut buf, mut by_fill) = (g(), [0u64; 61], Vec::new());
    loop {
        let k = gen.fill(&mut buf);
        if k == 0 {
            break;
        }
        by_fill.extend_from_slice(&buf[..k]);
    }
    assert_eq!(by_next, by_fill, "next and fill differ");
    by_next
}

/// Asserts edge-for-edge equality, naming the first step that differs.
fn assert_same(plan: &[u64], int: IntProfile) {
    let want: Vec<u64> = IntEdgeGenerator::new(int).collect();
    assert_eq!(plan.len(), want.len(), "edge count");
    let bad: Vec<(usize, u64, u64)> = (0..want.len())
        .filter(|&k| plan[k] != want[k])
        .map(|k| (k + 1, plan[k], want[k]))
        .take(8)
        .collect();
    assert!(bad.is_empty(), "(step, plan, int): {bad:?}");
}

fn limits(steps: u64, vmax: u64, amax: u64, vs: u64, ve: u64, hz: u64) -> Option<Vec<u64>> {
    let im = IntLimitsMove {
        steps,
        vmax,
        amax,
        start_speed: vs,
        end_speed: ve,
    };
    let int = IntProfile::limits(&im, IntClock::hz(hz)).ok()?;
    let m = LimitsMove {
        start_speed: vs as f64,
        end_speed: ve as f64,
        ..LimitsMove::trapezoid(steps, vmax as f64, amax as f64)
    };
    let plan = plan_edges(&Move::Limits(m), hz);
    assert_same(&plan, int);
    Some(plan)
}

/// The limits-mode move whose cruise falls on an exact half tick every 130 steps: the
/// board takes the earlier tick, and so must the plan path.
#[test]
fn limits_cruise_on_exact_half_ticks_goes_to_the_earlier_tick() {
    let e = limits(1170, 42102, 19_243_484, 0, 0, 50_000_000).unwrap();
    // steps 130, 260, …, 1040 are the ties (the earlier of the two ticks)
    assert_eq!(e[129], 209_083);
    assert_eq!(e[1039], 1_289_792);
}

/// A move at exactly one step a tick plans (its f64 peak rounds above the clock).
#[test]
fn a_limits_move_at_the_clock_rate_plans_and_agrees() {
    let e = limits(1001, 1000, 15_874, 0, 0, 1000).unwrap();
    assert!(e.windows(2).all(|w| w[1] > w[0]), "steps share a tick");
}

/// A cruise at 32 000 steps/s on 50 MHz puts every other step on a half tick, in all three
/// modes.
#[test]
fn half_tick_cruises_agree_in_every_mode() {
    let hz = 50_000_000;
    limits(100_000, 32_000, 1_000_000, 0, 0, hz).unwrap();
    limits(100_000, 32_000, 999_999, 1_000, 3, hz).unwrap();
    let pm = IntPhaseMove {
        steps: 40_000,
        accel_ticks: 6_250_000,
        cruise_ticks: 50_000_000,
        decel_ticks: 6_250_000,
        start_speed: 0,
        end_speed: 0,
    };
    let m = Move::Phase(PhaseMove::new(40_000, Family::Trapezoid, 0.125, 1.0, 0.125));
    assert_same(
        &plan_edges(&m, hz),
        IntProfile::phase(&pm, IntClock::hz(hz)).unwrap(),
    );
}

fn phase_case(
    steps: u64,
    t: (u64, u64, u64),
    vs: u64,
    ve: u64,
    hz: u64,
) -> Result<(), TestCaseError> {
    let pm = IntPhaseMove {
        steps,
        accel_ticks: t.0,
        cruise_ticks: t.1,
        decel_ticks: t.2,
        start_speed: vs,
        end_speed: ve,
    };
    let Ok(int) = IntProfile::phase(&pm, IntClock::hz(hz)) else {
        return Err(TestCaseError::reject("not an integer move"));
    };
    let s = |ticks: u64| ticks as f64 / hz as f64;
    let m = PhaseMove::new(steps, Family::Trapezoid, s(t.0), s(t.1), s(t.2))
        .with_speeds(vs as f64, ve as f64);
    let p = Profile::plan_on_clock(&Move::Phase(m), hz as f64);
    prop_assume!(p.is_ok(), "the float planner refuses it: {:?}", p);
    assert_same(&plan_edges(&Move::Phase(m), hz), int);
    Ok(())
}

fn segments_case(segs: &[(u64, u64, u64)], hz: u64) -> Result<(), TestCaseError> {
    let is: Vec<IntSegment> = segs
        .iter()
        .map(|&(v0, ticks, steps)| IntSegment { v0, ticks, steps })
        .collect();
    let Ok(int) = IntProfile::segments(&is, IntClock::hz(hz)) else {
        return Err(TestCaseError::reject("not an integer move"));
    };
    let fs: Vec<Segment> = segs
        .iter()
        .map(|&(v0, ticks, steps)| Segment {
            v0: v0 as f64,
            duration: ticks as f64 / hz as f64,
            steps,
        })
        .collect();
    let p = Profile::plan_on_clock(&Move::Segments(&fs), hz as f64);
    prop_assume!(p.is_ok(), "the float planner refuses it: {:?}", p);
    assert_same(&plan_edges(&Move::Segments(&fs), hz), int);
    Ok(())
}

/// Clocks with many divisors (ties are common) and odd ones.
fn clock() -> impl Strategy<Value = u64> {
    prop_oneof![
        Just(1_000u64),
        Just(48_000),
        Just(1_000_000),
        Just(50_000_000),
        1_000u64..100_000_000,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 400,
        max_global_rejects: 1 << 16,
        ..ProptestConfig::default()
    })]

    #[test]
    fn limits_moves_agree(
        hz in clock(),
        steps in 1u64..20_000,
        vmax_frac in 1u64..=1000,
        amax in 1u64..50_000_000,
        vs_frac in prop_oneof![Just(0u64), 0u64..=1000],
        ve_frac in prop_oneof![Just(0u64), 0u64..=1000],
    ) {
        // vmax up to the clock (the plan path refuses a move faster than its clock)
        let vmax = (hz.min(200_000) * vmax_frac / 1000).max(1);
        let (vs, ve) = (vmax * vs_frac / 1000, vmax * ve_frac / 1000);
        let r = limits(steps, vmax, amax, vs, ve, hz);
        prop_assume!(r.is_some());
    }

    #[test]
    fn phase_moves_agree(
        hz in clock(),
        steps in 1u64..20_000,
        ta in 0u64..2_000_000,
        tb in 0u64..2_000_000,
        tc in 0u64..2_000_000,
        vs in prop_oneof![Just(0u64), 0u64..5_000],
        ve in prop_oneof![Just(0u64), 0u64..5_000],
    ) {
        let scale = |t: u64| t % (hz * 2).max(1);
        phase_case(steps, (scale(ta), scale(tb), scale(tc)), vs, ve, hz)?;
    }

    #[test]
    fn segment_moves_agree(
        hz in clock(),
        segs in prop::collection::vec((0u64..=1000, 1u64..2_000_000, 1u64..5_000), 1..6),
    ) {
        // start speeds up to half the clock, at most a step every two ticks on average
        let segs: Vec<(u64, u64, u64)> = segs
            .into_iter()
            .map(|(v0, t, n)| {
                // and the end speed 2n/T − v0 not below zero
                let (t, v0) = (t % (hz * 2) + 2, hz / 2 * v0 / 1000);
                let lo = (v0 * t).div_ceil(2 * hz).max(1);
                (v0, t, lo + n % (t / 2 + 1 - lo.min(t / 2)))
            })
            .collect();
        segments_case(&segs, hz)?;
    }
}
