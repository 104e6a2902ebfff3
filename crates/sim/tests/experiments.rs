//! The seeds' experiments: the calibration holds, the parabolic curve beats the trapezoid in
//! both of seed 001's tables, and seed 000's two-axis run stays within its ±8 microsteps.

use multistep_sim::experiments::{curve_limits, two_axis, CurveLimitsSetup, FAMILIES};

#[test]
fn curve_limits_reproduce_seed_001_ordering() {
    let setup = CurveLimitsSetup::seed001().unwrap();
    let r = curve_limits(&setup).unwrap();
    let json = serde_json::to_value(&r).unwrap();
    for key in ["max_angle_deg", "min_time_360_ms"] {
        for fam in FAMILIES {
            assert!(json[key][fam].as_f64().unwrap().is_finite(), "{key}.{fam}");
        }
    }
    // The damping ratio is the motor file's, not fitted, and in the range 0.05–0.3.
    assert!((0.05..=0.3).contains(&r.damping_ratio));
    // Calibration: the trapezoid's limit is the calibration angle, to the bisection's 1°.
    let trap = r.max_angle_deg["trapezoid"];
    assert!((810.0..811.0).contains(&trap), "{trap}");
    // Seed 001's finding: parabolic beats trapezoid in both tables.
    assert!(r.max_angle_deg["parabolic"] > trap);
    assert!(r.min_time_360_ms["parabolic"] < r.min_time_360_ms["trapezoid"]);
    // DESIGN.md's exponential has the lowest peak speed of the three: it is not the worst.
    assert!(r.max_angle_deg["exponential"] > trap);
    // Bisection assumes pass/fail is monotone; spot-check below each angle limit.
    let mut m = setup.motor.clone();
    m.load_inertia = r.load_inertia;
    for (fam, &a) in &r.max_angle_deg {
        for below in [a - 10.0, a / 2.0] {
            let run = setup.run(&m, fam, below, setup.period_s, true).unwrap();
            assert!(!run.lost, "{fam}: {below}° loses although {a}° does not");
        }
    }
    // Each limit is a real edge: the move one resolution step past it loses a step.
    for cells in [&r.cells_max_angle, &r.cells_min_time] {
        for (fam, c) in cells.iter() {
            assert!(c.loss_past_limit_ms.is_some(), "{fam}");
            assert!(
                c.error_max_deg < 3.6,
                "{fam}: no loss at the limit means |error| < 2 full steps"
            );
        }
    }
}

#[test]
fn two_axis_run_stays_within_seed_000s_bound() {
    let r = two_axis(1e-6).unwrap();
    assert_eq!(r.axes.len(), 2);
    assert_eq!((r.axes[0].steps, r.axes[1].steps), (2400, 1800));
    for ax in &r.axes {
        assert_eq!(ax.lost_steps, 0);
        assert!(ax.peak_following_error_steps > 1.0, "{ax:?}");
        assert!(
            ax.peak_following_error_steps <= r.paper_bound_steps,
            "{ax:?}"
        );
    }
    // The longer move reaches the higher speed and lags more.
    assert!(r.axes[0].peak_following_error_steps > r.axes[1].peak_following_error_steps);
}
