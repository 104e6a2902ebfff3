//! Co-simulation: the emitted RTL in Icarus Verilog against the Rust references — the
//! core's integer datapath (`multistep_core::int`, every edge) and its cycle-accurate TDM
//! board (`multistep_core::tdm`, the RTL's latencies, no underrun in both). Needs
//! `iverilog` (a missing tool fails).

mod common;

use common::host::half_interval_falls;
use common::{narrow_params, params, random_move, IntMove, Rng, HZ};
use multistep_core::int::{IntEdgeGenerator, IntPhaseMove};
use multistep_core::tdm::{Axis, Board, Latencies, TdmConfig};
use multistep_hdl::simulator::Simulator;
use multistep_hdl::tools::{simulate, simulate_in, SimOutput};
use multistep_hdl::{Arch, AxisMove, CoreParams, Design};

/// The core's TDM board on the same moves (float twins) with the RTL's latencies: its
/// edges from the group's start, and its underrun count.
fn board(p: &CoreParams, moves: &[IntMove]) -> (Vec<Vec<u64>>, u64) {
    let (e, _, u) = board_pulses(p, moves);
    (e, u)
}

/// The board's rises and falls per axis (from the group's start) and its underruns.
fn board_pulses(p: &CoreParams, moves: &[IntMove]) -> (Vec<Vec<u64>>, Vec<Vec<u64>>, u64) {
    let w = p.widths().unwrap();
    let mut axes: Vec<Axis> = moves
        .iter()
        .map(|m| Axis::new(m.float_profile(), HZ as f64).unwrap())
        .collect();
    let cfg = TdmConfig {
        clock_hz: HZ as f64,
        fifo_depth: p.fifo_depth as usize,
        latencies: w.latencies(),
        ..Default::default()
    };
    let board = Board::new(cfg, &mut axes).unwrap();
    let start = board.start_tick();
    let mut edges = vec![Vec::new(); moves.len()];
    let mut falls = vec![Vec::new(); moves.len()];
    let report = board.run(|sp| {
        edges[sp.axis].push(sp.rise - start);
        falls[sp.axis].push(sp.fall - start);
    });
    for (e, f) in edges.iter_mut().zip(&mut falls) {
        // pulses arrive per axis in step order, but a fall may come later than the next rise
        e.sort_unstable();
        f.sort_unstable();
    }
    (edges, falls, report.underruns)
}

/// Every select-to-FIFO-write takes the latency; selects are never closer than the
/// interval, and exactly that apart while the calculator is saturated.
fn check_timing(out: &SimOutput, lat: Latencies, name: &str) {
    for (c, (sels, pushes)) in out.sels.iter().zip(&out.pushes).enumerate() {
        assert_eq!(sels.len(), pushes.len(), "{name}: calculator {c}");
        for (s, p) in sels.iter().zip(pushes) {
            // select in cycle s, FIFO write in cycle p: p − s + 1 cycles
            assert_eq!(
                p - s + 1,
                lat.latency(),
                "{name}: calculator {c} period at {s}"
            );
        }
        if let Some(gap) = sels.windows(2).map(|w| w[1] - w[0]).min() {
            assert_eq!(
                gap,
                lat.interval(),
                "{name}: calculator {c} closest selects"
            );
        }
    }
}

/// Simulates `moves` on `arch`: bit-exact edges against core::int, the 50 % duty falls,
/// DIR, no underrun, the board's edges, and the measured cycles against the latencies.
fn cosim(arch: Arch, p: &CoreParams, moves: &[(IntMove, AxisMove)], name: &str) -> SimOutput {
    cosim_in(Simulator::Icarus, arch, p, moves, name)
}

/// [`cosim`] in `sim` (Verilator for the long runs).
fn cosim_in(
    sim: Simulator,
    arch: Arch,
    p: &CoreParams,
    moves: &[(IntMove, AxisMove)],
    name: &str,
) -> SimOutput {
    let d = Design::new(p, arch).expect("parameters");
    let dir = tempfile::Builder::new().prefix(name).tempdir().unwrap();
    let regs: Vec<AxisMove> = moves.iter().map(|m| m.1.clone()).collect();
    let last: u64 = regs
        .iter()
        .map(|m| m.edges().last().copied().unwrap_or(0))
        .max()
        .unwrap();
    let out =
        simulate_in(sim, &d, &regs, dir.path(), last + 200_000).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.underrun, 0, "{name}: underrun");
    let dirs: u32 = regs
        .iter()
        .enumerate()
        .map(|(a, m)| u32::from(m.dir) << a)
        .sum();
    assert_eq!(out.dir, dirs, "{name}: DIR lines");
    let steps: usize = regs.iter().map(|m| m.steps() as usize).sum();
    assert_eq!(
        out.sels.iter().map(Vec::len).sum::<usize>(),
        steps,
        "{name}"
    );
    check_timing(&out, d.widths.latencies(), name);
    // the prefill: the model's start tick (P periods back to back) plus the RTL's start
    // write, one init cycle per axis of a calculator and the cycle from ready to go
    let lat = d.widths.latencies();
    let fill = |ms: &[AxisMove]| {
        let p_: u64 = ms
            .iter()
            .map(|m| m.steps().min(u64::from(p.fifo_depth)))
            .sum();
        (p_ - 1) * lat.interval() + lat.latency() + ms.len() as u64 + 2
    };
    let go = match arch {
        Arch::Tdm => fill(&regs),
        Arch::Independent => regs.chunks(1).map(fill).max().unwrap(),
    };
    assert_eq!(out.go_cycle - out.start_cycle, go, "{name}: group start");
    let ints: Vec<IntMove> = moves.iter().map(|m| m.0.clone()).collect();
    let (model, underruns) = board(p, &ints);
    assert_eq!(underruns, 0, "{name}: the board underruns");
    for (a, (im, _)) in moves.iter().enumerate() {
        let want: Vec<u64> = IntEdgeGenerator::new(im.profile()).collect();
        assert_eq!(
            out.edges[a].len(),
            want.len(),
            "{name}: axis {a} step count"
        );
        if let Some(k) = (0..want.len()).find(|&k| out.edges[a][k] != want[k]) {
            panic!(
                "{name}: axis {a} step {} at tick {} in RTL, {} in core::int ({im:?})",
                k + 1,
                out.edges[a][k],
                want[k]
            );
        }
        assert_eq!(
            out.falls[a],
            half_interval_falls(&want),
            "{name}: axis {a} falls"
        );
        assert_board_edges(&model[a], &want, &format!("{name}: axis {a}"));
    }
    out
}

/// The float board's edges are core::int's on every step, exact half-tick ties included
/// (the float profile keeps its integer move and settles ties on it).
fn assert_board_edges(board: &[u64], want: &[u64], name: &str) {
    assert_eq!(board.len(), want.len(), "{name}: board step count");
    if let Some(k) = (0..want.len()).find(|&k| board[k] != want[k]) {
        panic!(
            "{name}: step {} at {} on the TDM board, {} in core::int",
            k + 1,
            board[k],
            want[k]
        );
    }
}

/// Random moves at rates the core sustains for K axes, `rounds` runs each.
fn random_runs(arch: Arch, ks: &[u32], seed: u64, rounds: usize, ticks: u64) {
    let mut rng = Rng(seed);
    for &k in ks {
        let p = params(k);
        let interval = p.widths().unwrap().latencies().interval();
        // one period per k computations, with a margin for the prefill
        let vmax = HZ / (interval * u64::from(k) * 3 / 2);
        for round in 0..rounds {
            let moves: Vec<_> = (0..k)
                .map(|_| random_move(&mut rng, &p, vmax.min(150_000), ticks))
                .collect();
            cosim(arch, &p, &moves, &format!("{arch:?}-k{k}-r{round}"));
        }
    }
}

#[test]
fn tdm_random_moves_k1_k2_k4_k8() {
    random_runs(Arch::Tdm, &[1, 2, 4, 8], 0x5eed_0007, 2, 120_000);
}

#[test]
fn independent_cores_match_too() {
    random_runs(Arch::Independent, &[3], 0xba5e_11e5, 1, 80_000);
}

/// Every kernel mode on one axis: a phase trapezoid with start and end speeds (Accel,
/// Cruise, Decel) and radix 2 (one result bit per cycle), whose latencies are the core's
/// `Latencies::RADIX2`.
#[test]
fn every_mode_at_radix_2_and_4() {
    let m = IntMove::Phase(IntPhaseMove {
        steps: 300,
        accel_ticks: 40_000,
        cruise_ticks: 30_000,
        decel_ticks: 50_001,
        start_speed: 5_000,
        end_speed: 1_000,
    });
    for radix_bits in [1, 2] {
        let p = CoreParams {
            axes: 1,
            radix_bits,
            ..Default::default()
        };
        let a = AxisMove::from_profile(&m.profile(), true, &p).unwrap();
        assert_eq!(a.pieces.len(), 3);
        cosim(
            Arch::Tdm,
            &p,
            &[(m.clone(), a)],
            &format!("modes-r{radix_bits}"),
        );
    }
    let r2 = CoreParams {
        radix_bits: 1,
        ..Default::default()
    };
    assert_eq!(r2.widths().unwrap().latencies(), Latencies::RADIX2);
}

/// Other widths and radices: radix 8 and radix 16 result digits, a 72-bit radicand, 40-bit
/// kernels, 16 tick bits, 10 step bits, FIFO depth 4, on trapezoids whose kernels fit.
#[test]
fn narrow_widths_and_other_radices() {
    let narrow = narrow_params(2, 4, 4);
    let trapezoid = |steps, ta, tb, tc| {
        IntMove::Phase(IntPhaseMove {
            steps,
            accel_ticks: ta,
            cruise_ticks: tb,
            decel_ticks: tc,
            start_speed: 0,
            end_speed: 0,
        })
    };
    let moves = [
        trapezoid(300, 40_000, 20_000, 40_000),
        trapezoid(250, 30_000, 45_000, 25_000),
    ];
    for (radix_bits, radicand_bits) in [(3, 72), (4, 64)] {
        let p = CoreParams {
            radix_bits,
            radicand_bits,
            ..narrow.clone()
        };
        let regs: Vec<_> = moves
            .iter()
            .map(|m| {
                let r = AxisMove::from_profile(&m.profile(), true, &p).unwrap();
                (m.clone(), r)
            })
            .collect();
        cosim(Arch::Tdm, &p, &regs, &format!("narrow-r{radix_bits}"));
    }
}

/// The throughput goal in model and RTL: at 100 000 steps/s per axis (trapezoids 1/3/1 ms at
/// 50 MHz, all started together) the core TDM model with the RTL's latencies finds the
/// largest axis count with no underrun (>= 8); the RTL runs that many with no underrun and
/// bit-exact edges, and one more axis underruns in both.
#[test]
fn most_axes_at_100k_steps_per_second() {
    use multistep_core::tdm::k_max;
    let m = IntMove::Phase(IntPhaseMove {
        steps: 400,
        accel_ticks: 50_000,
        cruise_ticks: 150_000,
        decel_ticks: 50_000,
        start_speed: 0,
        end_speed: 0,
    });
    let p = params(1);
    let cfg = TdmConfig {
        clock_hz: HZ as f64,
        fifo_depth: p.fifo_depth as usize,
        latencies: p.widths().unwrap().latencies(),
        ..Default::default()
    };
    let mut storage: Vec<Axis> = (0..16)
        .map(|_| Axis::new(m.float_profile(), HZ as f64).unwrap())
        .collect();
    let found = k_max(&cfg, &[m.float_profile()], &mut storage).unwrap();
    eprintln!(
        "100 k steps/s: k_max {} (eq. 12: {}, t_calc {} cycles)",
        found.k_max, found.k_eq12, found.interval_cycles
    );
    assert!(found.k_max >= 8 && !found.capped, "{found:?}");
    let k = found.k_max as u32;
    let p = params(k);
    let moves: Vec<_> = (0..k)
        .map(|a| {
            let r = AxisMove::from_profile(&m.profile(), a % 2 == 0, &p).unwrap();
            (m.clone(), r)
        })
        .collect();
    let sim = Simulator::Verilator;
    cosim_in(sim, Arch::Tdm, &p, &moves, &format!("k{k}-100k"));
    // one more axis: the RTL underruns as the model does
    let p = params(k + 1);
    let d = Design::new(&p, Arch::Tdm).unwrap();
    let regs = vec![moves[0].1.clone(); k as usize + 1];
    let dir = tempfile::tempdir().unwrap();
    let out = simulate_in(sim, &d, &regs, dir.path(), 2_000_000).unwrap_or_else(|e| panic!("{e}"));
    assert_ne!(out.underrun, 0, "K = {} in RTL", k + 1);
}

/// A FIFO absorbs a burst faster than the calculator's share: two axes, one cruising at
/// 240 k steps/s after a slow start that fills its FIFO.
#[test]
fn fifo_absorbs_a_fast_burst() {
    use multistep_core::int::IntSegment;
    let p = params(2);
    let burst = IntMove::Segments(vec![
        IntSegment {
            v0: 2_000,
            ticks: 50_000,
            steps: 2,
        },
        IntSegment {
            v0: 240_000,
            ticks: 2_500,
            steps: 12,
        },
    ]);
    let slow = IntMove::Segments(vec![IntSegment {
        v0: 0,
        ticks: 100_000,
        steps: 10,
    }]);
    let moves: Vec<_> = [burst, slow]
        .into_iter()
        .map(|m| {
            let r = AxisMove::from_profile(&m.profile(), false, &p).unwrap();
            (m, r)
        })
        .collect();
    cosim(Arch::Tdm, &p, &moves, "burst");
}

/// When the calculator cannot keep up, the pulse units flag underruns and run exactly as
/// the core's TDM model says: every rise and every fall of every axis equals the board's
/// (late edges, STEP held high while a period is missing), never early against core::int.
#[test]
fn overloaded_core_equals_the_model_edge_by_edge() {
    let fast = |v0: u64, steps: u64| {
        IntMove::Segments(vec![multistep_core::int::IntSegment {
            v0,
            ticks: 50_000,
            steps,
        }])
    };
    let mut rng = Rng(0x0be2_10ad);
    // (axes, FIFO depth, radix bits, moves): 200 k steps/s against 6 x 51 cycles; 16 axes
    // waiting longer than half a period; radix 2 with mixed random moves
    let runs: Vec<(u32, u32, u32, Vec<IntMove>)> = vec![
        (6, 2, 2, vec![fast(200_000, 200); 6]),
        (
            16,
            2,
            2,
            (0..16).map(|a| fast(150_000 + 5_000 * a, 160)).collect(),
        ),
        (
            5,
            4,
            1,
            (0..5)
                .map(|_| random_move(&mut rng, &params(5), 240_000, 60_000).0)
                .collect(),
        ),
    ];
    for (k, depth, radix_bits, moves) in runs {
        let p = CoreParams {
            axes: k,
            fifo_depth: depth,
            radix_bits,
            ..Default::default()
        };
        let regs: Vec<AxisMove> = moves
            .iter()
            .map(|m| AxisMove::from_profile(&m.profile(), false, &p).unwrap())
            .collect();
        let d = Design::new(&p, Arch::Tdm).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = simulate(&d, &regs, dir.path(), 4_000_000).unwrap_or_else(|e| panic!("{e}"));
        let (rises, falls, underruns) = board_pulses(&p, &moves);
        let name = format!("K = {k}, depth {depth}, radix bits {radix_bits}");
        assert!(underruns > 0 && out.underrun != 0, "{name}: not overloaded");
        for a in 0..k as usize {
            assert_eq!(out.edges[a], rises[a], "{name}: axis {a} rises");
            if let Some(i) = (0..falls[a].len()).find(|&i| out.falls[a].get(i) != falls[a].get(i)) {
                panic!(
                    "{name}: axis {a} fall {i} of {}: RTL {:?}, model {}; rises {:?} / {:?}",
                    falls[a].len(),
                    out.falls[a].get(i),
                    falls[a][i],
                    &out.edges[a][i.saturating_sub(2)..(i + 2).min(out.edges[a].len())],
                    &rises[a][i.saturating_sub(2)..(i + 2).min(rises[a].len())]
                );
            }
            assert_eq!(out.falls[a].len(), falls[a].len(), "{name}: axis {a} falls");
            let exact = regs[a].edges();
            assert!(out.edges[a].iter().zip(&exact).all(|(r, e)| r >= e));
        }
    }
}

/// Seed 000's two-axis experiment (trapezoids of 2400 and 1800 steps, 20 ms accel, 10 ms
/// cruise, 20 ms decel at 50 MHz): all 4200 RTL edges are core::int's.
#[test]
fn seed000_two_axis_experiment() {
    let p = params(2);
    let moves: Vec<_> = [(2400, false), (1800, true)]
        .into_iter()
        .map(|(steps, dir)| {
            let m = IntMove::Phase(IntPhaseMove {
                steps,
                accel_ticks: 1_000_000,
                cruise_ticks: 500_000,
                decel_ticks: 1_000_000,
                start_speed: 0,
                end_speed: 0,
            });
            let r = AxisMove::from_profile(&m.profile(), dir, &p).unwrap();
            (m, r)
        })
        .collect();
    cosim_in(Simulator::Verilator, Arch::Tdm, &p, &moves, "seed000");
}
