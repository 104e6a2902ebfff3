//! Co-simulation of the whole board (`ms_board`, UART included) in Icarus Verilog, driven
//! by the Rust host link (`multistep_hdl::link`): frames in, replies decoded, every STEP
//! edge against `multistep_core::int`. Needs `iverilog` (a missing tool fails).

mod common;

use common::{params, random_move, IntMove, Rng};
use multistep_core::int::IntEdgeGenerator;
use multistep_hdl::board_sim::{simulate, BoardLog, Script};
use multistep_hdl::link::{
    move_writes, requests, start_write, AxisReg, BoardReg, BuildId, Reg, Reply, Request, Status,
};
use multistep_hdl::{AxisMove, BoardTop, CoreParams};

/// Clocks from the group's `go` to a STEP pin's rise at move tick t: the pin rises after
/// clock edge go + t + TICK0 (the pulse unit's register and the pin's register).
const TICK0: u64 = 1;

fn board(p: CoreParams, baud: u32) -> BoardTop {
    BoardTop::new(p, baud)
}

fn run(b: &BoardTop, s: &Script, name: &str, timeout: u64) -> BoardLog {
    let dir = tempfile::Builder::new().prefix(name).tempdir().unwrap();
    // MS_BOARD_KEEP=1 keeps the simulation directory (its path is printed)
    let path = if std::env::var_os("MS_BOARD_KEEP").is_some() {
        let p = dir.keep();
        eprintln!("{name}: {}", p.display());
        p
    } else {
        dir.path().to_path_buf()
    };
    simulate(b, s, &path, timeout).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The replies, which must all decode and answer `reqs` in order.
fn answers(log: &BoardLog, reqs: &[Request], name: &str) -> Vec<Reply> {
    let got: Vec<Reply> = log
        .replies()
        .into_iter()
        .map(|r| r.unwrap_or_else(|e| panic!("{name}: {e}")))
        .collect();
    assert_eq!(got.len(), reqs.len(), "{name}: reply count");
    for (r, q) in got.iter().zip(reqs) {
        assert_eq!(r.seq, q.seq, "{name}: reply order");
    }
    got
}

/// A script that sends `reqs` back to back and waits for the replies.
struct Host {
    s: Script,
    reqs: Vec<Request>,
    seq: u8,
}

impl Host {
    fn new() -> Host {
        Host {
            s: Script::new(),
            reqs: Vec::new(),
            seq: 0,
        }
    }
    fn write(&mut self, reg: Reg, data: u32) -> usize {
        let r = Request::write(self.seq, reg, data);
        self.push(r)
    }
    fn read(&mut self, reg: Reg) -> usize {
        let r = Request::read(self.seq, reg);
        self.push(r)
    }
    fn push(&mut self, r: Request) -> usize {
        self.seq = self.seq.wrapping_add(1);
        self.s.send(&r);
        self.reqs.push(r);
        self.reqs.len() - 1
    }
    fn writes(&mut self, ws: &[multistep_hdl::link::RegWrite]) {
        for w in ws {
            self.write(w.reg, w.data);
        }
    }
}

/// Moves of every kind (random segments, phase and limits trapezoids with start and end
/// speeds) on K axes through the link: every STEP rise at `go + edge + TICK0`, the 50 %
/// falls, DIR pins, replies, and the readback (state, position, period) after the move.
fn link_moves(k: u32, seed: u64, baud: u32, ticks: u64) {
    let name = format!("board-k{k}");
    let p = params(k);
    let b = board(p.clone(), baud);
    let mut rng = Rng(seed);
    let interval = p.widths().unwrap().latencies().interval();
    let vmax = (50_000_000 / (interval * u64::from(k) * 3 / 2)).min(150_000);
    let moves: Vec<(IntMove, AxisMove)> = (0..k)
        .map(|_| random_move(&mut rng, &p, vmax, ticks))
        .collect();
    let mut h = Host::new();
    let id = [
        h.read(Reg::Board(BoardReg::Id)),
        h.read(Reg::Board(BoardReg::Config)),
        h.read(Reg::Board(BoardReg::Widths)),
        h.read(Reg::Board(BoardReg::ClockHz)),
        h.read(Reg::Board(BoardReg::Baud)),
    ];
    for (a, (_, m)) in moves.iter().enumerate() {
        h.writes(&move_writes(&p, a as u32, m, 0).unwrap());
    }
    let start = h.write(start_write((1 << k) - 1).reg, (1 << k) - 1);
    h.s.sync().idle();
    let reads: Vec<[usize; 3]> = (0..k)
        .map(|a| {
            [
                h.read(Reg::Axis(a, AxisReg::State)),
                h.read(Reg::Axis(a, AxisReg::Position)),
                h.read(Reg::Axis(a, AxisReg::Period)),
            ]
        })
        .collect();
    h.s.sync();
    let log = run(&b, &h.s, &name, 30_000_000);
    let rep = answers(&log, &h.reqs, &name);
    for (i, r) in rep.iter().enumerate() {
        assert_eq!(r.status, Status::Ok, "{name}: request {i} {:?}", h.reqs[i]);
    }
    let bid = BuildId::decode(
        rep[id[0]].data,
        rep[id[1]].data,
        rep[id[2]].data,
        rep[id[3]].data,
        rep[id[4]].data,
    )
    .unwrap();
    assert_eq!(bid, BuildId::of(&p, baud).unwrap(), "{name}: build id");
    let _ = start;
    assert_eq!(log.go.len(), 1, "{name}: one group start");
    let go = log.go[0];
    for (a, (im, m)) in moves.iter().enumerate() {
        let want: Vec<u64> = IntEdgeGenerator::new(im.profile()).collect();
        let rises: Vec<u64> = log.rises(a, true).iter().map(|c| c - go - TICK0).collect();
        assert_eq!(rises, want, "{name}: axis {a} edges");
        let falls: Vec<u64> = log.rises(a, false).iter().map(|c| c - go - TICK0).collect();
        assert_eq!(falls, half_interval_falls(&want), "{name}: axis {a} falls");
        let st = rep[reads[a][0]].data;
        assert_eq!(st & 7, 0, "{name}: axis {a} idle after the move ({st:#x})");
        let n = want.len() as i64;
        let pos = rep[reads[a][1]].data as i32 as i64;
        assert_eq!(pos, if m.dir { n } else { -n }, "{name}: axis {a} position");
        let last = want.len() - 1;
        let per = if last > 0 {
            want[last] - want[last - 1]
        } else {
            0
        };
        assert_eq!(
            u64::from(rep[reads[a][2]].data),
            per,
            "{name}: axis {a} period"
        );
        let dir_level = log.dir[a].last().map_or(false, |e| e.level);
        assert_eq!(dir_level, m.dir, "{name}: axis {a} DIR pin");
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

#[test]
fn one_axis_at_three_megabaud() {
    link_moves(1, 0x0b0a_0001, 3_000_000, 60_000);
}

#[test]
fn smoke() {
    let b = board(params(1), 3_000_000);
    let mut h = Host::new();
    h.read(Reg::Board(BoardReg::Id));
    h.s.sync();
    let log = run(&b, &h.s, "smoke", 200_000);
    let rep = answers(&log, &h.reqs, "smoke");
    assert_eq!(rep[0].data >> 16, 0x4D53);
}
