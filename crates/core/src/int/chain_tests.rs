//! The forward-difference chain against the float edge generator (`multistep plan`'s
//! edges) on random S-curve and scurve4 moves, the per-step recurrence on the chain
//! (chain_recurrence.rs) against both, and the chain's width check.

extern crate std;

use super::chain::{pieces, ChainEdges, ChainError, ChainWidths};
use crate::edges::edges;
use crate::profile::{Family, LimitsMove, Move, PhaseMove, Profile};
use proptest::prelude::*;
use std::vec::Vec;

const F: u64 = 50_000_000;
const WIDE: ChainWidths = ChainWidths::uniform(510);

fn chain_equals_plan(m: &Move<'_>) -> Result<(), TestCaseError> {
    let profile = Profile::plan_on_clock(m, F as f64).unwrap();
    let want: Vec<u64> = edges(m, F as f64).unwrap().collect();
    let got: Vec<u64> = ChainEdges::new(profile.clone(), F, WIDE).unwrap().collect();
    prop_assert_eq!(got.len(), want.len());
    if let Some(i) = got.iter().zip(&want).position(|(a, b)| a != b) {
        prop_assert!(false, "step {}: chain {} plan {}", i + 1, got[i], want[i]);
    }
    let mut r = ChainEdges::new(profile, F, WIDE).unwrap().by_recurrence();
    let by_recurrence: Vec<u64> = r.by_ref().collect();
    if let Some(i) = by_recurrence.iter().zip(&want).position(|(a, b)| a != b) {
        prop_assert!(
            false,
            "step {}: recurrence {} plan {}",
            i + 1,
            by_recurrence[i],
            want[i]
        );
    }
    prop_assert_eq!(by_recurrence.len(), want.len());
    prop_assert_eq!(r.recurrence_tally().unwrap().steps, want.len() as u64);
    Ok(())
}

fn family() -> impl Strategy<Value = Family> {
    prop_oneof![
        (0.05f64..=0.5).prop_map(|phi| Family::SCurve { phi }),
        (0.05f64..=0.5, 0.05f64..=0.5).prop_map(|(phi, psi)| Family::SCurve4 { phi, psi }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn phase_moves_equal_plan(
        steps in 20u64..1500,
        family in family(),
        (ta, tb, tc) in (0.5e-3f64..6e-3, 0.0f64..3e-3, 0.5e-3f64..6e-3),
        (vs, ve) in (0.0f64..20_000.0, 0.0f64..20_000.0),
        speeds in any::<bool>(),
    ) {
        let mut m = PhaseMove::new(steps, family, ta, tb, tc);
        if speeds {
            m = m.with_speeds(vs, ve);
        }
        let m = Move::Phase(m);
        prop_assume!(Profile::plan_on_clock(&m, F as f64).is_ok());
        chain_equals_plan(&m)?;
    }

    #[test]
    fn limits_moves_equal_plan(
        steps in 5u64..1500,
        fourth in any::<bool>(),
        vmax in 20_000.0f64..150_000.0,
        amax in 2e7f64..2e8,
        jmax in 2e10f64..2e12,
        smax in 2e13f64..2e16,
        (vs, ve) in (0.0f64..1.0, 0.0f64..1.0),
    ) {
        let m = if fourth {
            LimitsMove::scurve4(steps, vmax, amax, jmax, smax)
        } else {
            LimitsMove::scurve(steps, vmax, amax, jmax)
        }
        .with_speeds(vs * vmax * 0.5, ve * vmax * 0.5);
        let m = Move::Limits(m);
        prop_assume!(Profile::plan_on_clock(&m, F as f64).is_ok());
        chain_equals_plan(&m)?;
    }
}

/// A limit narrower than a piece needs is refused with the piece and both widths.
#[test]
fn too_wide_pieces_are_refused() {
    let m = Move::Phase(PhaseMove::new(
        400,
        Family::SCurve4 { phi: 0.5, psi: 0.5 },
        1e-3,
        1e-3,
        1e-3,
    ));
    let p = Profile::plan_on_clock(&m, F as f64).unwrap();
    let need = ChainEdges::new(p.clone(), F, WIDE).unwrap().widths();
    assert!(need.max() > 64);
    match ChainEdges::new(p.clone(), F, ChainWidths::uniform(64)) {
        Err(ChainError::TooWide { needed, limit, .. }) => {
            assert_eq!(limit, ChainWidths::uniform(64));
            assert!(!needed.fits(&limit));
        }
        other => panic!("{other:?}"),
    }
    // exactly the widths needed are enough
    assert!(ChainEdges::new(p, F, need).is_ok());
}

/// Widths on typical moves (printed with `--nocapture` for the docs): every piece fits
/// 512 bits and the reduced scale K is the widest part of R.
#[test]
fn widths_of_typical_moves() {
    let s4 = Family::SCurve4 { phi: 0.5, psi: 0.5 };
    let s3 = Family::SCurve { phi: 0.5 };
    let cases = [
        (
            "scurve4 0.1/0.3/0.1 s to 100k",
            PhaseMove::new(40_000, s4, 0.1, 0.3, 0.1),
        ),
        (
            "scurve 0.1/0.3/0.1 s to 100k",
            PhaseMove::new(40_000, s3, 0.1, 0.3, 0.1),
        ),
        (
            "scurve4 1/8/1 s to 100k",
            PhaseMove::new(900_000, s4, 1.0, 8.0, 1.0),
        ),
        (
            "scurve 1/8/1 s to 100k",
            PhaseMove::new(900_000, s3, 1.0, 8.0, 1.0),
        ),
        (
            "scurve4 0.1/0.3/0.1 s, 5k..100k..2k",
            PhaseMove::new(40_000, s4, 0.1, 0.3, 0.1).with_speeds(5000.0, 2000.0),
        ),
    ];
    for (name, m) in cases {
        let p = Profile::plan_on_clock(&Move::Phase(m), F as f64).unwrap();
        let w = pieces(&p, F).fold(ChainWidths::default(), |w, c| w.union(c.unwrap().widths));
        std::eprintln!("{name}: {w:?}");
        assert!(w.max() <= 510 && w.r >= w.k && w.k > 0, "{name}: {w:?}");
    }
    let l = LimitsMove::scurve4(200_000, 100_000.0, 2e6, 1e8, 1e10);
    let p = Profile::plan_on_clock(&Move::Limits(l), F as f64).unwrap();
    let w = pieces(&p, F).fold(ChainWidths::default(), |w, c| w.union(c.unwrap().widths));
    std::eprintln!("limits scurve4 200k steps, 100k/2e6/1e8/1e10: {w:?}");
    assert!(w.max() <= 510);
}

/// One calculator running the recurrence on chains keeps more than 32 axes fed, each on an
/// all-ramp S-curve from rest to 100 k steps/s and back (10 000 steps in 0.2 s), FIFOs of
/// 16 periods (a model: `RecurrenceClocks::CHAIN_MODEL`).
#[test]
fn one_calculator_feeds_over_32_scurve_axes_at_100k_steps_a_second() {
    use super::recurrence::{peak_load, RecurrenceClocks};
    for family in [
        Family::SCurve { phi: 0.5 },
        Family::SCurve4 { phi: 0.5, psi: 0.5 },
    ] {
        let m = Move::Phase(PhaseMove::new(10_000, family, 0.1, 0.0, 0.1));
        let p = Profile::plan_on_clock(&m, F as f64).unwrap();
        let mut edges = ChainEdges::new(p, F, WIDE).unwrap().by_recurrence();
        let peak = peak_load::<16>(&mut edges, &RecurrenceClocks::CHAIN_MODEL);
        assert!(
            peak > 0.0 && peak < 1.0 / 32.0,
            "{family:?}: peak load {peak}"
        );
        let c = edges.recurrence_tally().unwrap();
        std::println!(
            "{family:?}: {c:?}\n  peak load {peak:.5}: {:.1} axes",
            1.0 / peak
        );
    }
}
