//! Limits mode with start/end speeds plans every feasible move of its family, dipping below
//! both end speeds when only that fits, and stays time-optimal and within every limit.
//!
//! The reference here is written from the definition of the family, not from the planner:
//! a move is `vs → vp → cruise at vp → ve`, each velocity change a minimum-time one that
//! starts and ends with zero acceleration (and jerk), so it covers `(v0 + v1)/2 · T` steps.
//! The reference finds the peak acceleration of a change by bisection and the best `vp` by
//! a brute-force search over a dense grid on `[0, vmax]`, refined around the best points.
// `!(x <= y)` fails on NaN too, on purpose
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::too_many_arguments)]

use multistep_core::{LimitsMove, Order, PlanError, Profile};
use proptest::prelude::*;

mod common;
use common::limits_ref::{assert_feasible, lim_of, reference, shape, Lim};

fn check_optimal(m: &LimitsMove) -> Result<Option<f64>, TestCaseError> {
    let l = lim_of(m);
    let n = m.steps as f64;
    let want = reference(&l, n, m.start_speed, m.end_speed, m.vmax).map(|r| r.0);
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
    assert!((0.0..74.0277).contains(&vmin), "{vmin}");
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
