//! Co-simulation: the emitted RTL in Icarus Verilog against the Rust reference model.
//! Every edge tick of every axis must be equal. Needs `iverilog` (a missing tool fails).

mod common;

use common::{params, random_move, Rng};
use multistep_core::tdm::{Axis, Board, TdmConfig};
use multistep_core::Profile;
use multistep_hdl::tools::simulate;
use multistep_hdl::{Arch, AxisMove, CoreParams, Design, SegRegs};

/// Simulates `moves` on `arch` and asserts bit-exact edges and no underrun.
fn cosim(arch: Arch, p: &CoreParams, moves: &[AxisMove], name: &str) {
    let d = Design::new(p, arch).expect("parameters");
    let dir = tempfile::Builder::new().prefix(name).tempdir().unwrap();
    let last: u64 = moves
        .iter()
        .map(|m| m.segs.iter().map(|s| u64::from(s.d)).sum::<u64>())
        .max()
        .unwrap();
    let out = simulate(&d, moves, dir.path(), last + 100_000).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.underrun, 0, "{name}: underrun");
    // one calculator start per step, each busy for the documented cycle count
    let steps: u64 = moves
        .iter()
        .map(|m| m.segs.iter().map(|s| u64::from(s.n)).sum::<u64>())
        .sum();
    assert_eq!(out.calc_starts, steps, "{name}: calculator starts");
    let busy = u64::from(d.widths.calc_busy_cycles());
    assert_eq!(
        out.calc_busy_cycles,
        steps * busy,
        "{name}: calculator busy cycles"
    );
    let dirs: u32 = moves
        .iter()
        .enumerate()
        .map(|(a, m)| u32::from(m.dir) << a)
        .sum();
    assert_eq!(out.dir, dirs, "{name}: DIR lines");
    for (a, m) in moves.iter().enumerate() {
        let want = m.edges(p.frac_bits);
        assert_eq!(
            out.falls[a],
            half_interval_falls(&want),
            "{name}: axis {a} STEP falls"
        );
        assert_eq!(
            out.edges[a].len(),
            want.len(),
            "{name}: axis {a} step count"
        );
        if let Some(k) = (0..want.len()).find(|&k| out.edges[a][k] != want[k]) {
            panic!(
                "{name}: axis {a} step {} at tick {} in RTL, {} in the model",
                k + 1,
                out.edges[a][k],
                want[k]
            );
        }
    }
}

/// 50 % duty: STEP stays high for half of the interval to the next edge (at least one
/// tick), the last pulse for half of the last interval.
fn half_interval_falls(rises: &[u64]) -> Vec<u64> {
    let mut prev = 0;
    (0..rises.len())
        .map(|k| {
            let interval = rises
                .get(k + 1)
                .map_or(rises[k] - prev, |next| next - rises[k]);
            prev = rises[k];
            rises[k] + (interval / 2).max(1)
        })
        .collect()
}

/// All three cases of the calculator (A > 0, A = 0, A < 0), one-step segments and a
/// move that ends on a perfect square, on one axis.
#[test]
fn single_axis_every_calculator_case() {
    let p = params(1);
    let q = 1u32 << p.frac_bits;
    let m = AxisMove {
        dir: true,
        segs: vec![
            SegRegs {
                n: 25,
                d: 10_000,
                s: 0,
            }, // accelerate from rest: A > 0
            SegRegs {
                n: 40,
                d: 8_000,
                s: 40 * q,
            }, // cruise: A = 0
            SegRegs {
                n: 1,
                d: 1_000,
                s: 400,
            }, // one step, decelerating (A < 0)
            SegRegs {
                n: 30,
                d: 12_001,
                s: 60 * q,
            }, // decelerate to rest: A < 0
        ],
    };
    m.check(&p).unwrap();
    cosim(Arch::Tdm, &p, &[m], "k1-cases");
}

#[test]
fn tdm_random_moves_k1_to_k4() {
    let mut rng = Rng(0x5eed_0007);
    for k in 1..=4u32 {
        let p = params(k);
        // sustained rate well below one period per k calculations (~130 cycles each)
        let vmax = 1.0 / (f64::from(k) * 200.0 + 200.0);
        for round in 0..2 {
            let moves: Vec<AxisMove> = (0..k)
                .map(|_| {
                    let segs = 1 + rng.range(0, 3) as usize;
                    random_move(&mut rng, &p, segs, vmax, round == 0)
                })
                .collect();
            cosim(Arch::Tdm, &p, &moves, &format!("tdm-k{k}-r{round}"));
        }
    }
}

#[test]
fn independent_cores_match_the_model_too() {
    let mut rng = Rng(0xba5e_11e5);
    let p = params(3);
    let moves: Vec<AxisMove> = (0..3)
        .map(|_| random_move(&mut rng, &p, 3, 1.0 / 300.0, true))
        .collect();
    cosim(Arch::Independent, &p, &moves, "indep-k3");
}

/// A FIFO absorbs a short burst faster than the calculator: 16 steps at 1/8 step per tick
/// after a slow start that fills it.
#[test]
fn fifo_absorbs_a_fast_burst() {
    let p = params(2);
    let q = 1u32 << p.frac_bits;
    let burst = AxisMove {
        dir: false,
        segs: vec![SegRegs {
            n: 12,
            d: 96,
            s: 12 * q,
        }],
    };
    let slow = AxisMove {
        dir: true,
        segs: vec![SegRegs {
            n: 10,
            d: 20_000,
            s: 0,
        }],
    };
    cosim(Arch::Tdm, &p, &[burst, slow], "burst");
}

/// When the calculator cannot keep up the pulse unit flags an underrun, and its edges are
/// late, never early.
#[test]
fn underrun_is_flagged_and_edges_are_late() {
    let p = CoreParams {
        axes: 2,
        fifo_depth: 2,
        ..Default::default()
    };
    let q = 1u32 << p.frac_bits;
    let fast = AxisMove {
        dir: false,
        segs: vec![SegRegs {
            n: 200,
            d: 1_600,
            s: 200 * q,
        }],
    };
    let d = Design::new(&p, Arch::Tdm).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = simulate(&d, &[fast.clone(), fast.clone()], dir.path(), 1_000_000)
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.underrun, 0b11);
    let want = fast.edges(p.frac_bits);
    for e in &out.edges {
        assert_eq!(e.len(), want.len());
        assert!(e.iter().zip(&want).all(|(r, m)| r >= m));
        assert!(e.last() > want.last());
    }
}

/// The core's cycle-accurate TDM model (float edge generator, the RTL's latencies) gives
/// the same edges as the RTL on the same moves, from the group's start.
#[test]
fn rtl_equals_core_tdm_board() {
    let mut rng = Rng(0x7d_0004);
    for k in [2u32, 3] {
        let p = params(k);
        let moves: Vec<AxisMove> = (0..k)
            .map(|_| random_move(&mut rng, &p, 3, 1.0 / 900.0, true))
            .collect();
        let w = p.widths().unwrap();
        let mut axes: Vec<Axis> = moves
            .iter()
            .map(|m| {
                let segs: Vec<_> = m
                    .segs
                    .iter()
                    .map(|s| s.to_core(p.clock_hz, p.frac_bits))
                    .collect();
                Axis::new(Profile::segments(&segs).unwrap(), p.clock_hz).unwrap()
            })
            .collect();
        let cfg = TdmConfig {
            clock_hz: p.clock_hz,
            fifo_depth: p.fifo_depth as usize,
            latencies: w.latencies(),
            ..Default::default()
        };
        let board = Board::new(cfg, &mut axes).unwrap();
        let start = board.start_tick();
        let mut model = vec![Vec::new(); k as usize];
        let mut falls = vec![Vec::new(); k as usize];
        let report = board.run(|sp| {
            model[sp.axis].push(sp.rise - start);
            falls[sp.axis].push(sp.fall - start);
        });
        assert_eq!(report.underruns, 0);
        assert_eq!(report.interval_cycles, u64::from(w.calc_busy_cycles()) + 2);
        assert_eq!(report.latency_cycles, u64::from(w.calc_busy_cycles()) + 2);
        let d = Design::new(&p, Arch::Tdm).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let out = simulate(&d, &moves, dir.path(), 400_000).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(out.underrun, 0);
        for a in 0..k as usize {
            assert_eq!(out.edges[a], model[a], "K = {k} axis {a}");
            assert_eq!(out.falls[a], falls[a], "K = {k} axis {a} falls");
            assert_eq!(
                out.edges[a],
                moves[a].edges(p.frac_bits),
                "K = {k} axis {a}"
            );
        }
    }
}

/// Seed 000's two-axis experiment (trapezoids of 2400 and 1800 steps, 20 ms accel, 10 ms
/// cruise, 20 ms decel at 50 MHz) loaded as three segments per axis: the RTL's edges are
/// the core's integer phase-mode edges of the same moves, all 4200 of them.
#[test]
fn seed000_two_axis_experiment() {
    use multistep_core::int::{IntClock, IntEdgeGenerator, IntPhaseMove, IntProfile};
    let p = params(2);
    let f = p.frac_bits;
    let axis = |steps: u32, dir: bool| {
        // vm = 2N / (Ta + 2Tb + Tc) = N / 0.03 s, in steps/tick times 2^F times d
        let (d_acc, d_cru) = (1_000_000u32, 500_000u32);
        let n = steps / 3;
        let s = |d: u32| ((u64::from(steps) << f) * u64::from(d) / 1_500_000) as u32;
        AxisMove {
            dir,
            segs: vec![
                SegRegs { n, d: d_acc, s: 0 },
                SegRegs {
                    n,
                    d: d_cru,
                    s: s(d_cru),
                },
                SegRegs {
                    n,
                    d: d_acc,
                    s: s(d_acc),
                },
            ],
        }
    };
    let moves = [axis(2400, false), axis(1800, true)];
    for m in &moves {
        let phase = IntPhaseMove {
            steps: m.segs.iter().map(|s| u64::from(s.n)).sum(),
            accel_ticks: 1_000_000,
            cruise_ticks: 500_000,
            decel_ticks: 1_000_000,
            start_speed: 0,
            end_speed: 0,
        };
        let profile = IntProfile::phase(&phase, IntClock::hz(50_000_000)).unwrap();
        let core: Vec<u64> = IntEdgeGenerator::new(profile).collect();
        assert_eq!(m.edges(f), core);
    }
    cosim(Arch::Tdm, &p, &moves, "seed000");
}
