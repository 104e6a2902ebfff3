//! The TDM engine with a calculator that finds periods by the per-step recurrence: each
//! period costs what the recurrence spends on it, the edges stay the plan's, and one
//! calculator keeps far more axes fed than by the closed form alone.

use multistep_core::int::recurrence::{check, RecurrenceClocks};
use multistep_core::int::{
    ChainEdges, ChainWidths, IntClock, IntEdgeGenerator, IntLimitsMove, IntPhaseMove, IntProfile,
};
use multistep_core::tdm::{Axis, Board, Latencies, Report, TdmConfig};
use multistep_core::{edges, Family, Move, PhaseMove, Profile};
use proptest::prelude::*;

const HZ: u64 = 50_000_000;

fn cfg(depth: usize) -> TdmConfig {
    TdmConfig {
        clock_hz: HZ as f64,
        fifo_depth: depth,
        latencies: Latencies::RADIX4,
        ..TdmConfig::default()
    }
}

fn phase(steps: u64, ticks: [u64; 3], vs: u64, ve: u64) -> Option<IntProfile<3>> {
    let m = IntPhaseMove {
        steps,
        accel_ticks: ticks[0],
        cruise_ticks: ticks[1],
        decel_ticks: ticks[2],
        start_speed: vs,
        end_speed: ve,
    };
    IntProfile::<3>::phase_in(&m, IntClock::hz(HZ)).ok()
}

/// From rest to 100 k steps/s in 0.1 s and back, no cruise: the calculator's worst move
/// (every step a ramp's, the fastest at 500 ticks a period).
fn ramp_100k() -> IntProfile<3> {
    phase(10_000, [5_000_000, 0, 5_000_000], 0, 0).unwrap()
}

/// Runs `profiles` started together, each axis by the recurrence at `clocks`; the report
/// and each axis's rises from the start tick.
fn run(
    profiles: &[IntProfile<3>],
    clocks: RecurrenceClocks,
    depth: usize,
) -> (Report, Vec<Vec<u64>>) {
    let axes: Vec<Axis> = profiles
        .iter()
        .map(|p| Axis::recurrent(p.clone(), HZ, clocks).unwrap())
        .collect();
    run_axes(axes, depth)
}

/// Runs `axes` started together: the report and each axis's rises from the start tick.
fn run_axes(mut axes: Vec<Axis>, depth: usize) -> (Report, Vec<Vec<u64>>) {
    let mut rises = vec![Vec::new(); axes.len()];
    let board = Board::new(cfg(depth), &mut axes).unwrap();
    let start = board.start_tick();
    let r = board.run(|p| rises[p.axis].push(p.rise - start));
    assert_eq!(r.start_tick, start);
    (r, rises)
}

fn int_edges(p: &IntProfile<3>) -> Vec<u64> {
    IntEdgeGenerator::<&IntProfile<3>, 3>::new(p).collect()
}

/// Every axis's rises are its plan's edges; nothing ran late.
fn assert_exact(r: &Report, profiles: &[IntProfile<3>], rises: &[Vec<u64>]) {
    assert_eq!(r.underruns, 0, "{r:?}");
    for (m, (p, got)) in profiles.iter().zip(rises).enumerate() {
        assert!(*got == int_edges(p), "axis {m}: the edges differ");
    }
}

/// The clocks the recurrence spends on the whole of `p` (and it gives the plan's edges).
fn clocks_of(p: &IntProfile<3>, c: &RecurrenceClocks) -> u64 {
    check(p).unwrap().clocks(c)
}

#[test]
fn the_calculator_is_busy_for_exactly_the_recurrences_clocks() {
    // three different moves: the busy cycles are the sum of what each recurrence spent,
    // and the group starts when the prefill's periods, one after the other, are done
    let profiles: Vec<IntProfile<3>> = [
        (4_000, [2_000_000, 1_000_000, 2_000_000], 0, 0),
        (2_500, [1_000_000, 3_000_000, 500_000], 2_000, 0),
        (900, [300_000, 0, 700_000], 0, 500),
    ]
    .iter()
    .map(|&(n, t, vs, ve)| phase(n, t, vs, ve).unwrap())
    .collect();
    let c = RecurrenceClocks::MODEL;
    let (r, rises) = run(&profiles, c, 16);
    assert_exact(&r, &profiles, &rises);
    let total: u64 = profiles.iter().map(|p| clocks_of(p, &c)).sum();
    assert_eq!(r.busy_cycles, total);
    // the prefill: the first two steps of each move by the closed form, the rest by jumps
    let mut prefill = 0;
    for p in &profiles {
        let mut a = vec![Axis::recurrent(p.clone(), HZ, c).unwrap()];
        let one = Board::new(cfg(16), &mut a).unwrap().start_tick();
        assert!(one > 2 * c.closed as u64, "{one}");
        prefill += one;
    }
    assert_eq!(r.start_tick, prefill);
}

#[test]
fn one_calculator_feeds_32_axes_on_the_worst_move_at_100k_steps_a_second() {
    // every axis on the all-ramp move at once (all at their fastest together), FIFOs of
    // 16 periods, 50 MHz: the recurrence's clocks of the Verilog unit (5 to the jump's
    // test, one a tick moved), and of ms_core with its digit-serial unit (RECUR = 1,
    // MR = 13: select, the prediction, 8 to the test, the answer and the FIFO write: 12,
    // the co-simulation's figure)
    let p = ramp_100k();
    let core = RecurrenceClocks {
        jump: 12,
        ..RecurrenceClocks::MODEL
    };
    for (name, c) in [
        ("MODEL", RecurrenceClocks::MODEL),
        ("ms_core, MR = 13", core),
    ] {
        let profiles = vec![p.clone(); 32];
        let (r, rises) = run(&profiles, c, 16);
        assert_exact(&r, &profiles, &rises);
        println!(
            "{name}: 32 axes, calculator busy {:.1} % of the run, least slack {} ticks",
            100.0 * r.calculator_utilization(),
            r.min_slack_ticks
        );
        // how many it keeps fed: the most axes (of the engine's 64) with no underrun
        let most = (32..=64)
            .take_while(|&k| run(&vec![p.clone(); k], c, 16).0.underruns == 0)
            .last()
            .unwrap();
        println!("{name}: {most} axes at 100 k steps/s without an underrun");
    }
    // the closed form alone (51 clocks a period) cannot: 32 axes underrun
    let closed = RecurrenceClocks::MODEL.closed;
    let closed_only = RecurrenceClocks {
        jump: closed,
        tick: 0,
        closed,
    };
    let (r, _) = run(&vec![p; 32], closed_only, 16);
    assert!(r.underruns > 0, "{r:?}");
}

#[test]
fn one_calculator_feeds_over_32_s_curve_axes_on_chains_at_100k_steps_a_second() {
    // scurve and scurve4 from rest to 100 k steps/s and back with no cruise, every axis at
    // once; the chain's jump taken as ten products through one pipelined multiplier
    // (`CHAIN_MODEL`, no chain-jump unit built), a tick a clock
    for family in [
        Family::SCurve { phi: 0.5 },
        Family::SCurve4 { phi: 0.5, psi: 0.5 },
    ] {
        let m = Move::Phase(PhaseMove::new(10_000, family, 0.1, 0.0, 0.1));
        let p = Profile::plan_on_clock(&m, HZ as f64).unwrap();
        let plan: Vec<u64> = edges(&m, HZ as f64).unwrap().collect();
        let axes = |k: usize| -> Vec<Axis> {
            let chain = ChainEdges::new(p.clone(), HZ, ChainWidths::uniform(510)).unwrap();
            (0..k)
                .map(|_| Axis::chain_recurrent(chain.clone(), RecurrenceClocks::CHAIN_MODEL))
                .collect::<Result<_, _>>()
                .unwrap()
        };
        let (r, rises) = run_axes(axes(32), 16);
        assert_eq!(r.underruns, 0, "{family:?}: {r:?}");
        assert!(
            rises.iter().all(|e| *e == plan),
            "{family:?}: the edges differ"
        );
        println!(
            "{family:?}: 32 axes, calculator busy {:.1} % of the run",
            100.0 * r.calculator_utilization()
        );
        // the most axes it keeps fed: a minute and a half of debug build, so on request
        if std::env::var_os("MULTISTEP_TDM_MOST_AXES").is_some() {
            let most = (33..=64)
                .take_while(|&k| run_axes(axes(k), 16).0.underruns == 0)
                .last()
                .unwrap_or(32);
            println!("{family:?}: {most} axes without an underrun");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Random phase and limits moves on 1 to 6 axes: the plan's edges, at the recurrence's
    /// costs and at a slow calculator's (a jump of 40 clocks, 4 a tick moved).
    #[test]
    fn random_moves_keep_the_plans_edges(
        moves in proptest::collection::vec(
            (1u64..3_000, 1u64..60_000, 1u64..2_000_000, 0u64..3_000, any::<bool>()), 1..6),
        slow in any::<bool>(),
    ) {
        let profiles: Vec<IntProfile<3>> = moves
            .iter()
            .filter_map(|&(steps, vmax, amax, vs, lim)| {
                if lim {
                    let m = IntLimitsMove {
                        steps, vmax, amax, start_speed: vs.min(vmax), end_speed: 0,
                    };
                    IntProfile::<3>::limits_in(&m, IntClock::hz(HZ)).ok()
                } else {
                    let t = 1 + HZ * steps / vmax;
                    phase(steps, [t / 3, t / 3, t / 3 + 1], 0, vs.min(vmax))
                }
            })
            .collect();
        prop_assume!(!profiles.is_empty());
        let c = if slow {
            RecurrenceClocks { jump: 40, tick: 4, closed: 51 }
        } else {
            RecurrenceClocks::MODEL
        };
        let (r, rises) = run(&profiles, c, 16);
        // a slow calculator may fall behind; then the edges shift late, never early
        if r.underruns == 0 {
            for (p, got) in profiles.iter().zip(&rises) {
                prop_assert!(*got == int_edges(p));
            }
        } else {
            for (p, got) in profiles.iter().zip(&rises) {
                let plan = int_edges(p);
                prop_assert_eq!(got.len(), plan.len());
                prop_assert!(got.iter().zip(&plan).all(|(g, e)| g >= e));
            }
        }
    }
}
