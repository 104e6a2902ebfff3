//! Computed scurve and scurve4 moves on the whole board (`ms_board` with a chain unit per
//! axis, the ULX3S-85F build, co-simulated, UART included): random phase and limits
//! moves with start and end speeds, their chain records (`multistep_hdl::chain`) written
//! into the axes' stream buffers in bulk writes, then one group start: every STEP rise at
//! `go + t + 1` for plan's t. A move whose last records never come underruns, flagged,
//! with every edge it makes still plan's.

mod common;

use common::host::Host;
use common::{board_move, params, Rng};
use multistep_core::{Family, Move, PhaseMove};
use multistep_hdl::board_sim::BoardLog;
use multistep_hdl::boards::Board;
use multistep_hdl::chain::{ChainedMove, CHAIN_LAYOUT};
use multistep_hdl::link::{
    core_addr, AxisReg, AxisRun, AxisState, BoardReg, Reg, Reply, Status, BULK_MAX,
};
use multistep_hdl::stream::StreamedMove;
use multistep_hdl::BoardTop;

const TICK0: u64 = 1;
/// The ULX3S's host link.
const BAUD: u32 = 3_000_000;

/// The ULX3S-85F's core clock: moves are planned in its ticks.
fn hz() -> u64 {
    Board::by_name("ulx3s-85f").unwrap().clock_hz() as u64
}

/// The ULX3S-85F's board top level with `k` axes (its 128-period FIFOs, its 3 Mbaud).
fn chain_board(k: u32) -> BoardTop {
    let board = Board::by_name("ulx3s-85f").unwrap();
    let b = board.board_top(&board.params(k).unwrap());
    assert_eq!(b.baud, BAUD);
    b
}

/// A random [`board_move`] of kind `kind` (0, 1: phase scurve, scurve4; 2, 3: limits
/// scurve, scurve4), retried until plan accepts it and the host would chain it (its
/// records fit the chain unit and keep up with the 128-period FIFO).
fn random_move(rng: &mut Rng, kind: u64, vmax: u64) -> (Move<'static>, ChainedMove) {
    let kind = [4, 5, 7, 8][kind as usize % 4];
    for _ in 0..50 {
        let mv = board_move(rng, kind, vmax);
        if let Ok(c) = ChainedMove::plan(&mv, hz(), 24, &CHAIN_LAYOUT) {
            if c.steps() > 2 && c.keeps_up(128) {
                return (mv, c);
            }
        }
    }
    panic!("no move of kind {kind} planned in 50 tries");
}

fn rises_after_go(log: &BoardLog, a: usize) -> Vec<u64> {
    let go = log.go[0];
    log.rises(a, true)
        .iter()
        .filter(|&&c| c > go)
        .map(|c| c - go - TICK0)
        .collect()
}

/// Loads one chained move per axis (the first `sent[a]` records of axis a's; the rest at
/// move tick `rest_at`) and starts them as one group; returns the log, the replies and
/// each axis's State and Position read indices.
fn run_group(
    b: &BoardTop,
    moves: &[ChainedMove],
    sent: &[usize],
    rest_at: u64,
    dirs: &[bool],
    name: &str,
) -> (BoardLog, Vec<Reply>, Vec<[usize; 2]>) {
    let w = b.widths().unwrap();
    let mut h = Host::new();
    let rec = CHAIN_LAYOUT.record_bytes();
    for (a, m) in moves.iter().enumerate() {
        let a = a as u32;
        h.write(
            Reg::Core(core_addr(&w, true, a, 1)),
            u32::from(dirs[a as usize]) << 31,
        );
        let arm = m.arm_write(a);
        h.write(arm.reg, arm.data);
        let first = sent[a as usize] * rec;
        for r in m.frames(BULK_MAX) {
            if r.start < first {
                let bw = m.bulk(a, r.start..r.end.min(first), h.seq());
                h.bulk(&bw);
            }
        }
    }
    h.write(Reg::Board(BoardReg::Start), (1u32 << moves.len()) - 1);
    // the start is answered (so the move tick counts from its go) before the rest
    h.s.sync();
    for (a, m) in moves.iter().enumerate() {
        let first = sent[a] * rec;
        if first < m.bytes.len() {
            h.s.at_move_tick(rest_at);
            for s in (first..m.bytes.len()).step_by(BULK_MAX) {
                let bw = m.bulk(a as u32, s..(s + BULK_MAX).min(m.bytes.len()), h.seq());
                h.bulk(&bw);
            }
        }
    }
    h.s.sync().idle();
    let reads = (0..moves.len() as u32)
        .map(|a| {
            [
                h.read(Reg::Axis(a, AxisReg::State)),
                h.read(Reg::Axis(a, AxisReg::Position)),
            ]
        })
        .collect();
    h.s.sync();
    let end = moves
        .iter()
        .map(|m| *m.edges.last().unwrap())
        .max()
        .unwrap();
    // every record byte over the link: 10 bits of the board's clocks each
    let bytes: u64 = moves.iter().map(|m| m.bytes.len() as u64).sum();
    let link = bytes * 10 * u64::from(b.div());
    let (log, rep) = h.run(b, name, end.max(rest_at) * 2 + link * 2 + 2_000_000);
    (log, rep, reads)
}

/// Random scurve and scurve4 moves (both modes) on K axes at once, moves the host would
/// chain (the timeline model keeps up): every edge plan's.
fn every_kind(k: u32, rounds: u64, seed: u64) {
    let b = chain_board(k);
    let mut rng = Rng(seed);
    for r in 0..rounds {
        let name = format!("chain-k{k}-r{r}");
        let (mvs, moves): (Vec<_>, Vec<_>) = (0..u64::from(k))
            .map(|a| random_move(&mut rng, (r * u64::from(k) + a) % 4, 100_000))
            .unzip();
        let dirs: Vec<bool> = (0..k).map(|a| (r + u64::from(a)) % 2 == 0).collect();
        let all: Vec<usize> = moves.iter().map(|m| m.records).collect();
        let (log, rep, reads) = run_group(&b, &moves, &all, 0, &dirs, &name);
        for (i, y) in rep.iter().enumerate() {
            assert_eq!(y.status, Status::Ok, "{name}: reply {i}");
        }
        assert_eq!(log.go.len(), 1, "{name}: one group start");
        for (a, m) in moves.iter().enumerate() {
            let what = format!("{name} axis {a} ({:?}, {} records)", mvs[a], m.records);
            assert_eq!(rises_after_go(&log, a), m.edges, "{what}: edges");
            let st = AxisState::decode(rep[reads[a][0]].data).unwrap();
            assert_eq!(st.run, AxisRun::Idle, "{what}: no underrun ({st:?})");
            assert!(!st.stream_armed && !st.stream_fault, "{what}: {st:?}");
            let n = m.steps() as i64;
            let pos = multistep_hdl::link::position_count(rep[reads[a][1]].data, 0);
            assert_eq!(pos, if dirs[a] { n } else { -n }, "{what}: position");
        }
    }
}

/// The largest K of the ULX3S-85F: eight chain units at once.
#[test]
fn chained_scurves_eight_axes() {
    every_kind(8, 1, 0xc4a1_0008);
}

/// Axis 0's last records (two or more, holding at least three steps) come only after its
/// move should have ended: the axis underruns (flagged in `State`), every step is still
/// made, the edges before the missing records are plan's and none is early; axis 1's move
/// is exact beside it.
#[test]
fn late_records_underrun_flagged() {
    let b = chain_board(2);
    let mut rng = Rng(0xc4a1_0bad);
    let (_, m0) = random_move(&mut rng, 1, 100_000);
    let (_, m1) = random_move(&mut rng, 3, 100_000);
    // the last records holding at least 3 steps (a short move's last pieces may hold none)
    let held = (2..m0.records)
        .find(|&n| m0.steps() - m0.spans[m0.records - n].first >= 3)
        .expect("a move of more than two records");
    let moves = [m0, m1];
    let sent = [moves[0].records - held, moves[1].records];
    let late = moves[0].edges.last().unwrap() + 10_000;
    let (log, rep, reads) = run_group(&b, &moves, &sent, late, &[true, true], "chain-late");
    let st = AxisState::decode(rep[reads[0][0]].data).unwrap();
    assert!(st.underrun && st.run == AxisRun::Underrun, "{st:?}");
    let got = rises_after_go(&log, 0);
    let want = &moves[0].edges;
    assert_eq!(got.len(), want.len(), "every step made, late");
    let first_late = got.iter().zip(want).position(|(g, w)| g != w).unwrap();
    assert!(first_late > 0 && got[first_late] > late, "{first_late}");
    assert!(got.iter().zip(want).all(|(g, w)| g >= w), "no edge early");
    assert_eq!(rises_after_go(&log, 1), moves[1].edges);
    let st1 = AxisState::decode(rep[reads[1][0]].data).unwrap();
    assert_eq!(st1.run, AxisRun::Idle, "{st1:?}");
}

/// `Chains` names the record size; a chained move then a streamed one on the same axis
/// (the buffer switches from records to nibble code) are both exact; a board without
/// chain units refuses `Chains` and `ChainSteps` (status 3).
#[test]
fn chains_register_and_a_streamed_move_after_a_chained_one() {
    let b = chain_board(1);
    assert!(b.chains && b.stream_buffer_bits == 12 && b.core.fifo_depth == 128);
    let w = b.widths().unwrap();
    let mut rng = Rng(0xc4a1_5eed);
    let (_, c) = random_move(&mut rng, 0, 80_000);
    let mv = Move::Phase(PhaseMove::new(300, Family::Sine, 1e-3, 1e-3, 1e-3));
    let s = StreamedMove::plan(&mv, hz(), 24).unwrap();
    let mut h = Host::new();
    let chains = h.read(Reg::Board(BoardReg::Chains));
    h.write(Reg::Core(core_addr(&w, true, 0, 1)), 1 << 31);
    let arm = c.arm_write(0);
    h.write(arm.reg, arm.data);
    for r in c.frames(BULK_MAX) {
        let bw = c.bulk(0, r, h.seq());
        h.bulk(&bw);
    }
    h.write(Reg::Board(BoardReg::Start), 1);
    h.s.sync().idle();
    let arm = s.arm_write(0);
    h.write(arm.reg, arm.data);
    for ch in s.chunks(4096, 128) {
        assert!(ch.not_before.is_none(), "the whole code fits");
        let bw = s.bulk(0, ch.range, h.seq());
        h.bulk(&bw);
    }
    h.write(Reg::Board(BoardReg::Start), 1);
    h.s.sync().idle();
    let pos = h.read(Reg::Axis(0, AxisReg::Position));
    h.s.sync();
    let end = c.edges.last().unwrap() + s.edges.last().unwrap();
    let (log, rep) = h.run(&b, "chain-then-stream", end + 3_000_000);
    assert_eq!(rep[chains].data as usize, CHAIN_LAYOUT.record_bytes());
    for (i, y) in rep.iter().enumerate() {
        assert_eq!(y.status, Status::Ok, "reply {i}");
    }
    assert_eq!(log.go.len(), 2);
    let rises = log.rises(0, true);
    for (g, want) in log.go.iter().zip([&c.edges, &s.edges]) {
        let got: Vec<u64> = rises
            .iter()
            .filter(|&&r| r > *g)
            .take(want.len())
            .map(|r| r - g - TICK0)
            .collect();
        assert_eq!(&got, want);
    }
    assert_eq!(rep[pos].data as u64, c.steps() + s.steps());

    // no chain units
    let plain = BoardTop::new(params(1), BAUD);
    let mut h = Host::new();
    let chains = h.read(Reg::Board(BoardReg::Chains));
    let refused = h.write(Reg::Axis(0, AxisReg::ChainSteps), 10);
    h.s.sync();
    let (_, rep) = h.run(&plain, "chain-none", 200_000);
    assert_eq!(rep[chains].status, Status::BadAddress);
    assert_eq!(rep[refused].status, Status::BadAddress);
}

/// The chain walks a tick a clock, so a fast stretch then a slow tail starves a short
/// FIFO: with 16 periods this rest-to-rest scurve4 underruns on the board at the step
/// `multistep_core::tdm::chain` names (the host streams such a move), every edge made,
/// none early; with the 85F's 128 the model says it keeps up.
#[test]
fn a_slow_tail_underruns_where_the_chain_model_says() {
    let mut b = chain_board(1);
    b.core.fifo_depth = 16;
    let mv = Move::Phase(PhaseMove::new(
        800,
        Family::SCurve4 { phi: 0.5, psi: 0.5 },
        0.002,
        0.001,
        0.002,
    ));
    let m = ChainedMove::plan(&mv, hz(), 24, &CHAIN_LAYOUT).unwrap();
    let predicted = m.timeline(16).first_late.expect("the model says late");
    assert!(m.keeps_up(128), "{:?}", m.timeline(128));
    let all = [m.records];
    let (log, rep, reads) = run_group(&b, std::slice::from_ref(&m), &all, 0, &[true], "chain-tail");
    let st = AxisState::decode(rep[reads[0][0]].data).unwrap();
    assert!(st.underrun, "{st:?}");
    let got = rises_after_go(&log, 0);
    assert_eq!(got.len(), m.edges.len(), "every step made");
    let first_late = got.iter().zip(&m.edges).position(|(g, w)| g != w).unwrap();
    assert!(
        first_late.abs_diff(predicted) <= 1,
        "board {first_late}, model {predicted}"
    );
    assert!(
        got.iter().zip(&m.edges).all(|(g, w)| g >= w),
        "no edge early"
    );
}
