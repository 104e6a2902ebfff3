//! Pieces longer than the core's tick or step bits: the host splits them at step
//! boundaries (`AxisMove::from_profile`, `PieceRegs::split_at`), and the split move's
//! edges are the planned move's tick for tick — against `multistep_core::int`'s edge
//! generator on a narrow core, against the unsplit registers of a wide one, and (one
//! co-simulation) against `plan` on the RTL at the iCEBreaker's widths.

mod common;

use common::{Rng, CLOCK, HZ};
use multistep_core::int::{IntEdgeGenerator, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment};
use multistep_core::{Family, Move, PhaseMove};
use multistep_hdl::boards::Board;
use multistep_hdl::link::{
    core_addr, int_profile, move_writes, piece_writes, rolling_writes, stop_ramp_writes, Reg,
    RegWrite,
};
use multistep_hdl::simulator::Simulator;
use multistep_hdl::tools::simulate_in;
use multistep_hdl::{Arch, AxisMove, CoreParams, Design, FitError};
use proptest::prelude::*;

/// 16 tick bits (1.3 ms pieces at 50 MHz), 10 step bits, 256 slots; kernels as wide as
/// the core takes, so only the tick and step bits bind.
fn narrow() -> CoreParams {
    CoreParams {
        axes: 1,
        pieces: 256,
        step_bits: 10,
        tick_bits: 16,
        radicand_bits: 128,
        kernel_bits: 95,
        clock_hz: HZ as f64,
        max_rate: 500_000.0,
        max_piece_s: 1e-3,
        ..CoreParams::default()
    }
}

/// The same kernels with 23 tick and step bits: the planned pieces unsplit.
fn wide() -> CoreParams {
    CoreParams {
        step_bits: 23,
        tick_bits: 23,
        max_piece_s: 0.1,
        ..narrow()
    }
}

/// Draws one of the three integer move kinds (seed 000 segments, phase and limits
/// trapezoids, start and end speeds) lasting up to about `ticks`.
fn draw(rng: &mut Rng, kind: u64, ticks: u64) -> Option<IntProfile> {
    let v = |r: &mut Rng| r.range(2_000, 150_000);
    match kind % 3 {
        0 => {
            let mut v0 = rng.zero_or(1_000, 100_000);
            let mut segs = Vec::new();
            for _ in 0..rng.range(1, 3) {
                let d = rng.range(1_000, ticks / 2);
                let v1 = v(rng);
                // n steps end at 2n/T − v0; keep n whole and the end speed within 0..
                let steps = ((v0 + v1) * d / (2 * HZ)).max(1);
                segs.push(IntSegment {
                    v0,
                    ticks: d,
                    steps,
                });
                v0 = (2 * steps * HZ).saturating_sub(v0 * d) / d;
            }
            IntProfile::segments(&segs, CLOCK).ok()
        }
        1 => {
            let (vs, ve, vm) = (rng.zero_or(500, 30_000), rng.zero_or(500, 30_000), v(rng));
            let (ta, tb, tc) = (
                rng.range(1, ticks / 3),
                rng.zero_or(1, ticks / 3),
                rng.range(1, ticks / 3),
            );
            let steps = (vs * ta + ve * tc + vm * (ta + 2 * tb + tc)) / (2 * HZ);
            let m = IntPhaseMove {
                steps: steps.max(1),
                accel_ticks: ta,
                cruise_ticks: tb,
                decel_ticks: tc,
                start_speed: vs,
                end_speed: ve,
            };
            IntProfile::phase(&m, CLOCK).ok()
        }
        _ => {
            let vm = v(rng);
            let m = IntLimitsMove {
                steps: rng.range(1, vm * ticks / HZ / 2),
                vmax: vm,
                amax: rng.range(vm * 5, vm * 100),
                start_speed: rng.zero_or(500, vm / 2),
                end_speed: rng.zero_or(500, vm / 2),
            };
            IntProfile::limits(&m, CLOCK).ok()
        }
    }
}

/// Whether every period of `edges` is one the core makes with `tick_bits` (2 ticks or
/// more after the first edge, below 2^tick_bits).
fn periods_fit(edges: &[u64], tick_bits: u32) -> bool {
    let mut prev = 0;
    edges.iter().enumerate().all(|(i, &e)| {
        let ok = e >= prev && (e - prev) >> tick_bits == 0 && (i == 0 || e - prev >= 2);
        prev = e;
        ok
    })
}

/// One move on the narrow core: it splits exactly when the wide core takes it and its
/// periods fit, into pieces within the narrow widths, with every edge core::int's.
/// Returns whether a piece was split.
fn check_split(profile: &IntProfile, dir: bool) -> Result<bool, TestCaseError> {
    let (n, w) = (narrow(), wide());
    let want: Vec<u64> = IntEdgeGenerator::new(profile.clone()).collect();
    let split = AxisMove::from_profile(profile, dir, &n);
    let whole = AxisMove::from_profile(profile, dir, &w);
    let Ok(whole) = whole else {
        // the kernels do not fit even unsplit: splitting changes no kernel width
        prop_assert!(split.is_err(), "split but not whole: {profile:?}");
        return Ok(false);
    };
    prop_assert_eq!(whole.edges(), want.clone());
    if !periods_fit(&want, n.tick_bits) {
        match split {
            Err(FitError::Move(e)) => prop_assert!(e.contains("period"), "{e}"),
            other => prop_assert!(false, "a period too long, yet {other:?}"),
        }
        return Ok(false);
    }
    let split = split.map_err(|e| TestCaseError::fail(format!("{e}: {profile:?}")))?;
    prop_assert_eq!(split.edges(), want);
    prop_assert_eq!(split.steps(), profile.steps());
    // loaded while it runs, a core of 4 slots (whose move ticks wrap) takes the same pieces
    let small = CoreParams { pieces: 4, ..n };
    let rolled = AxisMove::rolling(profile, dir, &small)
        .map_err(|e| TestCaseError::fail(format!("rolling: {e}: {profile:?}")))?;
    prop_assert_eq!(&rolled.pieces, &split.pieces);
    check_rolling_writes(&small, &rolled)?;
    prop_assert!(split.pieces.len() >= whole.pieces.len());
    let (max_t, max_n) = ((1u64 << n.tick_bits) - 1, (1u64 << n.step_bits) - 1);
    for pc in &split.pieces {
        prop_assert!(pc.steps <= max_n);
        let last = pc.local_edge(pc.steps - 1).unwrap();
        prop_assert!(last <= max_t, "{pc:?}: last local edge {last}");
    }
    // a planned piece is split exactly when its last local edge or its steps outgrow them
    let outgrown = whole
        .pieces
        .iter()
        .any(|pc| pc.steps > max_n || pc.local_edge(pc.steps - 1).is_none_or(|e| e > max_t));
    prop_assert_eq!(outgrown, split.pieces.len() > whole.pieces.len());
    Ok(outgrown)
}

/// The writes of `m` loaded while it runs on `p`: a move that fits the slots is
/// `move_writes`' with no later loads; otherwise the first slots' pieces, each later
/// piece i into slot i mod slots after the steps of pieces 0 to i − slots, the control
/// word then naming its slot the last.
fn check_rolling_writes(p: &CoreParams, m: &AxisMove) -> Result<(), TestCaseError> {
    let (now, later) =
        rolling_writes(p, 0, m, 0, None).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let slots = p.pieces as usize;
    let w = p.widths().unwrap();
    let first = AxisMove {
        dir: m.dir,
        pieces: m.pieces[..slots.min(m.pieces.len())].to_vec(),
    };
    prop_assert_eq!(now, move_writes(p, 0, &first, 0).unwrap());
    prop_assert_eq!(later.len(), m.pieces.len().saturating_sub(slots));
    for (l, i) in later.iter().zip(slots..) {
        let made: u64 = m.pieces[..=i - slots].iter().map(|pc| pc.steps).sum();
        prop_assert_eq!((l.piece, l.made), (i, made));
        let n = l.writes.len();
        let (commit, ctl) = (l.writes[n - 2], l.writes[n - 1]);
        prop_assert_eq!(commit.reg, Reg::Core(core_addr(&w, true, 0, 0)));
        prop_assert_eq!(commit.data as usize, i % slots);
        prop_assert_eq!(ctl.reg, Reg::Core(core_addr(&w, true, 0, 1)));
        prop_assert_eq!(ctl.data, (u32::from(m.dir) << 31) | (i % slots) as u32);
    }
    // with a homing search's stop ramp: slots − 1 pieces ahead, the ramp in the slot after
    // the last loaded piece, moved on before that slot takes the next piece
    let ramp = m.pieces[0];
    let (now, later) = rolling_writes(p, 0, m, 0, Some(&ramp)).unwrap();
    let ahead = slots - 1;
    let stop_slot = |slot: usize| stop_ramp_writes(p, 0, slot as u32, &ramp).unwrap();
    if m.pieces.len() <= ahead {
        let mut want = move_writes(p, 0, m, 0).unwrap();
        want.extend(stop_slot(slots - 1));
        prop_assert_eq!(now, want);
        prop_assert!(later.is_empty());
        return Ok(());
    }
    let first = AxisMove {
        dir: m.dir,
        pieces: m.pieces[..ahead].to_vec(),
    };
    let mut want = move_writes(p, 0, &first, 0).unwrap();
    want.extend(stop_slot(slots - 1));
    prop_assert_eq!(now, want);
    prop_assert_eq!(later.len(), m.pieces.len() - ahead);
    for (l, i) in later.iter().zip(ahead..) {
        let made: u64 = m.pieces[..=i + 1 - slots].iter().map(|pc| pc.steps).sum();
        prop_assert_eq!((l.piece, l.made), (i, made));
        let mut want = stop_slot((i + 1) % slots);
        want.extend(piece_writes(&w, 0, (i % slots) as u32, &m.pieces[i]));
        want.push(RegWrite {
            reg: Reg::Core(core_addr(&w, true, 0, 1)),
            data: (u32::from(m.dir) << 31) | (i % slots) as u32,
        });
        prop_assert_eq!(&l.writes, &want);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random segments, phase and limits trapezoids with start and end speeds, up to
    /// 0.1 s (77 of the narrow core's pieces).
    #[test]
    fn split_moves_make_the_planned_edges(seed in any::<u64>(), kind in 0u64..3, dir in any::<bool>()) {
        let mut rng = Rng(seed | 1);
        if let Some(p) = draw(&mut rng, kind, 5_000_000) {
            check_split(&p, dir)?;
        }
    }
}

/// Enough of the random moves split, in every kind, for the property to mean something.
#[test]
fn most_random_moves_split() {
    let mut rng = Rng(0x5b11_7000);
    let mut split = [0u32; 3];
    for i in 0..90 {
        let kind = i % 3;
        if let Some(p) = draw(&mut rng, kind, 5_000_000) {
            split[kind as usize] += u32::from(check_split(&p, i % 2 == 0).unwrap());
        }
    }
    assert!(split.iter().all(|&n| n >= 10), "split per kind: {split:?}");
}

/// One segment (a cruise when `steps` is `v0` over `ticks`).
fn segment(v0: u64, ticks: u64, steps: u64) -> IntProfile {
    IntProfile::segments(&[IntSegment { v0, ticks, steps }], CLOCK).unwrap()
}

/// A piece of more steps than the step bits hold splits too (a long fast cruise).
#[test]
fn a_piece_of_too_many_steps_splits() {
    let p = segment(100_000, 5_000_000, 10_000);
    let m = AxisMove::from_profile(&p, true, &narrow()).unwrap();
    // a period of 500 ticks: the first piece holds the edges 500 … 65 500 (131 steps),
    // every later one starts at its first edge and holds 0 … 65 500 (132 steps)
    let steps: Vec<u64> = m.pieces.iter().map(|pc| pc.steps).collect();
    assert_eq!(steps.len(), 76);
    assert_eq!(steps[0], 131);
    assert!(steps[1..75].iter().all(|&n| n == 132), "{steps:?}");
    assert_eq!(steps[75], 10_000 - 131 - 74 * 132);
    assert_eq!(m.edges(), IntEdgeGenerator::new(p).collect::<Vec<_>>());
    // 10 k steps/s with 23 tick bits: 1023 steps (5.1 M ticks) fit the ticks, so the
    // step bits split it
    let p = segment(10_000, 15_000_000, 3_000);
    let q = CoreParams {
        tick_bits: 23,
        max_piece_s: 0.1,
        max_rate: 10_000.0,
        ..narrow()
    };
    let m = AxisMove::from_profile(&p, false, &q).unwrap();
    let steps: Vec<u64> = m.pieces.iter().map(|pc| pc.steps).collect();
    assert_eq!(steps, [1023, 1023, 954]);
    assert_eq!(m.edges(), IntEdgeGenerator::new(p).collect::<Vec<_>>());
}

/// A move far beyond the slots is refused without splitting it all (a 10 000 s cruise
/// is some 7.6 M pieces of 16 tick bits).
#[test]
fn a_move_far_beyond_the_slots_is_refused_quickly() {
    let p = segment(1_000, 500_000_000_000, 10_000_000);
    let e = AxisMove::from_profile(&p, true, &narrow()).unwrap_err();
    assert!(matches!(e, FitError::Move(_)), "{e}");
    assert!(e.to_string().contains("more than 4096 pieces"), "{e}");
}

/// `split_at` at every step of each mode's piece gives the same edges, and refuses a
/// shift past the step's edge (a numerator would go negative).
#[test]
fn split_at_any_step_is_exact() {
    let m = IntPhaseMove {
        steps: 600,
        accel_ticks: 1_000_001,
        cruise_ticks: 499_999,
        decel_ticks: 700_003,
        start_speed: 3_000,
        end_speed: 1_000,
    };
    let p = IntProfile::phase(&m, CLOCK).unwrap();
    let a = AxisMove::from_profile(&p, true, &wide()).unwrap();
    assert_eq!(a.pieces.len(), 3, "accel, cruise, decel");
    for pc in &a.pieces {
        let edge = |q: &multistep_hdl::PieceRegs, j| q.t0 + q.local_edge(j).unwrap();
        for s in 0..pc.steps {
            let e = pc.local_edge(s).unwrap();
            for shift in [0, e / 2, e] {
                let q = pc.split_at(s, shift).unwrap();
                assert_eq!(q.steps, pc.steps - s);
                for j in 0..q.steps {
                    assert_eq!(edge(&q, j), edge(pc, s + j), "{:?} s {s}", pc.kernel.mode);
                }
            }
            assert!(pc.split_at(s, e + 1).is_none());
        }
        assert!(pc.split_at(pc.steps, 0).is_none());
    }
}

/// The iCEBreaker (20 tick bits at 18 MHz, 16 slots): a 5000-step trapezoid with 0.1 s
/// ramps (1.8 M ticks each) is two pieces of two, its edges `plan`'s; with a 0.3 s cruise
/// too it is ten, still edge for edge; with a 0.8 s cruise it is 18, more than the core's
/// slots, refused saying so.
#[test]
fn icebreaker_takes_a_move_of_long_ramps() {
    let board = Board::by_name("icebreaker").unwrap();
    let p = board.params(1).unwrap();
    assert_eq!(p.pieces, 16);
    let clock = p.clock_hz as u64;
    for (cruise, pieces) in [(0.0, 4), (0.3, 10)] {
        let mv = Move::Phase(PhaseMove::new(5_000, Family::Trapezoid, 0.1, cruise, 0.1));
        let profile = int_profile(&mv, clock).unwrap();
        assert_eq!(profile.pieces()[0].dur, 1_800_000);
        let m = AxisMove::from_profile(&profile, true, &p).unwrap();
        assert_eq!(m.pieces.len(), pieces, "cruise {cruise} s");
        let plan: Vec<u64> = multistep_core::edges(&mv, clock as f64).unwrap().collect();
        assert_eq!(m.edges(), plan, "cruise {cruise} s");
        assert!(move_writes(&p, 0, &m, 0).is_ok());
    }
    let mv = Move::Phase(PhaseMove::new(5_000, Family::Trapezoid, 0.1, 0.8, 0.1));
    let e = AxisMove::from_profile(&int_profile(&mv, clock).unwrap(), true, &p).unwrap_err();
    assert!(matches!(e, FitError::Move(_)), "{e}");
    assert!(e.to_string().contains("18 pieces with steps"), "{e}");
}

/// The RTL at the iCEBreaker's widths (20 tick bits, 14 step bits, 48-bit radicand,
/// 26-bit kernels, radix 2, 16 slots) on a move whose ramps are 1.08 M ticks and cruise
/// 2.16 M: split into seven pieces, every STEP rise is `plan`'s edge. Verilator by default
/// (`MULTISTEP_SIM=icarus` for Icarus); 4.4 M clocks.
#[test]
fn cosim_split_move_on_icebreaker_widths() {
    let p = Board::by_name("icebreaker").unwrap().params(1).unwrap();
    let clock = p.clock_hz as u64;
    let mv = Move::Phase(PhaseMove::new(1_200, Family::Trapezoid, 0.06, 0.12, 0.06));
    let profile = int_profile(&mv, clock).unwrap();
    let max_dur = profile.pieces().iter().map(|pc| pc.dur).max().unwrap();
    assert!(
        max_dur >> p.tick_bits != 0,
        "{max_dur} ticks fit: nothing to split"
    );
    let m = AxisMove::from_profile(&profile, false, &p).unwrap();
    assert_eq!(m.pieces.len(), 7);
    let plan: Vec<u64> = multistep_core::edges(&mv, clock as f64).unwrap().collect();
    let d = Design::new(&p, Arch::Tdm).unwrap();
    let dir = tempfile::Builder::new().prefix("split").tempdir().unwrap();
    let sim = Simulator::from_env().unwrap();
    let last = *plan.last().unwrap();
    let out = simulate_in(sim, &d, &[m], dir.path(), last + 100_000).unwrap();
    assert_eq!(out.underrun, 0);
    assert_eq!(out.dir, 0);
    assert_eq!(out.edges[0].len(), plan.len());
    if let Some(k) = (0..plan.len()).find(|&k| out.edges[0][k] != plan[k]) {
        panic!("step {}: RTL {}, plan {}", k + 1, out.edges[0][k], plan[k]);
    }
}

/// `mv` on the RTL of `p` from `AxisMove::rolling`: `pieces` pieces, more than the slots
/// (refused loaded before the start), its move ticks wrapping `wraps` times; every STEP
/// rise is `plan`'s edge, and no underrun.
fn cosim_rolling(p: &CoreParams, mv: &Move, dir: bool, pieces: usize, wraps: u64) {
    let w = p.widths().unwrap();
    let clock = p.clock_hz as u64;
    let profile = int_profile(mv, clock).unwrap();
    let e = AxisMove::from_profile(&profile, dir, p).unwrap_err();
    assert!(
        e.to_string()
            .contains(&format!("the core holds 1..={}", p.pieces)),
        "{e}"
    );
    let m = AxisMove::rolling(&profile, dir, p).unwrap();
    assert_eq!(m.pieces.len(), pieces);
    let plan: Vec<u64> = multistep_core::edges(mv, clock as f64).unwrap().collect();
    assert_eq!(m.edges(), plan);
    let last = *plan.last().unwrap();
    assert_eq!(last >> w.wt, wraps, "the move ticks' wraps: {last}");
    let d = Design::new(p, Arch::Tdm).unwrap();
    let tmp = tempfile::Builder::new()
        .prefix("rolling")
        .tempdir()
        .unwrap();
    let sim = Simulator::from_env().unwrap();
    let out = simulate_in(sim, &d, &[m], tmp.path(), last + 100_000).unwrap();
    assert_eq!(out.underrun, 0);
    assert_eq!(out.dir, u32::from(dir));
    assert_eq!(out.edges[0].len(), plan.len());
    if let Some(k) = (0..plan.len()).find(|&k| out.edges[0][k] != plan[k]) {
        panic!("step {}: RTL {}, plan {}", k + 1, out.edges[0][k], plan[k]);
    }
}

/// A move of more pieces than the core has slots, loaded while it runs (the testbench's
/// roll): a 4-slot core of 16 tick bits at 50 MHz (pieces of at most 1.3 ms, move ticks of
/// 19 bits that wrap every 10.5 ms) runs a 30 ms trapezoid of 25 pieces, each written
/// into the slot of the piece four before it once that one's steps are made.
#[test]
fn cosim_rolling_pieces_run_a_move_longer_than_the_slots() {
    let p = CoreParams {
        pieces: 4,
        ..narrow()
    };
    let mv = Move::Phase(PhaseMove::new(
        3_000,
        Family::Trapezoid,
        0.008,
        0.014,
        0.008,
    ));
    cosim_rolling(&p, &mv, true, 25, 2);
}

/// The same at the iCEBreaker's widths (20 tick bits at 18 MHz, 16 slots): a 2 s
/// trapezoid of 8 000 steps is 35 pieces, where a move loaded before its start holds 16
/// (about 0.9 s); its move ticks pass 2^25 once. 36 M clocks in Verilator.
#[test]
fn cosim_rolling_pieces_on_icebreaker_widths() {
    let p = Board::by_name("icebreaker").unwrap().params(1).unwrap();
    let mv = Move::Phase(PhaseMove::new(8_000, Family::Trapezoid, 0.4, 1.2, 0.4));
    cosim_rolling(&p, &mv, false, 35, 1);
}
