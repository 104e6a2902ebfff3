//! The predicted steps on curved pieces (the tick extrapolated from the last steps' times
//! and proved at its half ticks) give the same edges as the generator without them (every
//! such step by safeguarded Newton), edge for edge, through every way of reading edges:
//! `next`, `fold`, `fill`, `seek` and the period extremes.

mod common;

use common::strategies::{clock, family};
use multistep_core::{EdgeGenerator, Family, LimitsMove, Move, Order, PhaseMove, Profile, Segment};
use proptest::prelude::*;

/// Least and greatest period (the first from tick 0) and the last edge.
fn extremes(edges: &[u64]) -> Option<(u64, u64, u64)> {
    let mut last = 0;
    let (mut lo, mut hi) = (u64::MAX, 0);
    for &e in edges {
        lo = lo.min(e - last);
        hi = hi.max(e - last);
        last = e;
    }
    (!edges.is_empty()).then_some((lo, hi, last))
}

/// Every way of reading `p`'s edges at `f` with prediction equals the reference.
fn check(p: &Profile, f: f64, chunk: usize, seek: u64) -> Result<(), TestCaseError> {
    let reference = EdgeGenerator::new(p, f).unwrap().without_prediction();
    let want: Vec<u64> = reference.collect();
    let gen = || EdgeGenerator::new(p, f).unwrap();
    let first_diff = |got: &[u64]| got.iter().zip(&want).position(|(a, b)| a != b);

    let folded: Vec<u64> = gen().collect();
    prop_assert_eq!(folded.len(), want.len());
    prop_assert_eq!(first_diff(&folded), None, "fold");

    // a `for` loop calls `next` (not `fold`)
    let mut stepped = Vec::with_capacity(want.len());
    for e in gen() {
        stepped.push(e);
    }
    prop_assert_eq!(stepped.len(), want.len());
    prop_assert_eq!(first_diff(&stepped), None, "next");

    let mut g = gen();
    let mut filled = Vec::with_capacity(want.len());
    let mut buf = vec![0u64; chunk];
    loop {
        let k = g.fill(&mut buf);
        if k == 0 {
            break;
        }
        filled.extend_from_slice(&buf[..k]);
    }
    prop_assert_eq!(filled.len(), want.len());
    prop_assert_eq!(first_diff(&filled), None, "fill({})", chunk);

    prop_assert_eq!(gen().period_extremes(0), extremes(&want));
    // in parts of `chunk` edges, each part's first period from the last part's last edge
    let mut g = gen();
    let (mut lo, mut hi, mut last) = (u64::MAX, 0, 0);
    while let Some((a, b, l)) = g.period_extremes_for(last, chunk as u64) {
        (lo, hi, last) = (lo.min(a), hi.max(b), l);
    }
    if let Some(x) = extremes(&want) {
        prop_assert_eq!((lo, hi, last), x);
    }

    // seek to a step, then read a few edges
    let mut g = gen();
    let start = 1 + seek % want.len().max(1) as u64;
    g.seek(start);
    let k = g.fill(&mut buf);
    let from = start as usize - 1;
    prop_assert_eq!(
        &buf[..k],
        &want[from..(from + k).min(want.len())],
        "seek {}",
        start
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn phase_moves_predicted_equal_newton(
        fam in family(), steps in 1u64..40_000, ta in 1e-3f64..0.5, tb in prop_oneof![Just(0.0), 1e-3f64..0.5],
        tc in 1e-3f64..0.5, vs in prop_oneof![Just(0.0), 0.0f64..2e4],
        ve in prop_oneof![Just(0.0), 0.0f64..2e4], f in clock(), chunk in 1usize..5000,
        seek in any::<u64>(),
    ) {
        let m = PhaseMove { steps, accel_time: ta, cruise_time: tb, decel_time: tc,
                            start_speed: vs, end_speed: ve, family: fam };
        // both the plain profile and the one planned on the clock (with its integer move)
        if let Ok(p) = Profile::phase(&m) {
            check(&p, f, chunk, seek)?;
        }
        if let Ok(p) = Profile::plan_on_clock(&Move::Phase(m), f) {
            check(&p, f, chunk, seek)?;
        }
    }

    #[test]
    fn limits_moves_predicted_equal_newton(
        order in prop_oneof![Just(Order::Trapezoid), Just(Order::SCurve), Just(Order::SCurve4)],
        steps in 1u64..40_000, vmax in 100.0f64..1e5, amax in 1e3f64..1e7,
        jmax in 1e5f64..1e10, smax in 1e7f64..1e14, fs in 0.0f64..1.0, fe in 0.0f64..1.0,
        f in clock(), chunk in 1usize..5000, seek in any::<u64>(),
    ) {
        let m = LimitsMove { steps, order, vmax, amax, jmax: Some(jmax), smax: Some(smax),
                             start_speed: fs * fs * vmax, end_speed: fe * fe * vmax };
        if let Ok(p) = Profile::plan(&Move::Limits(m)) {
            check(&p, f, chunk, seek)?;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// One constant-acceleration segment, speeding up or slowing down: its least and
    /// greatest period sit among the many periods within a tick or two of the run's end
    /// periods, where the period extremes compare only a head and a tail of the run.
    #[test]
    fn constant_acceleration_runs_give_their_extremes(
        steps in 100u64..60_000, v0 in 0.0f64..2e5, ve in 0.0f64..2e5, f in clock(),
        chunk in 1usize..5000, seek in any::<u64>(),
    ) {
        prop_assume!(v0 + ve > 1.0);
        let seg = [Segment { v0, duration: 2.0 * steps as f64 / (v0 + ve), steps }];
        if let Ok(p) = Profile::segments(&seg) {
            check(&p, f, chunk, seek)?;
        }
    }
}

/// The bench's all-ramp moves (2·10⁵ steps in 1 s up, 1 s down, at 50 MHz), whose steps
/// are nearly all predicted.
#[test]
fn all_ramp_family_moves_predicted_equal_newton() {
    for family in [
        Family::Parabolic,
        Family::Exponential { rho: 0.25 },
        Family::Sine,
        Family::SCurve { phi: 0.5 },
        Family::SCurve4 { phi: 0.5, psi: 0.5 },
    ] {
        let m = PhaseMove {
            steps: 200_000,
            accel_time: 1.0,
            cruise_time: 0.0,
            decel_time: 1.0,
            start_speed: 0.0,
            end_speed: 0.0,
            family,
        };
        let p = Profile::plan_on_clock(&Move::Phase(m), 50e6).unwrap();
        check(&p, 50e6, 4096, 123_457).unwrap_or_else(|e| panic!("{family:?}: {e}"));
    }
}
