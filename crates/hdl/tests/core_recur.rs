//! `ms_core` with the per-step recurrence (`RECUR = 1`) in Icarus Verilog: every edge is
//! the plan's, and every period costs the clocks the core TDM model charges for it
//! (`tdm::Axis::recurrent` at `Widths::recurrence_clocks`): the calculator's cycles, the
//! group's start and the scheduler's run all match. Needs `iverilog`.

mod common;

use common::host::half_interval_falls;
use common::{Rng, CLOCK, HZ};
use multistep_core::int::recurrence::{CountedEdges, Recurrence, RecurrenceClocks};
use multistep_core::int::{IntEdgeGenerator, IntLimitsMove, IntPhaseMove, IntProfile};
use multistep_core::tdm::{Axis, Board, TdmConfig};
use multistep_core::{Family, Move, PhaseMove, Profile};
use multistep_hdl::link::RecurRegs;
use multistep_hdl::simulator::Simulator;
use multistep_hdl::tools::{simulate_in, SimOutput};
use multistep_hdl::{Arch, AxisMove, CoreParams, Design};

/// A move of up to three quadratic pieces, in the two forms the test needs.
struct Planned {
    full: IntProfile,
    three: IntProfile<3>,
}

fn phase(m: &IntPhaseMove) -> Option<Planned> {
    Some(Planned {
        full: IntProfile::phase(m, CLOCK).ok()?,
        three: IntProfile::<3>::phase_in(m, CLOCK).ok()?,
    })
}

fn limits(m: &IntLimitsMove) -> Option<Planned> {
    Some(Planned {
        full: IntProfile::limits(m, CLOCK).ok()?,
        three: IntProfile::<3>::limits_in(m, CLOCK).ok()?,
    })
}

/// A random trapezoid (phase mode, start and end speeds) or limits move, fast enough to
/// walk on most steps and short enough for Icarus; None where the planner refuses it.
fn random_move(rng: &mut Rng) -> Option<Planned> {
    let steps = rng.range(40, 250);
    if rng.range(0, 2) == 0 {
        phase(&IntPhaseMove {
            steps,
            accel_ticks: rng.range(20_000, 80_000),
            cruise_ticks: rng.range(0, 40_000),
            decel_ticks: rng.range(20_000, 80_000),
            start_speed: rng.range(0, 3) * rng.range(0, 4_000),
            end_speed: rng.range(0, 3) * rng.range(0, 4_000),
        })
    } else {
        limits(&IntLimitsMove {
            steps,
            vmax: rng.range(20_000, 80_000),
            amax: rng.range(2_000_000, 40_000_000),
            start_speed: rng.range(0, 2) * rng.range(0, 4_000),
            end_speed: rng.range(0, 2) * rng.range(0, 4_000),
        })
    }
}

/// The recurrence's cost of each period of `p`, in step order.
fn costs(p: &IntProfile<3>, c: &RecurrenceClocks) -> Vec<u64> {
    let mut r = Recurrence::<&IntProfile<3>, 3>::new(p);
    let mut out = Vec::new();
    let mut before = 0;
    while r.next().is_some() {
        let now = r.counted().clocks(c);
        out.push(now - before);
        before = now;
    }
    out
}

/// Runs `moves` on a K-axis core with the recurrence at `digit` bits and checks it.
fn run(digit: u32, moves: &[Planned], name: &str) -> SimOutput {
    run_in(Simulator::Icarus, digit, moves, name)
}

/// [`run`] in `sim`.
fn run_in(sim: Simulator, digit: u32, moves: &[Planned], name: &str) -> SimOutput {
    let p = CoreParams {
        axes: moves.len() as u32,
        recurrence: Some(digit),
        ..Default::default()
    };
    let d = Design::new(&p, Arch::Tdm).expect("parameters");
    let clocks = d.widths.recurrence_clocks().unwrap();
    let regs: Vec<AxisMove> = moves
        .iter()
        .enumerate()
        .map(|(a, m)| AxisMove::from_profile(&m.full, a % 2 == 0, &p).unwrap())
        .collect();
    for (a, r) in regs.iter().enumerate() {
        // an unsplit move, so the core's pieces are the model's, each one the recurrence's
        assert_eq!(
            r.pieces.len(),
            moves[a].three.pieces().len(),
            "{name}: axis {a}"
        );
        for pc in &r.pieces {
            let f = RecurRegs::of(pc, &d.widths);
            assert!(
                f.is_some() || pc.dur < 2,
                "{name}: axis {a}: {pc:?} {:?}",
                pc.kernel
            );
        }
    }
    let last = regs
        .iter()
        .map(|m| m.edges().last().copied().unwrap_or(0))
        .max()
        .unwrap();
    let dir = tempfile::Builder::new().prefix(name).tempdir().unwrap();
    let out =
        simulate_in(sim, &d, &regs, dir.path(), last + 200_000).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.underrun, 0, "{name}: underrun");
    for (a, m) in moves.iter().enumerate() {
        let want: Vec<u64> = IntEdgeGenerator::new(&m.full).collect();
        assert!(
            out.edges[a] == want,
            "{name}: axis {a}'s edges are not the plan's"
        );
        assert_eq!(
            out.falls[a],
            half_interval_falls(&want),
            "{name}: axis {a} falls"
        );
    }
    // every period's cycles, select to FIFO write, against the recurrence's costs: the
    // same multiset (the calculator serves the axes in the scheduler's order)
    let mut rtl: Vec<u64> = out.sels[0]
        .iter()
        .zip(&out.pushes[0])
        .map(|(s, p)| p - s + 1)
        .collect();
    let mut model: Vec<u64> = moves
        .iter()
        .flat_map(|m| costs(&m.three, &clocks))
        .collect();
    rtl.sort_unstable();
    model.sort_unstable();
    assert!(
        rtl == model,
        "{name}: the periods' cycles are not the model's"
    );
    // the TDM model with those costs: the plan's edges from the same start, no underrun
    let mut axes: Vec<Axis> = moves
        .iter()
        .map(|m| Axis::recurrent(m.three.clone(), HZ, clocks).unwrap())
        .collect();
    let cfg = TdmConfig {
        clock_hz: HZ as f64,
        fifo_depth: p.fifo_depth as usize,
        latencies: d.widths.latencies(),
        ..Default::default()
    };
    let board = Board::new(cfg, &mut axes).unwrap();
    let start = board.start_tick();
    let mut rises = vec![Vec::new(); moves.len()];
    let report = board.run(|sp| rises[sp.axis].push(sp.rise - start));
    assert_eq!(report.underruns, 0, "{name}: the model underruns");
    assert_eq!(
        report.busy_cycles,
        model.iter().sum::<u64>(),
        "{name}: busy"
    );
    assert!(rises == out.edges, "{name}: the model's edges differ");
    // the group starts when the prefill is computed: the model's start tick plus the
    // RTL's start write, one init cycle per axis and the cycle from ready to go
    assert_eq!(
        out.go_cycle - out.start_cycle,
        start + moves.len() as u64 + 2,
        "{name}: group start"
    );
    out
}

/// Steps by the recurrence, by the closed form, and walks that fail over to it, in one
/// run: the counts of the model's kinds on these moves.
fn kinds(moves: &[Planned]) -> (u64, u64, u64) {
    let (mut walked, mut closed, mut failed) = (0, 0, 0);
    for m in moves {
        let mut r = Recurrence::<&IntProfile<3>, 3>::new(&m.three);
        r.by_ref().for_each(drop);
        let t = r.counted();
        walked += t.steps - t.closed;
        closed += t.closed - t.abandoned;
        failed += t.abandoned;
    }
    (walked, closed, failed)
}

/// Random phase and limits moves on four axes, digit-serial (the boards' unit) and
/// full-width multiplies.
#[test]
fn random_moves_edges_and_cycles_are_the_models() {
    let mut rng = Rng(0x7ec0_55e5);
    for (round, digit) in [13, 0].into_iter().enumerate() {
        let moves: Vec<Planned> = std::iter::from_fn(|| Some(random_move(&mut rng)))
            .flatten()
            .take(4)
            .collect();
        let (walked, closed, _) = kinds(&moves);
        assert!(
            walked > 10 * closed,
            "round {round}: {walked} walked, {closed} closed"
        );
        run(digit, &moves, &format!("recur-r{round}-md{digit}"));
    }
}

/// Every kernel mode, with start and end speeds, and slow ramps whose walks give up:
/// the failed walk's step takes the closed form two cycles after its answer.
#[test]
fn failed_walks_and_every_mode() {
    let m = phase(&IntPhaseMove {
        steps: 40,
        accel_ticks: 150_000,
        cruise_ticks: 10_000,
        decel_ticks: 200_001,
        start_speed: 0,
        end_speed: 100,
    })
    .unwrap();
    let fast = phase(&IntPhaseMove {
        steps: 300,
        accel_ticks: 40_000,
        cruise_ticks: 30_000,
        decel_ticks: 50_001,
        start_speed: 5_000,
        end_speed: 1_000,
    })
    .unwrap();
    let moves = [m, fast];
    let (walked, _, failed) = kinds(&moves);
    eprintln!("{walked} steps walked, {failed} walks failed over to the closed form");
    assert!(failed > 0 && walked > 0, "{walked} walked, {failed} failed");
    run(13, &moves, "recur-modes");
}

/// A host that writes only the 17 closed-form words to a core with the recurrence gets
/// the closed form on every step (each commit clears `hi`): the plan's edges, every
/// period the closed form's cycles.
#[test]
fn a_host_without_the_recurrence_gets_the_closed_form() {
    let p = CoreParams {
        axes: 2,
        recurrence: Some(13),
        ..Default::default()
    };
    let mut d = Design::new(&p, Arch::Tdm).unwrap();
    let closed = d.widths.period_cycles();
    d.widths.recur = None; // the testbench writes what such a host writes
    let mut rng = Rng(0xc105_ed00);
    let moves: Vec<Planned> = std::iter::from_fn(|| Some(random_move(&mut rng)))
        .flatten()
        .take(2)
        .collect();
    let regs: Vec<AxisMove> = moves
        .iter()
        .map(|m| AxisMove::from_profile(&m.full, true, &p).unwrap())
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let out = simulate_in(Simulator::Icarus, &d, &regs, dir.path(), 2_000_000)
        .unwrap_or_else(|e| panic!("{e}"));
    for (a, m) in moves.iter().enumerate() {
        let want: Vec<u64> = IntEdgeGenerator::new(&m.full).collect();
        assert!(out.edges[a] == want, "axis {a}'s edges are not the plan's");
    }
    let cycles: Vec<u64> = out.sels[0]
        .iter()
        .zip(&out.pushes[0])
        .map(|(s, p)| p - s + 1)
        .collect();
    assert!(!cycles.is_empty() && cycles.iter().all(|&c| u64::from(closed) == c));
}

/// Thirty-two axes (the most a core holds; the ULX3S-25F's pins carry 14) at 100 k
/// steps/s at once on the all-ramp move (2 000 steps, from rest to 100 k steps/s in 20 ms
/// and back): with the recurrence the core keeps every FIFO fed (Verilator, every edge the
/// plan's, every period the model's cycles); the closed form alone falls behind on the
/// same move in the TDM model.
#[test]
fn thirty_two_axes_at_100k_steps_a_second_all_ramps() {
    const AXES: usize = 32;
    let m = IntPhaseMove {
        steps: 2_000,
        accel_ticks: 1_000_000,
        cruise_ticks: 0,
        decel_ticks: 1_000_000,
        start_speed: 0,
        end_speed: 0,
    };
    let moves: Vec<Planned> = (0..AXES).map(|_| phase(&m).unwrap()).collect();
    let out = run_in(Simulator::Verilator, 13, &moves, "recur-32x100k");
    let busy: u64 = out.sels[0]
        .iter()
        .zip(&out.pushes[0])
        .map(|(s, p)| p - s + 1)
        .sum();
    eprintln!(
        "{AXES} axes at 100 k steps/s: calculator busy {busy} of {} cycles",
        out.edges[0].last().unwrap()
    );
    let p = CoreParams {
        axes: AXES as u32,
        ..Default::default()
    };
    let w = p.widths().unwrap();
    // the same move planned on the clock, each period at the closed form's latency
    let float = Move::Phase(PhaseMove::new(2_000, Family::Trapezoid, 0.02, 0.0, 0.02));
    let profile = Profile::plan_on_clock(&float, HZ as f64).unwrap();
    let mut axes: Vec<Axis> = (0..AXES)
        .map(|_| Axis::new(profile.clone(), HZ as f64).unwrap())
        .collect();
    let cfg = TdmConfig {
        clock_hz: HZ as f64,
        fifo_depth: p.fifo_depth as usize,
        latencies: w.latencies(),
        ..Default::default()
    };
    let report = Board::new(cfg, &mut axes).unwrap().run(|_| {});
    assert!(report.underruns > 0, "the closed form alone: {report:?}");
}
