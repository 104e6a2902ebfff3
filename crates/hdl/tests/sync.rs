//! The cross-board group start in Icarus Verilog: two `ms_board`s on their own clocks
//! (different power-up instants, so different free-running counts; one test also a
//! different rate), their SYNC pins wired as one open-drain line. Moves are armed on both,
//! one board fires: every board starts its group at its own third clock edge after the
//! line fell, so the starts differ by less than the longest clock period, and each
//! board's `SyncTick` is its count at the fall plus the synchronizer's 2 clocks, so the
//! host reads every board's clock offset at one instant.

mod common;

use common::{params, random_move, Rng};
use multistep_core::int::IntEdgeGenerator;
use multistep_hdl::link::{move_writes, BoardReg, Reg, Reply, Request, Status};
use multistep_hdl::sync_sim::{simulate_boards, MultiLog, MultiScript, SimClock};
use multistep_hdl::{BoardTop, CoreParams};

/// The synchronizer's latency: `SyncTick` = the count at the line's fall + 2.
const SYNC_LAG: u64 = 2;

struct Host {
    s: MultiScript,
    reqs: Vec<Vec<Request>>,
    seq: u8,
}

impl Host {
    fn new(n: usize) -> Host {
        Host {
            s: MultiScript::new(n),
            reqs: vec![Vec::new(); n],
            seq: 0,
        }
    }
    fn push(&mut self, b: usize, r: Request) -> usize {
        self.seq = self.seq.wrapping_add(1);
        self.s.send(b, &r);
        self.reqs[b].push(r);
        self.reqs[b].len() - 1
    }
    fn write(&mut self, b: usize, reg: Reg, data: u32) -> usize {
        let r = Request::write(self.seq, reg, data);
        self.push(b, r)
    }
    fn read(&mut self, b: usize, reg: Reg) -> usize {
        let r = Request::read(self.seq, reg);
        self.push(b, r)
    }
}

fn run(boards: &[(BoardTop, SimClock)], s: &MultiScript, name: &str) -> MultiLog {
    let (_dir, path) = common::host::sim_dir(name);
    simulate_boards(boards, s, &path, 20_000_000_000).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn answers(log: &MultiLog, h: &Host, b: usize, name: &str) -> Vec<Reply> {
    let got: Vec<Reply> = log
        .replies(b)
        .into_iter()
        .map(|r| r.unwrap_or_else(|e| panic!("{name}: board {b}: {e}")))
        .collect();
    assert_eq!(got.len(), h.reqs[b].len(), "{name}: board {b} reply count");
    for (r, q) in got.iter().zip(&h.reqs[b]) {
        assert_eq!(r.seq, q.seq, "{name}: board {b} reply order");
    }
    got
}

/// Two boards, K axes each, every axis with a random move; armed on both, fired `fires`
/// times from board `firer` (the first fire starts the groups, later ones only latch
/// `SyncTick`). Returns the skew of the group starts (ps, board 1 − board 0) and each
/// fire's SyncTicks.
fn two_boards(
    clocks: [SimClock; 2],
    firer: usize,
    fires: usize,
    seed: u64,
    name: &str,
) -> (i64, Vec<[u64; 2]>) {
    let k = 2;
    let p: CoreParams = params(k);
    let baud = 12_500_000;
    let boards: Vec<(BoardTop, SimClock)> = clocks
        .iter()
        .map(|&c| (BoardTop::new(p.clone(), baud), c))
        .collect();
    let mut rng = Rng(seed);
    let mut h = Host::new(2);
    let mut moves = Vec::new();
    for b in 0..2 {
        let ms: Vec<_> = (0..k)
            .map(|_| random_move(&mut rng, &p, 100_000, 8_000))
            .collect();
        for (a, (_, m)) in ms.iter().enumerate() {
            for w in move_writes(&p, a as u32, m, 0).unwrap() {
                h.write(b, w.reg, w.data);
            }
        }
        h.write(b, Reg::Board(BoardReg::Arm), 0b11);
        moves.push(ms);
    }
    // a start while the armed group waits is refused, and changes nothing
    let refused = h.write(1, Reg::Board(BoardReg::Start), 0b01);
    h.s.sync().delay_ns(20_000);
    let st0: Vec<usize> = (0..2)
        .map(|b| h.read(b, Reg::Board(BoardReg::Status)))
        .collect();
    h.s.sync();
    let mut ticks = Vec::new();
    for f in 0..fires {
        h.write(firer, Reg::Board(BoardReg::Fire), 1);
        h.s.sync();
        if f == 0 {
            h.s.idle(0).idle(1);
        } else {
            h.s.delay_ns(5_000);
        }
        ticks.push([
            h.read(0, Reg::Board(BoardReg::SyncTick)),
            h.read(1, Reg::Board(BoardReg::SyncTick)),
        ]);
        h.s.sync();
    }
    let st1: Vec<usize> = (0..2)
        .map(|b| h.read(b, Reg::Board(BoardReg::Status)))
        .collect();
    h.s.sync();
    let log = run(&boards, &h.s, name);
    let rep: Vec<Vec<Reply>> = (0..2).map(|b| answers(&log, &h, b, name)).collect();
    for b in 0..2 {
        for (i, r) in rep[b].iter().enumerate() {
            let want = if b == 1 && i == refused {
                Status::Busy
            } else {
                Status::Ok
            };
            assert_eq!(r.status, want, "{name}: board {b} request {i}");
        }
        // armed (bit 3), pending (2), ready (6), line high (5); after: none, not late
        assert_eq!(
            rep[b][st0[b]].data & 0x7C,
            0x6C,
            "{name}: board {b} status armed"
        );
        assert_eq!(
            rep[b][st1[b]].data & 0x7C,
            0x20,
            "{name}: board {b} status after"
        );
    }
    assert_eq!(log.sync_falls.len(), fires, "{name}: one fall per fire");
    let mut sync_ticks = Vec::new();
    for (f, (t, frees)) in log.sync_falls.iter().enumerate() {
        let got = [rep[0][ticks[f][0]].data, rep[1][ticks[f][1]].data];
        for b in 0..2 {
            // the testbench's count is the clock's edges before the fall (an independent
            // reference for the offset), and SyncTick is that count + the synchronizer
            assert_eq!(
                frees[b],
                clocks[b].edges_by(*t),
                "{name}: board {b} count at fall {f}"
            );
            assert_eq!(
                u64::from(got[b]),
                (frees[b] + SYNC_LAG) & 0xFFFF_FFFF,
                "{name}: board {b} SyncTick at fall {f}"
            );
        }
        sync_ticks.push([u64::from(got[0]), u64::from(got[1])]);
    }
    // one group start per board, at the fall's third own clock edge
    let t_fall = log.sync_falls[0].0;
    let mut go = [0u64; 2];
    for b in 0..2 {
        assert_eq!(log.go[b].len(), 1, "{name}: board {b} one group start");
        let g = log.go[b][0];
        assert_eq!(
            g.free,
            log.sync_falls[0].1[b] + SYNC_LAG,
            "{name}: board {b} go edge"
        );
        let c = clocks[b];
        assert!(
            g.ps > t_fall + 2 * c.period_ps && g.ps <= t_fall + 3 * c.period_ps,
            "{name}"
        );
        go[b] = g.ps;
        // every STEP rise at go + (t + 1) clock periods of the board's own clock
        for (a, (im, _)) in moves[b].iter().enumerate() {
            let want: Vec<u64> = IntEdgeGenerator::new(im.profile())
                .map(|t| g.ps + (t + 1) * c.period_ps)
                .collect();
            assert_eq!(log.rises(b, a), want, "{name}: board {b} axis {a} rises");
        }
    }
    let skew = go[1] as i64 - go[0] as i64;
    let bound = clocks.iter().map(|c| c.period_ps).max().unwrap() as i64;
    assert!(skew.abs() < bound, "{name}: start skew {skew} ps");
    (skew, sync_ticks)
}

/// Board 1 powers up 1000 clocks and 7 ns after board 0 (same 50 MHz): its count is 1000
/// (or 1001, between the two edges) behind at every instant; board 0 fires.
#[test]
fn two_boards_start_together_and_latch_their_offset() {
    let c0 = SimClock {
        period_ps: 20_000,
        start_ps: 0,
    };
    let c1 = SimClock {
        period_ps: 20_000,
        start_ps: 1000 * 20_000 + 7_000,
    };
    let (skew, ticks) = two_boards([c0, c1], 0, 1, 0x5_1c01, "sync-offset");
    let off = ticks[0][0] as i64 - ticks[0][1] as i64;
    assert!(off == 1000 || off == 1001, "offset {off}");
    eprintln!("sync-offset: start skew {skew} ps, SyncTick offset {off} ticks");
}

/// Board 1's clock is 100 ppm slow (20 002 ps) and board 1 fires; a second fire, with no
/// group armed, starts nothing and latches both counts again: their differences match the
/// clock ratio within a tick of quantization.
#[test]
fn two_boards_at_different_rates_fired_from_the_second() {
    let c0 = SimClock {
        period_ps: 20_000,
        start_ps: 3_000,
    };
    let c1 = SimClock {
        period_ps: 20_002,
        start_ps: 500 * 20_000 + 13_000,
    };
    let (skew, ticks) = two_boards([c0, c1], 1, 2, 0x5_1c02, "sync-rate");
    let d0 = ticks[1][0] - ticks[0][0];
    let d1 = ticks[1][1] - ticks[0][1];
    // d0 / d1 = 20 002 / 20 000 within one tick of quantization on each count
    let lhs = d0 as i128 * 20_000;
    let rhs = d1 as i128 * 20_002;
    assert!((lhs - rhs).abs() <= 2 * 20_002, "d0 {d0} d1 {d1}");
    eprintln!("sync-rate: start skew {skew} ps, {d0} and {d1} ticks between the fires");
}

/// A board built without the SYNC line answers Arm, Fire, SyncTick and ArmTimeout with "unknown
/// register" and starts nothing; a board with it refuses an empty Arm mask.
#[test]
fn boards_without_sync_refuse_arm_fire_and_sync_tick() {
    let name = "sync-none";
    let p = params(1);
    let mut plain = BoardTop::new(p.clone(), 12_500_000);
    plain.sync = false;
    let clock = SimClock {
        period_ps: 20_000,
        start_ps: 0,
    };
    let with = BoardTop::new(p, 12_500_000);
    let mut h = Host::new(2);
    let refused = [
        h.write(0, Reg::Board(BoardReg::Arm), 1),
        h.write(0, Reg::Board(BoardReg::Fire), 1),
        h.read(0, Reg::Board(BoardReg::SyncTick)),
        h.write(0, Reg::Board(BoardReg::ArmTimeout), 1),
        h.read(0, Reg::Board(BoardReg::ArmTimeout)),
    ];
    let empty = h.write(1, Reg::Board(BoardReg::Arm), 0);
    let beyond = h.write(1, Reg::Board(BoardReg::Arm), 0b10);
    let read_fire = h.read(1, Reg::Board(BoardReg::Fire));
    h.s.sync().delay_ns(2_000);
    let log = run(&[(plain, clock), (with, clock)], &h.s, name);
    let r0 = answers(&log, &h, 0, name);
    let r1 = answers(&log, &h, 1, name);
    for i in refused {
        assert_eq!(r0[i].status, Status::BadAddress, "{name}: request {i}");
    }
    assert_eq!(r1[empty].status, Status::BadValue, "{name}: empty mask");
    assert_eq!(r1[beyond].status, Status::BadValue, "{name}: mask beyond K");
    assert_eq!(
        r1[read_fire].status,
        Status::BadAddress,
        "{name}: Fire is write only"
    );
    assert!(
        log.sync_falls.is_empty() && log.go.iter().all(Vec::is_empty),
        "{name}"
    );
}

/// A fire before the armed group is ready (here: inside a 20 000-clock DIR setup) starts
/// it as soon as it is, with Status's late bit; a Stop cancels an armed group, so a later
/// fire starts nothing.
#[test]
fn a_fire_before_ready_starts_late_and_a_stop_cancels_an_armed_group() {
    let name = "sync-late";
    let p = params(1);
    let clock = SimClock {
        period_ps: 20_000,
        start_ps: 0,
    };
    let boards = [(BoardTop::new(p.clone(), 12_500_000), clock)];
    let mut rng = Rng(0x5_1c03);
    let (im, m) = random_move(&mut rng, &p, 100_000, 8_000);
    let mut h = Host::new(1);
    h.write(0, Reg::Board(BoardReg::DirSetup), 20_000);
    for w in move_writes(&p, 0, &m, 0).unwrap() {
        h.write(0, w.reg, w.data);
    }
    h.write(0, Reg::Board(BoardReg::Arm), 1);
    h.write(0, Reg::Board(BoardReg::Fire), 1);
    h.s.sync().idle(0);
    let late = h.read(0, Reg::Board(BoardReg::Status));
    let tick = h.read(0, Reg::Board(BoardReg::SyncTick));
    // armed again, stopped, fired: nothing starts
    for w in move_writes(&p, 0, &m, 0).unwrap() {
        h.write(0, w.reg, w.data);
    }
    h.write(0, Reg::Board(BoardReg::Arm), 1);
    h.write(0, Reg::Board(BoardReg::Stop), 1);
    h.write(0, Reg::Board(BoardReg::Fire), 1);
    h.s.sync().delay_ns(2_000);
    let after = h.read(0, Reg::Board(BoardReg::Status));
    h.s.sync();
    let log = run(&boards, &h.s, name);
    let rep = answers(&log, &h, 0, name);
    for (i, r) in rep.iter().enumerate() {
        assert_eq!(r.status, Status::Ok, "{name}: request {i}");
    }
    // late (bit 4), nothing pending or armed, the line idle
    assert_eq!(rep[late].data & 0x7C, 0x30, "{name}: late status");
    assert_eq!(rep[after].data & 0x08, 0, "{name}: the stop disarmed");
    assert_eq!(log.sync_falls.len(), 2, "{name}: two fires");
    assert_eq!(log.go[0].len(), 1, "{name}: only the first group starts");
    let (fall, frees) = &log.sync_falls[0];
    assert_eq!(
        u64::from(rep[tick].data),
        frees[0] + SYNC_LAG,
        "{name}: SyncTick"
    );
    let g = log.go[0][0];
    // the group waited out its DIR setup, far past the fall
    assert!(
        g.free > frees[0] + SYNC_LAG + 15_000,
        "{name}: go {g:?}, fall {frees:?}"
    );
    let want: Vec<u64> = IntEdgeGenerator::new(im.profile())
        .map(|t| g.ps + (t + 1) * clock.period_ps)
        .collect();
    assert_eq!(log.rises(0, 0), want, "{name}: rises after the late start");
    assert!(g.ps > *fall, "{name}");
}

/// ArmTimeout bounds how long a group stays armed: past it, with no SYNC edge, the group
/// is cut (the board goes idle with nothing started), Status bit 7 says so, and a later
/// fire starts nothing; the next Arm clears the bit, and with no bound a fire starts it.
#[test]
fn an_armed_group_past_its_arm_timeout_is_cut_and_a_later_fire_starts_nothing() {
    let name = "sync-arm-timeout";
    let p = params(1);
    let clock = SimClock {
        period_ps: 20_000,
        start_ps: 0,
    };
    let boards = [(BoardTop::new(p.clone(), 12_500_000), clock)];
    let mut rng = Rng(0x5_1c04);
    let (im, m) = random_move(&mut rng, &p, 100_000, 8_000);
    let mut h = Host::new(1);
    // 5000 clocks: 100 us at 50 MHz
    h.write(0, Reg::Board(BoardReg::ArmTimeout), 5_000);
    let timeout = h.read(0, Reg::Board(BoardReg::ArmTimeout));
    for w in move_writes(&p, 0, &m, 0).unwrap() {
        h.write(0, w.reg, w.data);
    }
    h.write(0, Reg::Board(BoardReg::Arm), 1);
    h.s.sync().delay_ns(40_000);
    let armed = h.read(0, Reg::Board(BoardReg::Status));
    h.s.sync().idle(0);
    let cut = h.read(0, Reg::Board(BoardReg::Status));
    let busy = h.read(0, Reg::Board(BoardReg::Busy));
    h.write(0, Reg::Board(BoardReg::Fire), 1);
    h.s.sync().delay_ns(2_000);
    let after_fire = h.read(0, Reg::Board(BoardReg::Status));
    // no bound: armed again, the bit cleared, and the fire starts it
    h.write(0, Reg::Board(BoardReg::ArmTimeout), 0);
    for w in move_writes(&p, 0, &m, 0).unwrap() {
        h.write(0, w.reg, w.data);
    }
    h.write(0, Reg::Board(BoardReg::Arm), 1);
    h.s.sync().delay_ns(200_000);
    let rearmed = h.read(0, Reg::Board(BoardReg::Status));
    h.write(0, Reg::Board(BoardReg::Fire), 1);
    h.s.sync().idle(0);
    h.read(0, Reg::Board(BoardReg::Status));
    h.s.sync();
    let log = run(&boards, &h.s, name);
    let rep = answers(&log, &h, 0, name);
    for (i, r) in rep.iter().enumerate() {
        assert_eq!(r.status, Status::Ok, "{name}: request {i}");
    }
    assert_eq!(rep[timeout].data, 5_000, "{name}: ArmTimeout reads back");
    // bits 7 expired, 3 armed, 2 pending
    assert_eq!(
        rep[armed].data & 0x8C,
        0x0C,
        "{name}: armed within the bound"
    );
    assert_eq!(rep[cut].data & 0x8C, 0x80, "{name}: cut past it");
    assert_eq!(rep[busy].data, 0, "{name}: no axis busy after the cut");
    assert_eq!(
        rep[after_fire].data & 0x8C,
        0x80,
        "{name}: the fire started nothing"
    );
    assert_eq!(rep[rearmed].data & 0x8C, 0x0C, "{name}: Arm clears the bit");
    assert_eq!(log.sync_falls.len(), 2, "{name}: two fires");
    assert_eq!(log.go[0].len(), 1, "{name}: only the second group starts");
    let g = log.go[0][0];
    assert!(
        g.ps > log.sync_falls[1].0,
        "{name}: started by the second fire"
    );
    assert!(
        log.rises(0, 0).iter().all(|&t| t > g.ps),
        "{name}: no step before it"
    );
    let want: Vec<u64> = IntEdgeGenerator::new(im.profile())
        .map(|t| g.ps + (t + 1) * clock.period_ps)
        .collect();
    assert_eq!(log.rises(0, 0), want, "{name}: rises of the second group");
}
