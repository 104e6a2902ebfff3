//! Streamed moves on the whole board (`ms_board` co-simulated, UART included): moves
//! of every profile family and mode, with start and end speeds, planned by `plan`'s edge
//! generator, coded (`multistep_core::stream`), sent in bulk writes at the link's real
//! baud while they run, and replayed by the board's `ms_replay` unit: every STEP rise at
//! `go + t + 1` for plan's t. A host that falls behind: the underrun is flagged.

mod common;

use common::host::Host;
use common::{board_move, family, params, Rng, BOARD_MOVE_KINDS, HZ};
use multistep_core::{Family, LimitsMove, Move, PhaseMove};
use multistep_hdl::board_sim::BoardLog;
use multistep_hdl::boards::Board;
use multistep_hdl::link::{
    core_addr, AxisReg, AxisRun, AxisState, BoardReg, Reg, RegWrite, Reply, Status,
};
use multistep_hdl::stream::StreamedMove;
use multistep_hdl::{BoardTop, CoreParams};

const TICK0: u64 = 1;
/// The board's stream buffer (`ms_board`'s LB = 9).
const BUFFER: u64 = multistep_hdl::link::STREAM_BUFFER;

/// A random [`board_move`] of kind `kind`, retried until plan accepts it.
fn random_move(
    rng: &mut Rng,
    kind: u64,
    vmax: u64,
    p: &CoreParams,
) -> (Move<'static>, StreamedMove) {
    for _ in 0..50 {
        let mv = board_move(rng, kind, vmax);
        if let Ok(s) = StreamedMove::plan(&mv, HZ, p.tick_bits) {
            if s.steps() > 2 {
                return (mv, s);
            }
        }
    }
    panic!("no move of kind {kind} planned in 50 tries");
}

/// Sends `m`'s code bytes `range` to `axis` in one bulk write.
fn send_chunk(h: &mut Host, m: &StreamedMove, axis: u32, range: std::ops::Range<usize>) {
    let w = m.bulk(axis, range, h.seq());
    h.bulk(&w);
}

/// Streams one move per axis as one group. `late` ticks are added to every chunk's
/// send time (a host that falls behind). Returns the log, the replies, the moves and
/// the indices of each axis's State and Position reads.
fn stream_group(
    b: &BoardTop,
    moves: &[StreamedMove],
    dirs: &[bool],
    frame: usize,
    late: u64,
    name: &str,
) -> (BoardLog, Vec<Reply>, Vec<[usize; 3]>) {
    let w = b.widths().unwrap();
    let mut h = Host::new();
    let mut later = Vec::new();
    for (a, m) in moves.iter().enumerate() {
        let a = a as u32;
        // DIR through the core's control word (bit 31), as for computed moves
        h.write(
            Reg::Core(core_addr(&w, true, a, 1)),
            u32::from(dirs[a as usize]) << 31,
        );
        let RegWrite { reg, data } = m.arm_write(a);
        h.write(reg, data);
        for c in m.chunks(BUFFER, frame) {
            match c.not_before {
                None => send_chunk(&mut h, m, a, c.range),
                Some(t) => later.push((t + late, a, c.range)),
            }
        }
    }
    let all = (1u32 << moves.len()) - 1;
    h.write(Reg::Board(BoardReg::Start), all);
    later.sort_by_key(|(t, a, _)| (*t, *a));
    for (t, a, r) in later {
        h.s.at_move_tick(t);
        send_chunk(&mut h, &moves[a as usize], a, r);
    }
    h.s.sync().idle();
    let reads: Vec<[usize; 3]> = (0..moves.len() as u32)
        .map(|a| {
            [
                h.read(Reg::Axis(a, AxisReg::State)),
                h.read(Reg::Axis(a, AxisReg::Position)),
                h.read(Reg::Axis(a, AxisReg::StreamSteps)),
            ]
        })
        .collect();
    h.s.sync();
    let end = moves
        .iter()
        .map(|m| *m.edges.last().unwrap())
        .max()
        .unwrap();
    let (log, rep) = h.run(b, name, end + late + 2_000_000);
    (log, rep, reads)
}

fn rises_after_go(log: &BoardLog, a: usize) -> Vec<u64> {
    let go = log.go[0];
    log.rises(a, true)
        .iter()
        .filter(|&&c| c > go)
        .map(|c| c - go - TICK0)
        .collect()
}

/// Random moves of every family and mode on K axes at 3 Mbaud: every edge plan's.
fn every_family(k: u32, rounds: u64, seed: u64) {
    every_family_on(&BoardTop::new(params(k), 3_000_000), rounds, seed);
}

/// [`every_family`] on board top `b` (its axes, its baud).
fn every_family_on(b: &BoardTop, rounds: u64, seed: u64) {
    let p = b.core.clone();
    let k = p.axes;
    let mut rng = Rng(seed);
    for r in 0..rounds {
        let name = format!("stream-k{k}-r{r}");
        let (mvs, moves): (Vec<_>, Vec<_>) = (0..u64::from(k))
            .map(|a| {
                random_move(
                    &mut rng,
                    (r * u64::from(k) + a) % BOARD_MOVE_KINDS,
                    100_000,
                    &p,
                )
            })
            .unzip();
        let dirs: Vec<bool> = (0..k).map(|a| (r + u64::from(a)) % 2 == 0).collect();
        let (log, rep, reads) = stream_group(b, &moves, &dirs, 128, 0, &name);
        for (i, y) in rep.iter().enumerate() {
            assert_eq!(y.status, Status::Ok, "{name}: reply {i}");
        }
        assert_eq!(log.go.len(), 1, "{name}: one group start");
        for (a, m) in moves.iter().enumerate() {
            let what = format!("{name} axis {a} ({:?})", mvs[a]);
            assert_eq!(rises_after_go(&log, a), m.edges, "{what}: edges");
            let st = AxisState::decode(rep[reads[a][0]].data).unwrap();
            assert_eq!(st.run, AxisRun::Idle, "{what}: no underrun ({st:?})");
            assert!(!st.stream_armed && !st.stream_fault, "{what}: {st:?}");
            let n = m.steps() as i64;
            let pos = multistep_hdl::link::position_count(rep[reads[a][1]].data, 0);
            assert_eq!(pos, if dirs[a] { n } else { -n }, "{what}: position");
            let dir_level = log.dir[a]
                .iter()
                .rfind(|e| e.cycle <= log.go[0])
                .is_some_and(|e| e.level);
            assert_eq!(dir_level, dirs[a], "{what}: DIR pin");
        }
    }
}

/// The nine kinds on the ULX3S-25F build at its largest K, 8 axes at once at its 3 Mbaud
/// (two rounds: every kind at least once).
#[test]
fn streamed_every_family_eight_axes_on_the_ulx3s() {
    let board = Board::by_name("ulx3s-25f").unwrap();
    let b = board.board_top(&board.params(8).unwrap());
    assert_eq!((b.core.axes, b.baud), (8, 3_000_000));
    every_family_on(&b, 2, 0x5eed_0001);
}

#[test]
fn streamed_every_family_two_axes() {
    every_family(2, 3, 0x5eed_0002);
}

/// A host that sends every chunk 12 ms late: the buffer runs dry, the axis underruns
/// and `State` says so; the edges before the first late one are exact, none is early.
#[test]
fn starved_link_is_flagged() {
    let p = params(1);
    let b = BoardTop::new(p.clone(), 3_000_000);
    let mv = Move::Limits(LimitsMove::scurve4(2600, 150_000.0, 5e7, 2e11, 1e15));
    let m = StreamedMove::plan(&mv, HZ, p.tick_bits).unwrap();
    assert!(
        m.bytes.len() as u64 > 2 * BUFFER,
        "the move outlasts its preload"
    );
    let (log, rep, reads) = stream_group(
        &b,
        std::slice::from_ref(&m),
        &[true],
        128,
        600_000,
        "starved",
    );
    let st = AxisState::decode(rep[reads[0][0]].data).unwrap();
    assert!(st.underrun && st.run == AxisRun::Underrun, "{st:?}");
    let got = rises_after_go(&log, 0);
    assert_eq!(got.len(), m.edges.len(), "every step made, late");
    let first_late = got.iter().zip(&m.edges).position(|(g, w)| g != w).unwrap();
    assert!(first_late > 16, "the preload ran exactly ({first_late})");
    // the core's link model with the same host predicts the same first late step
    use multistep_core::tdm::stream::{run, StreamAxisReport, StreamLink};
    let link = StreamLink {
        clock_hz: HZ as f64,
        baud: 3e6,
        buffer: BUFFER,
        frame: 128,
        host_delay: 600_000,
    };
    let mut out = [StreamAxisReport::default()];
    run(&link, &[&m.edges[..]], &mut out).unwrap();
    let predicted = out[0].first_underrun.expect("the model underruns too") as usize;
    assert!(
        predicted.abs_diff(first_late) <= 1,
        "model {predicted}, board {first_late}"
    );
    let on_time = StreamLink {
        host_delay: 0,
        ..link
    };
    run(&on_time, &[&m.edges[..]], &mut out).unwrap();
    assert_eq!(out[0].first_underrun, None, "on time, neither underruns");
    assert!(
        got.iter().zip(&m.edges).all(|(g, w)| g >= w),
        "no edge early"
    );
}

/// Representative moves of every family and mode at 50 MHz, up to 100 k steps/s.
fn representative() -> Vec<(&'static str, Move<'static>)> {
    let ph = |f| Move::Phase(PhaseMove::new(40_000, f, 0.1, 0.3, 0.1));
    let sp = |f| Move::Phase(PhaseMove::new(40_000, f, 0.1, 0.3, 0.1).with_speeds(5000.0, 2000.0));
    vec![
        ("trapezoid", ph(family(0))),
        ("parabolic", ph(family(1))),
        ("exponential", ph(family(2))),
        ("sine", ph(family(3))),
        ("scurve", ph(family(4))),
        ("scurve4", ph(family(5))),
        ("sine, start/end speeds", sp(family(3))),
        ("scurve4, start/end speeds", sp(family(5))),
        (
            "limits trapezoid",
            Move::Limits(LimitsMove::trapezoid(40_000, 1e5, 1e6)),
        ),
        (
            "limits scurve",
            Move::Limits(LimitsMove::scurve(40_000, 1e5, 1e6, 2e7)),
        ),
        (
            "limits scurve4",
            Move::Limits(LimitsMove::scurve4(40_000, 1e5, 1e6, 2e7, 1e9)),
        ),
    ]
}

/// The code's size: every family under 1 byte per step (the goal), about half a byte.
#[test]
fn bytes_per_step_of_every_family() {
    let mut total = (0u64, 0u64);
    for (name, mv) in representative() {
        let m = StreamedMove::plan(&mv, HZ, 24).unwrap();
        let link = m.bytes.len() as f64 * (1.0 + 8.0 / 128.0) / m.steps() as f64;
        eprintln!(
            "{name:28} {:6} steps {:7} bytes {:.3} B/step, {:.3} with 128-byte frames",
            m.steps(),
            m.bytes.len(),
            m.bytes_per_step(),
            link
        );
        assert!(m.bytes_per_step() < 0.75, "{name}: {}", m.bytes_per_step());
        total.0 += m.bytes.len() as u64;
        total.1 += m.steps();
    }
    assert!((total.0 as f64) < 0.6 * total.1 as f64, "{total:?}");
}

/// Ten-second moves (scurve4 and parabolic, about 1 M steps each at up to 100 k
/// steps/s) on K axes at once over the 3 Mbaud link, in the core's link model (the same
/// chunks the co-simulation sends; ten seconds are 5·10^8 clocks, too many to co-simulate here),
/// on both ULX3S builds (each at its clock, with its stream buffer): 4 axes keep up with
/// no underrun; the most axes that keep up is found, and one more underruns, flagged.
#[test]
fn ten_second_moves_over_three_megabaud() {
    for name in ["ulx3s-25f", "ulx3s-85f"] {
        let b = Board::by_name(name).unwrap();
        let most = ten_second_moves_on(b.clock_hz() as u64, 1 << b.stream_buffer_bits);
        eprintln!("{name}: the most axes that keep up: {most}");
    }
}

/// [`ten_second_moves_over_three_megabaud`] at `hz` with `buffer` bytes an axis: the most
/// axes that keep up.
fn ten_second_moves_on(hz: u64, buffer: u64) -> usize {
    use multistep_core::tdm::stream::{run, StreamAxisReport, StreamLink};
    let s4 = Move::Limits(LimitsMove::scurve4(900_000, 1e5, 1e5, 2e5, 1e6));
    let pa = Move::Phase(PhaseMove::new(880_000, Family::Parabolic, 2.0, 6.0, 2.0));
    let e4 = StreamedMove::plan(&s4, hz, 24).unwrap();
    let ep = StreamedMove::plan(&pa, hz, 24).unwrap();
    for m in [&e4, &ep] {
        let secs = *m.edges.last().unwrap() as f64 / hz as f64;
        assert!((9.5..11.0).contains(&secs), "{secs} s");
    }
    let link = StreamLink {
        clock_hz: hz as f64,
        baud: 3e6,
        buffer,
        frame: 128,
        host_delay: 0,
    };
    let go = |k: usize| {
        let axes: Vec<&[u64]> = (0..k)
            .map(|a| {
                if a % 2 == 0 {
                    &e4.edges[..]
                } else {
                    &ep.edges[..]
                }
            })
            .collect();
        let mut out = vec![StreamAxisReport::default(); k];
        let r = run(&link, &axes, &mut out).unwrap();
        (r, out)
    };
    let (r, out) = go(4);
    assert_eq!(r.underruns, 0, "{hz} Hz: {out:?}");
    eprintln!("{hz} Hz, 4 axes: {r:?}");
    let most = (4..=16)
        .take_while(|&k| go(k).0.underruns == 0)
        .last()
        .unwrap();
    let (r, out) = go(most + 1);
    eprintln!("{} underrun ({:?})", most + 1, out[0]);
    assert!(r.underruns > 0);
    assert!(out
        .iter()
        .all(|o| !matches!(o.first_underrun, Some(s) if s <= 16)));
    most
}

/// Bulk writes that must change nothing: one larger than the free space (status 7), one
/// with a bad CRC (status 1), one to a register that is not `StreamData` or to an axis
/// beyond K (3); the free count follows only the accepted ones; arming empties the buffer.
/// Each axis's free count and fit are its own (one subtractor serves them all): a frame
/// for axis 1 fits while axis 0's buffer is full.
#[test]
fn bad_bulk_writes_change_nothing() {
    use multistep_hdl::link::BulkWrite;
    let b = BoardTop::new(params(2), 3_000_000);
    let mut h = Host::new();
    let bulk = |h: &mut Host, addr: u16, len: usize, corrupt: bool| {
        let w = BulkWrite {
            seq: h.seq(),
            addr,
            data: (0..len).map(|i| i as u8).collect(),
        };
        let mut f = w.encode().unwrap();
        if corrupt {
            f[6] ^= 1;
        }
        h.frame(&f)
    };
    let data = Reg::Axis(0, AxisReg::StreamData).addr();
    h.write(Reg::Axis(0, AxisReg::StreamSteps), 50);
    let armed = h.read(Reg::Axis(0, AxisReg::StreamSteps));
    let f0 = h.read(Reg::Axis(0, AxisReg::StreamFree));
    let ok1 = bulk(&mut h, data, 255, false);
    let ok2 = bulk(&mut h, data, 255, false);
    let full = bulk(&mut h, data, 3, false);
    let crc = bulk(&mut h, data, 2, true);
    let wrong = bulk(&mut h, Reg::Axis(0, AxisReg::Position).addr(), 2, false);
    let beyond = bulk(&mut h, Reg::Axis(3, AxisReg::StreamData).addr(), 2, false);
    let other = bulk(&mut h, Reg::Axis(1, AxisReg::StreamData).addr(), 3, false);
    let f1 = h.read(Reg::Axis(0, AxisReg::StreamFree));
    let g1 = h.read(Reg::Axis(1, AxisReg::StreamFree));
    let plain = h.sent();
    h.write(Reg::Axis(0, AxisReg::StreamData), 7); // not by a plain write
    h.write(Reg::Axis(0, AxisReg::StreamSteps), 0);
    let disarmed = h.read(Reg::Axis(0, AxisReg::StreamSteps));
    let f2 = h.read(Reg::Axis(0, AxisReg::StreamFree));
    h.s.sync();
    let (_, rep) = h.run(&b, "bulk-bad", 2_000_000);
    let st = |i: usize| rep[i].status;
    assert_eq!((st(armed), rep[armed].data), (Status::Ok, 1));
    assert_eq!(rep[f0].data, 512);
    assert_eq!((st(ok1), rep[ok1].data), (Status::Ok, 257));
    assert_eq!((st(ok2), rep[ok2].data), (Status::Ok, 2));
    assert_eq!(st(full), Status::StreamFull);
    assert_eq!(st(crc), Status::BadCrc);
    assert_eq!(
        (st(wrong), st(beyond)),
        (Status::BadAddress, Status::BadAddress)
    );
    assert_eq!(rep[f1].data, 2, "only the accepted bulk writes count");
    assert_eq!((st(other), rep[other].data), (Status::Ok, 509));
    assert_eq!(rep[g1].data, 509, "axis 1's buffer is its own");
    assert_eq!(st(plain), Status::BadAddress);
    assert_eq!((st(disarmed), rep[disarmed].data), (Status::Ok, 0));
    assert_eq!(rep[f2].data, 512, "arming empties the buffer");
}

/// A board without replay units (`LB` = 0, as the iCEBreaker) frames a bulk write by its
/// length and answers it "no room" (status 7) without executing anything; the requests
/// around it are answered as usual.
#[test]
fn a_board_without_replay_units_answers_bulk_writes_no_room() {
    use multistep_hdl::link::BulkWrite;
    let mut b = BoardTop::new(params(1), 3_000_000);
    b.stream_buffer_bits = 0;
    let mut h = Host::new();
    h.write(Reg::Axis(0, AxisReg::Position), 77);
    // data bytes that look like frame starts must not resynchronize the link
    let w = BulkWrite {
        seq: h.seq(),
        addr: Reg::Axis(0, AxisReg::StreamData).addr(),
        data: vec![0xA5; 40],
    };
    let bulk = h.frame(&w.encode().unwrap());
    let pos = h.read(Reg::Axis(0, AxisReg::Position));
    h.s.sync();
    let (_, rep) = h.run(&b, "bulk-none", 1_000_000);
    assert_eq!(rep[0].status, Status::Ok);
    assert_eq!((rep[bulk].status, rep[bulk].seq), (Status::StreamFull, 1));
    assert_eq!((rep[pos].status, rep[pos].data), (Status::Ok, 77));
}

/// An open-ended stream (armed for the most steps, as a tracking host arms it) ends
/// cleanly when `StreamSteps` is written while it runs: after exactly that many steps,
/// every rise plan's, no underrun (without the write the axis would underrun, busy).
#[test]
fn an_open_ended_stream_ends_after_the_count_written_while_it_runs() {
    let p = params(2);
    let b = BoardTop::new(p.clone(), 3_000_000);
    let w = b.widths().unwrap();
    let mv = Move::Phase(PhaseMove::new(600, family(3), 0.001, 0.002, 0.001));
    let m = StreamedMove::plan(&mv, HZ, p.tick_bits).unwrap();
    let mut h = Host::new();
    h.write(Reg::Core(core_addr(&w, true, 0, 1)), 1 << 31);
    h.write(Reg::Axis(0, AxisReg::StreamSteps), u32::MAX);
    let mut later = Vec::new();
    for c in m.chunks(BUFFER, 128) {
        match c.not_before {
            None => send_chunk(&mut h, &m, 0, c.range),
            Some(t) => later.push((t, c.range)),
        }
    }
    h.write(Reg::Board(BoardReg::Start), 1);
    // the count arrives while the first steps run
    h.s.at_move_tick(m.edges[20]);
    let close = h.sent();
    h.write(Reg::Axis(0, AxisReg::StreamSteps), m.steps() as u32);
    for (t, r) in later {
        h.s.at_move_tick(t);
        send_chunk(&mut h, &m, 0, r);
    }
    h.s.sync().idle();
    let state = h.read(Reg::Axis(0, AxisReg::State));
    let pos = h.read(Reg::Axis(0, AxisReg::Position));
    h.s.sync();
    let end = *m.edges.last().unwrap();
    let (log, rep) = h.run(&b, "open", end + 2_000_000);
    assert!(rep.iter().all(|r| r.status == Status::Ok), "{rep:?}");
    assert_eq!(
        rep[close].status,
        Status::Ok,
        "the count taken while running"
    );
    let st = AxisState::decode(rep[state].data).unwrap();
    assert!(
        !st.busy && !st.underrun && st.run == AxisRun::Idle,
        "{st:?}"
    );
    assert_eq!(rep[pos].data, 600, "Position");
    assert_eq!(
        rises_after_go(&log, 0),
        m.edges,
        "every rise plan's, no more"
    );
}
