//! The registers the core is loaded with against the core: the edges of
//! `AxisMove::from_profile` (core::int's kernels) are `IntEdgeGenerator`'s, and moves that
//! do not fit the configured widths are refused with a typed error.

mod common;

use common::{params, random_move, Rng, CLOCK};
use multistep_core::int::{IntEdgeGenerator, IntPhaseMove, IntProfile};
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
    // a 0.3 s trapezoid: its radicand needs more than 100 bits
    let m = IntPhaseMove {
        steps: 30_000,
        accel_ticks: 5_000_000,
        cruise_ticks: 5_000_000,
        decel_ticks: 5_000_000,
        start_speed: 0,
        end_speed: 0,
    };
    let profile = IntProfile::phase(&m, CLOCK).unwrap();
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
}
