//! Library code never panics on input: random values, including NaN, ±∞, zero, negative
//! and huge ones, either plan and generate or return a typed error.

use multistep_core::{EdgeGenerator, MoveParams, MoveSpec, Segment};
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
}
