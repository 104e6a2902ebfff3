//! Library code never panics on input: random values, including NaN, ±∞, zero, negative
//! and huge ones, either plan and generate or return a typed error.

use multistep_core::{
    EdgeGenerator, Family, LimitsMove, Move, MoveParams, MoveSpec, PhaseMove, PlanError, Profile,
    Segment,
};
use proptest::prelude::*;

fn wild() -> impl Strategy<Value = Option<f64>> {
    prop_oneof![
        Just(None),
        any::<f64>().prop_map(Some),
        (-1e3f64..1e6).prop_map(Some),
        Just(Some(0.0)),
        Just(Some(f64::NAN)),
        Just(Some(f64::INFINITY)),
        Just(Some(1e300)),
        Just(Some(1e-300)),
    ]
}

fn name() -> impl Strategy<Value = Option<&'static str>> {
    prop_oneof![
        Just(None),
        Just(Some("trapezoid")),
        Just(Some("parabolic")),
        Just(Some("exponential")),
        Just(Some("sine")),
        Just(Some("scurve")),
        Just(Some("scurve4")),
        Just(Some("bogus")),
        Just(Some("")),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4000, ..ProptestConfig::default() })]

    #[test]
    fn any_input_plans_or_errors(
        profile in name(), steps in prop_oneof![Just(None), any::<u64>().prop_map(Some), (0u64..100).prop_map(Some)],
        ta in wild(), tb in wild(), tc in wild(), vs in wild(), ve in wild(),
        vmax in wild(), amax in wild(), jmax in wild(), smax in wild(),
        rho in wild(), phi in wild(), psi in wild(),
        segs in prop::collection::vec((any::<f64>(), any::<f64>(), 0u64..10_000), 0..3),
        clock in prop_oneof![Just(50e6), any::<f64>()],
    ) {
        let segments: Vec<Segment> = segs.into_iter()
            .map(|(v0, duration, steps)| Segment { v0, duration, steps }).collect();
        let params = MoveParams { accel_time: ta, cruise_time: tb, decel_time: tc,
            start_speed: vs, end_speed: ve, vmax, amax, jmax, smax, rho, phi, psi };
        let spec = MoveSpec { profile, steps, params, segments: &segments };
        // on a clock too (whole-tick limits trapezoids): a profile or a typed error
        if let Ok(p) = spec.plan_on_clock(clock) {
            prop_assert!(p.duration() > 0.0 && p.duration().is_finite());
        }
        if let Ok(m) = spec.resolve() {
            check_is_planning_and_playing(&m, clock)?;
        }
        if let Ok(p) = spec.plan() {
            prop_assert!(p.duration() > 0.0 && p.duration().is_finite());
            if let Ok(mut g) = EdgeGenerator::new(p.clone(), clock) {
                let n = p.steps();
                let mut last = 0;
                for e in g.by_ref().take(50) {
                    prop_assert!(e >= last);
                    last = e;
                }
                g.seek(n.saturating_sub(50));
                let tail: Vec<u64> = g.collect();
                prop_assert!(!tail.is_empty());
                prop_assert!(tail.windows(2).all(|w| w[0] <= w[1]));
            }
        }
    }

    #[test]
    fn limits_moves_check_as_they_plan_and_play(
        order in 0usize..3, steps in 1u64..10_000_000,
        vmax in 1.0f64..1e6, amax in 1.0f64..1e8, jmax in 1.0f64..1e10, smax in 1.0f64..1e12,
        vs in 0.0f64..1.0, ve in 0.0f64..1.0,
        clock in prop_oneof![Just(50e6), Just(18e6), 1e3f64..1e9],
    ) {
        let m = match order {
            0 => LimitsMove::trapezoid(steps, vmax, amax),
            1 => LimitsMove::scurve(steps, vmax, amax, jmax),
            _ => LimitsMove::scurve4(steps, vmax, amax, jmax, smax),
        }
        .with_speeds(vs * vmax, ve * vmax);
        check_is_planning_and_playing(&Move::Limits(m), clock)?;
        // the margin the clock check leaves a limits move's peak (10⁻⁹ of vmax)
        for p in [Profile::plan_on_clock(&Move::Limits(m), clock), Profile::limits(&m)].iter().flatten() {
            prop_assert!(p.peak_speed() <= vmax * (1.0 + 1e-12), "{} > {}", p.peak_speed(), vmax);
        }
    }
}

#[test]
fn check_on_clock_is_what_planning_and_playing_give() {
    let segs = [(0.0, 0.1, 50), (1000.0, 0.1, 100)].map(|(v0, duration, steps)| Segment {
        v0,
        duration,
        steps,
    });
    let phase = |family| Move::Phase(PhaseMove::new(10_000, family, 0.1, 0.2, 0.1));
    let moves = [
        Move::Limits(LimitsMove::trapezoid(100_000, 2e4, 1e5)),
        Move::Limits(LimitsMove::scurve(100_000, 2e4, 1e5, 1e6)),
        Move::Limits(LimitsMove::trapezoid(1000, 1000.0, 10_000.0)),
        phase(Family::SCurve4 { phi: 0.3, psi: 0.5 }),
        phase(Family::Sine),
        Move::Segments(&segs),
    ];
    // 1000 Hz: the 1000 steps/s trapezoid runs at its clock, the others exceed it;
    // 1e15 Hz: the long moves exceed the generator's ticks
    for clock in [50e6, 1000.0, 999.0, 1e15, 0.0, f64::NAN] {
        for m in &moves {
            check_is_planning_and_playing(m, clock).unwrap();
        }
    }
    let e = Profile::check_on_clock(&moves[0], 1e15).unwrap_err();
    assert!(matches!(e, PlanError::TooManyTicks { .. }), "{e}");
    let e = Profile::check_on_clock(&moves[0], 999.0).unwrap_err();
    assert!(matches!(e, PlanError::FasterThanClock { .. }), "{e}");
}

/// `Profile::check_on_clock` gives what planning on the clock and playing there give:
/// the same steps, duration and last edge tick, or the same error.
fn check_is_planning_and_playing(m: &Move<'_>, clock: f64) -> Result<(), TestCaseError> {
    let full = Profile::plan_on_clock(m, clock)
        .and_then(|p| EdgeGenerator::new(p, clock))
        .map(|g| {
            (
                g.profile().steps(),
                g.profile().duration(),
                g.last_edge_tick(),
            )
        });
    let check = Profile::check_on_clock(m, clock).map(|c| (c.steps, c.duration, c.last_edge_tick));
    prop_assert_eq!(
        check.map_err(|e| e.to_string()),
        full.map_err(|e| e.to_string()),
        "{:?} at {} Hz",
        m,
        clock
    );
    Ok(())
}
