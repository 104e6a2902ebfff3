//! The registers the core is loaded with against the core: the edges of
//! `AxisMove::from_profile` (core::int's kernels) are `IntEdgeGenerator`'s, and moves that
//! do not fit the configured widths are refused with a typed error.

mod common;

use common::{params, random_move, Rng, CLOCK};
use multistep_core::int::{IntEdgeGenerator, IntPhaseMove, IntProfile, IntSegment};
use multistep_hdl::{AxisMove, CoreParams, HdlError};

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
    assert!(matches!(e, HdlError::Piece { .. }), "{e}");
    assert!(e.to_string().contains("radicand"), "{e}");
    // more pieces than slots
    let two = CoreParams {
        pieces: 2,
        ..params(1)
    };
    let e = AxisMove::from_profile(&profile, false, &two).unwrap_err();
    assert!(matches!(e, HdlError::Move(_)), "{e}");
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
