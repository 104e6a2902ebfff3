//! The registers the core is loaded with against the core: the edges of
//! `AxisMove::from_profile` (core::int's kernels) are `IntEdgeGenerator`'s, and moves that
//! do not fit the configured widths are refused with a typed error.

mod common;

use common::{params, random_move, Rng, CLOCK};
use multistep_core::int::{IntEdgeGenerator, IntPhaseMove, IntProfile, IntSegment};
use multistep_hdl::{AxisMove, CoreParams, FitError};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// Any phase trapezoid at 50 MHz: either it becomes registers whose every radicand
    /// (sampled inside each piece too) fits the core and whose edges are core::int's, or it
    /// is refused with a typed error naming the piece or the move.
    #[test]
    fn phase_moves_fit_exactly_or_are_refused(
        steps in 1u64..20_000,
        ta in 0u64..3_000_000,
        tb in 0u64..3_000_000,
        tc in 1u64..3_000_000,
        vs in 0u64..50_000,
        ve in 0u64..50_000,
        pick in any::<u64>(),
    ) {
        let m = IntPhaseMove { steps, accel_ticks: ta, cruise_ticks: tb, decel_ticks: tc, start_speed: vs, end_speed: ve };
        let Ok(profile) = IntProfile::phase(&m, CLOCK) else { return Ok(()) };
        let p = CoreParams { radicand_bits: 120, ..params(1) };
        let w = p.widths().unwrap();
        match AxisMove::from_profile(&profile, false, &p) {
            Ok(a) => {
                for pc in &a.pieces {
                    let j = pick % pc.steps;
                    prop_assert!(pc.kernel.radicand(j) >> w.wy == 0);
                    prop_assert!(pc.kernel.dv >> w.wk == 0);
                }
                let want: Vec<u64> = IntEdgeGenerator::new(profile).collect();
                prop_assert_eq!(a.edges(), want);
            }
            Err(e) => prop_assert!(matches!(e, FitError::Piece { .. } | FitError::Move(_)), "{e}"),
        }
    }
}

#[test]
fn random_moves_edges_are_core_int_edges() {
    let p = params(1);
    let mut rng = Rng(7);
    for _ in 0..300 {
        let (m, a) = random_move(&mut rng, &p, 200_000, 400_000);
        let want: Vec<u64> = IntEdgeGenerator::new(m.profile()).collect();
        assert_eq!(a.edges(), want, "{m:?}");
    }
}

#[test]
fn moves_too_wide_for_the_core_are_refused() {
    // a 30 ms trapezoid with coprime phase times and start/end speeds: its radicand needs more than 100 bits
    let m = IntPhaseMove {
        steps: 3_001,
        accel_ticks: 500_001,
        cruise_ticks: 499_999,
        decel_ticks: 500_003,
        start_speed: 1_234,
        end_speed: 777,
    };
    let profile = IntProfile::phase(&m, CLOCK).unwrap();
    let bits = |y: u128| 128 - y.leading_zeros();
    let widest = profile
        .pieces()
        .iter()
        .filter_map(|p| {
            p.kernel()
                .map(|k| bits(k.radicand(0)).max(bits(k.radicand(p.steps - 1))))
        })
        .max()
        .unwrap();
    assert!((101..=128).contains(&widest), "{widest} bits");
    assert!(AxisMove::from_profile(&profile, false, &params(1)).is_ok());
    let narrow = CoreParams {
        radicand_bits: 100,
        ..params(1)
    };
    let e = AxisMove::from_profile(&profile, false, &narrow).unwrap_err();
    assert!(matches!(e, FitError::Piece { .. }), "{e}");
    assert!(e.to_string().contains("radicand"), "{e}");
    // more pieces than slots
    let two = CoreParams {
        pieces: 2,
        ..params(1)
    };
    let e = AxisMove::from_profile(&profile, false, &two).unwrap_err();
    assert!(matches!(e, FitError::Move(_)), "{e}");
    // a 0.3 s segment at odd speeds: core::int runs it on its 256-bit path, the RTL cannot
    let seg = IntSegment {
        v0: 123_457,
        ticks: 15_000_001,
        steps: 2_000_003,
    };
    let wide = IntProfile::segments(&[seg], CLOCK).unwrap();
    assert!(wide.pieces()[0].kernel().is_none());
    let e = AxisMove::from_profile(&wide, false, &params(1)).unwrap_err();
    assert!(e.to_string().contains("128 bits"), "{e}");
}
