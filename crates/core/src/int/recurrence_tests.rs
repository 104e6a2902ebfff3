//! The recurrence against the closed form, and what it costs.

use super::recurrence::{check, peak_load, Recurrence, RecurrenceClocks, RecurrenceCount};
use super::{IntClock, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment};
use proptest::prelude::*;

const HZ: u64 = 50_000_000;

fn phase(steps: u64, ticks: [u64; 3], vs: u64, ve: u64, hz: u64) -> Option<IntProfile> {
    let m = IntPhaseMove {
        steps,
        accel_ticks: ticks[0],
        cruise_ticks: ticks[1],
        decel_ticks: ticks[2],
        start_speed: vs,
        end_speed: ve,
    };
    IntProfile::phase(&m, IntClock::hz(hz)).ok()
}

fn exact(p: &IntProfile) -> Result<RecurrenceCount, TestCaseError> {
    check(p).map_err(|i| TestCaseError::fail(format!("step {i} differs: {p:?}")))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// Phase-mode trapezoids, rests and start/end speeds, at 50 MHz and odd clocks.
    #[test]
    fn phase_moves_are_the_closed_forms(
        steps in 1u64..30_000, t in proptest::array::uniform3(0u64..4_000_000),
        vs in 0u64..20_000, ve in 0u64..20_000, odd in 1_000u64..60_000_000, at50 in any::<bool>(),
    ) {
        let hz = if at50 { HZ } else { odd | 1 };
        if let Some(p) = phase(steps, t, vs, ve, hz) {
            let c = exact(&p)?;
            prop_assert_eq!(c.steps, p.steps());
        }
    }

    /// Moves with many steps exactly on a half tick (power-of-two phase times at 2^24 Hz,
    /// whose exact times are binary fractions): the tie goes to the earlier tick.
    #[test]
    fn half_tick_ties_go_to_the_earlier_tick(
        steps in 1u64..48, la in 1u32..22, lc in 1u32..22, lw in 2u32..24,
        vs in 0u64..200, ve in 0u64..200,
    ) {
        let (ta, tc, w) = (1u64 << la, 1u64 << lc, 1u64 << lw);
        prop_assume!(w >= ta + tc && (w - ta - tc) % 2 == 0);
        if let Some(p) = phase(steps, [ta, (w - ta - tc) / 2, tc], vs, ve, 1 << 24) {
            exact(&p)?;
        }
    }

    /// Limits-mode trapezoids (vmax, amax, start and end speeds).
    #[test]
    fn limits_moves_are_the_closed_forms(
        steps in 1u64..50_000, vmax in 1u64..200_000, amax in 1u64..5_000_000,
        vs in 0u64..200_000, ve in 0u64..200_000,
    ) {
        let m = IntLimitsMove {
            steps, vmax, amax, start_speed: vs.min(vmax), end_speed: ve.min(vmax),
        };
        if let Ok(p) = IntProfile::limits(&m, IntClock::hz(HZ)) {
            exact(&p)?;
        }
    }

    /// Seed 000's segment chains.
    #[test]
    fn segment_chains_are_the_closed_forms(
        segs in proptest::collection::vec((0u64..3_000, 1u64..2_000_000), 1..4),
        steps in 1u64..5_000,
    ) {
        let segs: Vec<IntSegment> =
            segs.iter().map(|&(v0, ticks)| IntSegment { v0, ticks, steps }).collect();
        if let Ok(p) = IntProfile::segments(&segs, IntClock::hz(HZ)) {
            exact(&p)?;
        }
    }
}

/// The work of an all-ramp move from rest to 100 k steps/s and back at 50 MHz: 500
/// ticks a step at the top.
fn ramp_100k() -> IntProfile {
    // 0 → 100 k steps/s in 0.1 s: 5 000 steps up, 5 000 down
    phase(10_000, [5_000_000, 0, 5_000_000], 0, 0, HZ).unwrap()
}

#[test]
fn a_ramp_takes_the_closed_form_only_near_rest() {
    let p = ramp_100k();
    let c = check(&p).unwrap();
    // the two first steps, and walks abandoned where the period changes fastest: from
    // rest and into it
    assert!(c.closed < 120, "{c:?}");
    let mut r = Recurrence::new(&p);
    let slow: Vec<(u64, u64)> = core::iter::from_fn(|| {
        let before = r.tally().closed;
        r.next().map(|e| (e, r.tally().closed - before))
    })
    .collect::<Vec<_>>()
    .windows(2)
    .filter(|w| w[1].1 == 1)
    .map(|w| (w[1].0, w[1].0 - w[0].0))
    .collect();
    // every closed-form step but the first two comes after a period of over 5 000 ticks
    // (below 10 k steps/s) or on a piece's first or last tick
    let bound = |e: u64| p.pieces().iter().any(|q| e == q.t0 || e == q.t0 + q.dur);
    assert!(
        slow.iter()
            .skip(1)
            .all(|&(e, period)| period > 5_000 || bound(e)),
        "{slow:?}"
    );
    assert!(slow.iter().any(|&(e, period)| period <= 5_000 && bound(e)));
    assert!(c.by_moves[0] + c.by_moves[1] + c.by_moves[2] > 9 * (c.steps - c.closed) / 10);
}

#[test]
fn one_calculator_feeds_over_32_axes_at_100k_steps_a_second() {
    // every axis on the same all-ramp move at once, FIFOs of 16 periods
    let p = ramp_100k();
    let mut r = Recurrence::new(&p);
    let peak = peak_load::<16>(&mut r, &RecurrenceClocks::MODEL);
    assert!(
        peak > 0.0 && peak < 1.0 / 32.0,
        "peak load {peak}: {} axes",
        1.0 / peak
    );
    let show = |name: &str, c: &RecurrenceCount| {
        let per_step = c.clocks(&RecurrenceClocks::MODEL) as f64 / c.steps as f64;
        std::println!("{name}: {c:?}\n  {per_step:.2} clocks a step");
    };
    show("all-ramp trapezoid, 10 000 steps", r.tally());
    std::println!("  peak load {peak:.5}: {:.1} axes", 1.0 / peak);
    // a long cruise: the walk's usual case
    let long = phase(1_000_000, [50_000_000, 400_000_000, 50_000_000], 0, 0, HZ).unwrap();
    show("trapezoid, 1 M steps", &check(&long).unwrap());
}
