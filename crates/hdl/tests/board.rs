//! Co-simulation of the whole board (`ms_board`, UART included) in Verilator (or Icarus
//! Verilog, `MULTISTEP_SIM=icarus`), driven by the Rust host link (`multistep_hdl::link`):
//! frames in, replies decoded, every STEP edge against `multistep_core::int`. Needs
//! `verilator` and `iverilog` (a missing tool fails).

mod common;

use common::host::{half_interval_falls, Host};
use common::{params, random_move, random_move_of, IntMove, Rng, CLOCK, HZ};
use multistep_core::int::{IntEdgeGenerator, IntProfile, IntSegment};
use multistep_core::tdm::{Axis, Board, TdmConfig};
use multistep_core::{PulseShape, StepDirTiming};
use multistep_hdl::link::{
    move_writes, start_write, stop_ramp_writes, AxisReg, AxisRun, AxisState, BoardReg, BuildId,
    Levels, Reg, Request, Status,
};
use multistep_hdl::{AxisMove, BoardTop, CoreParams};

/// Clocks from the group's `go` to a STEP pin's rise at move tick t: the pin rises after
/// clock edge go + t + TICK0 (the pulse unit's register and the pin's register).
const TICK0: u64 = 1;

fn board(p: CoreParams, baud: u32) -> BoardTop {
    BoardTop {
        // ECP5's build: the calculator reads dy from distributed RAM without a clock
        lutram: p.axes == 8,
        ..BoardTop::new(p, baud)
    }
}

/// Moves of every kind (segment chains, phase and limits trapezoids, with random start
/// and end speeds; axis a of round r runs kind (r·K + a) mod 3) on K axes through the
/// link, `rounds` groups one after the other: every STEP rise at `go + edge + TICK0`, the
/// 50 % falls, DIR pins, replies, and the readback (state, position, period) after each.
fn link_moves(k: u32, rounds: u32, seed: u64, baud: u32, ticks: u64) {
    link_moves_on(params(k), &format!("board-k{k}"), rounds, seed, baud, ticks);
}

fn link_moves_on(p: CoreParams, name: &str, rounds: u32, seed: u64, baud: u32, ticks: u64) {
    let k = p.axes;
    let name = name.to_string();
    let b = board(p.clone(), baud);
    let mut rng = Rng(seed);
    let interval = p.widths().unwrap().latencies().interval();
    let vmax = (50_000_000 / (interval * u64::from(k) * 3 / 2)).min(150_000);
    let mut h = Host::new();
    let id = [
        h.read(Reg::Board(BoardReg::Id)),
        h.read(Reg::Board(BoardReg::Config)),
        h.read(Reg::Board(BoardReg::Widths)),
        h.read(Reg::Board(BoardReg::ClockHz)),
        h.read(Reg::Board(BoardReg::Baud)),
    ];
    let mut all = Vec::new();
    for r in 0..rounds {
        let moves: Vec<(IntMove, AxisMove)> = (0..k)
            .map(|a| random_move_of(&mut rng, &p, vmax, ticks, u64::from(r * k + a)))
            .collect();
        for (a, (_, m)) in moves.iter().enumerate() {
            h.writes(&move_writes(&p, a as u32, m, 0).unwrap());
        }
        let all_axes = ((1u64 << k) - 1) as u32;
        let s = start_write(all_axes);
        h.write(s.reg, s.data);
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
        all.push((moves, reads));
    }
    let (log, rep) = h.run(&b, &name, 30_000_000);
    for (i, r) in rep.iter().enumerate() {
        assert_eq!(r.status, Status::Ok, "{name}: request {i}");
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
    assert_eq!(
        log.go.len(),
        rounds as usize,
        "{name}: one group start per round"
    );
    let mut position = vec![0i64; k as usize];
    for (r, (moves, reads)) in all.iter().enumerate() {
        let go = log.go[r];
        let end = log.go.get(r + 1).copied().unwrap_or(u64::MAX);
        let window = |v: Vec<u64>| -> Vec<u64> {
            v.iter()
                .filter(|&&c| c > go && c < end)
                .map(|c| c - go - TICK0)
                .collect()
        };
        for (a, (im, m)) in moves.iter().enumerate() {
            let want: Vec<u64> = IntEdgeGenerator::new(im.profile()).collect();
            assert_eq!(
                window(log.rises(a, true)),
                want,
                "{name}: round {r} axis {a} edges ({im:?})"
            );
            assert_eq!(
                window(log.rises(a, false)),
                half_interval_falls(&want),
                "{name}: round {r} axis {a} falls"
            );
            let st = rep[reads[a][0]].data;
            assert_eq!(st & 7, 0, "{name}: axis {a} idle after the move ({st:#x})");
            let n = want.len() as i64;
            position[a] += if m.dir { n } else { -n };
            let pos = multistep_hdl::link::position_count(rep[reads[a][1]].data, 0);
            assert_eq!(pos, position[a], "{name}: round {r} axis {a} position");
            // the period the pulse unit timed last: the move's last (its only one: from
            // the go to the edge)
            let last = want.len() - 1;
            let per = if last > 0 {
                want[last] - want[last - 1]
            } else {
                want[0]
            };
            assert_eq!(
                u64::from(rep[reads[a][2]].data),
                per,
                "{name}: axis {a} period"
            );
            // the DIR pin during the move: its level at the group's start
            let dir_level = log.dir[a]
                .iter()
                .rfind(|e| e.cycle <= go)
                .is_some_and(|e| e.level);
            assert_eq!(dir_level, m.dir, "{name}: round {r} axis {a} DIR pin");
        }
    }
}

#[test]
fn one_axis_three_kinds_at_three_megabaud() {
    link_moves(1, 3, 0x0b0a_0001, 3_000_000, 60_000);
}

#[test]
fn two_axes_two_rounds_at_three_megabaud() {
    link_moves(2, 2, 0x0b0a_0002, 3_000_000, 80_000);
}

/// The ULX3S build's K = 8 (with its dy memory in distributed RAM) at its 3 Mbaud host
/// link.
#[test]
fn eight_axes() {
    link_moves(8, 1, 0x0b0a_0008, 3_000_000, 100_000);
}

/// The iCEBreaker build's core (its narrow widths, radix 2, FIFO depth 2, 18 MHz, from
/// `boards.rs`) at its most axes, with a 3 Mbaud host link (6 clocks per bit).
#[test]
fn icebreaker_widths_at_its_axis_count() {
    let b = multistep_hdl::boards::Board::by_name("icebreaker").unwrap();
    let p = b.params(b.max_axes).unwrap();
    link_moves_on(p, "board-ice", 1, 0x0b0a_1ce4, 3_000_000, 20_000);
}

/// The core TDM model with a STEP pulse width and DIR setup time: rises and falls from
/// its start, and its start tick.
fn model(
    p: &CoreParams,
    moves: &[IntMove],
    step_dir: StepDirTiming,
) -> (Vec<Vec<(u64, u64)>>, u64) {
    let w = p.widths().unwrap();
    let mut axes: Vec<Axis> = moves
        .iter()
        .map(|m| Axis::new(m.float_profile(), HZ as f64).unwrap())
        .collect();
    let cfg = TdmConfig {
        clock_hz: HZ as f64,
        fifo_depth: p.fifo_depth as usize,
        latencies: w.latencies(),
        step_dir,
        ..Default::default()
    };
    let board = Board::new(cfg, &mut axes).unwrap();
    let start = board.start_tick();
    let mut pulses = vec![Vec::new(); moves.len()];
    let rep = board.run(|sp| pulses[sp.axis].push((sp.rise - start, sp.fall - start)));
    assert_eq!(rep.underruns, 0);
    for v in &mut pulses {
        v.sort_unstable();
    }
    (pulses, start)
}

/// A fixed STEP width and a DIR setup time longer than the prefill, with STEP, DIR and
/// ENABLE active low: pins against the core TDM model with `PulseShape::Fixed` and
/// `dir_setup_ticks` (rises, falls, the group's start), DIR before the first STEP.
#[test]
fn fixed_pulse_width_dir_setup_and_active_low_pins() {
    let name = "board-pulse";
    let (k, width, setup) = (2u32, 7u32, 5_000u64);
    let p = params(k);
    let b = board(p.clone(), 3_000_000);
    let mut rng = Rng(0x0b0a_0077);
    let moves: Vec<(IntMove, AxisMove)> = (0..k)
        .map(|_| random_move(&mut rng, &p, 120_000, 60_000))
        .collect();
    let low = Levels {
        step: false,
        dir: false,
        enable: false,
        ..Levels::default()
    };
    let mut h = Host::new();
    h.write(Reg::Board(BoardReg::PulseWidth), width);
    h.write(Reg::Board(BoardReg::DirSetup), setup as u32);
    h.write(Reg::Board(BoardReg::Levels), low.bits());
    h.write(Reg::Board(BoardReg::Enable), 0b11);
    for (a, (_, m)) in moves.iter().enumerate() {
        h.writes(&move_writes(&p, a as u32, m, width).unwrap());
    }
    h.write(Reg::Board(BoardReg::Start), 0b11);
    h.s.sync().idle();
    let (log, rep) = h.run(&b, name, 5_000_000);
    for (i, r) in rep.iter().enumerate() {
        assert_eq!(r.status, Status::Ok, "{name}: request {i}");
    }
    let ints: Vec<IntMove> = moves.iter().map(|m| m.0.clone()).collect();
    let step_dir = StepDirTiming {
        pulse: PulseShape::Fixed {
            ticks: u64::from(width),
        },
        dir_setup_ticks: setup,
    };
    let (pulses, start) = model(&p, &ints, step_dir);
    assert_eq!(
        start, setup,
        "{name}: the setup time is longer than the prefill"
    );
    assert_eq!((log.go.len(), log.start.len()), (1, 1));
    let (go, s) = (log.go[0], log.start[0]);
    assert_eq!(
        go - s,
        u64::from(k) + 2 + start,
        "{name}: group start = model's + K + 2"
    );
    for (a, (im, m)) in moves.iter().enumerate() {
        let idle = log.step[a][0];
        assert!(
            idle.level && idle.cycle < s,
            "{name}: STEP idles high when active low"
        );
        let after_go = |v: Vec<u64>| -> Vec<u64> {
            v.iter()
                .filter(|&&c| c > go)
                .map(|c| c - go - TICK0)
                .collect()
        };
        let rises = after_go(log.rises(a, false));
        let falls = after_go(log.rises(a, true));
        let want: Vec<u64> = IntEdgeGenerator::new(im.profile()).collect();
        assert_eq!(rises, want, "{name}: axis {a} edges");
        let fixed: Vec<u64> = want.iter().map(|r| r + u64::from(width)).collect();
        assert_eq!(falls, fixed, "{name}: axis {a} falls");
        let model_rises: Vec<u64> = pulses[a].iter().map(|p| p.0).collect();
        let model_falls: Vec<u64> = pulses[a].iter().map(|p| p.1).collect();
        // the float model may put a tie one tick later (see cosim.rs); count them
        let ties = model_rises
            .iter()
            .zip(&rises)
            .filter(|(m, r)| m != r)
            .count();
        assert!(
            ties * 1000 <= rises.len(),
            "{name}: axis {a} model ties {ties}"
        );
        for (mf, (mr, r)) in model_falls.iter().zip(model_rises.iter().zip(&rises)) {
            assert_eq!(mf - mr, u64::from(width), "{name}: model pulse width");
            assert!(
                mr == r || *mr == r + 1,
                "{name}: axis {a} model rise {mr} vs {r}"
            );
        }
        // DIR (active low: the pin is the inverted bit) changed before the start write's
        // go by at least the setup time
        let d = log.dir[a].last().expect("DIR pin set at start");
        assert_eq!(d.level, !m.dir, "{name}: axis {a} DIR pin active low");
        let first = log.rises(a, false)[0];
        assert!(first - d.cycle > setup, "{name}: axis {a} DIR setup");
        let en = log.enable[a].last().expect("ENABLE pin set");
        assert!(!en.level, "{name}: ENABLE active low");
    }
}

/// A constant-speed move (the Hall search of a homing) at 100 k steps/s, and its stop
/// ramp from 100 k steps/s to 0 in 100 steps.
fn search_move(p: &CoreParams, steps: u64) -> (IntProfile, AxisMove, IntProfile, AxisMove) {
    let cruise = IntProfile::segments(
        &[IntSegment {
            v0: 100_000,
            ticks: steps * 500,
            steps,
        }],
        CLOCK,
    )
    .unwrap();
    let ramp = IntProfile::segments(
        &[IntSegment {
            v0: 100_000,
            ticks: 100_000,
            steps: 100,
        }],
        CLOCK,
    )
    .unwrap();
    let cm = AxisMove::from_profile(&cruise, true, p).unwrap();
    let rm = AxisMove::from_profile(&ramp, true, p).unwrap();
    (cruise, cm, ramp, rm)
}

/// Hall glitches shorter than the debounce are never accepted; the accepted edge latches
/// the position where its level began (several steps before it is accepted) and runs the
/// stop ramp from the last computed edge; then a limit edge stops a second move at once.
/// The filter time is prescaled (4 clocks a strobe). Icarus and Verilator write the same
/// log.
#[test]
fn hall_debounce_latch_stop_ramp_and_limit() {
    let name = "board-hall";
    let deb = 1800u32;
    let latest = multistep_hdl::filter_latest(u64::from(deb));
    assert_eq!(latest, 1808);
    let p = params(1);
    let b = board(p.clone(), 3_000_000);
    let (cruise, cm, ramp, rm) = search_move(&p, 400);
    let mut h = Host::new();
    h.write(Reg::Board(BoardReg::Debounce), deb);
    h.write(Reg::Board(BoardReg::HallStop), 1);
    h.writes(&move_writes(&p, 0, &cm, 0).unwrap());
    h.writes(&stop_ramp_writes(&p, 0, 3, &rm.pieces[0]).unwrap());
    h.write(Reg::Board(BoardReg::Start), 1);
    h.s.sync().steps(0, 60);
    h.s.hall(0, true)
        .wait(u64::from(deb) / 2)
        .hall(0, false)
        .steps(0, 20);
    h.s.hall(0, true)
        .wait(u64::from(deb) - 1)
        .hall(0, false)
        .steps(0, 20);
    h.s.mark(1).hall(0, true).wait(u64::from(deb) + 10).mark(2);
    // diverted to its ramp (1 ms), the axis takes no more pieces: a commit into a slot
    // it is not in and a control word keeping DIR, taken before the edge, are refused
    let w = p.widths().unwrap();
    let diverted = [
        h.write(Reg::Core(multistep_hdl::link::core_addr(&w, true, 0, 0)), 1),
        h.write(
            Reg::Core(multistep_hdl::link::core_addr(&w, true, 0, 1)),
            1 << 31,
        ),
    ];
    h.s.sync().idle();
    let st1 = h.read(Reg::Axis(0, AxisReg::State));
    let hp = h.read(Reg::Axis(0, AxisReg::HallPosition));
    let pos1 = h.read(Reg::Axis(0, AxisReg::Position));
    // the second move: Hall released (accepted low), limit stop only
    h.s.hall(0, false).wait(u64::from(deb) + 10);
    h.write(Reg::Board(BoardReg::Clear), 1);
    h.write(Reg::Board(BoardReg::HallStop), 0);
    h.write(Reg::Board(BoardReg::LimitStop), 1);
    h.write(Reg::Axis(0, AxisReg::Position), 0);
    h.writes(&move_writes(&p, 0, &cm, 0).unwrap());
    h.write(Reg::Board(BoardReg::Start), 1);
    h.s.sync().steps(0, 50).mark(3).limit(0, true).idle();
    let st2 = h.read(Reg::Axis(0, AxisReg::State));
    let pos2 = h.read(Reg::Axis(0, AxisReg::Position));
    h.s.sync();
    let (log, rep) = h.run_in_both(&b, name, 3_000_000);
    for (i, r) in rep.iter().enumerate() {
        let want = if diverted.contains(&i) {
            Status::Busy
        } else {
            Status::Ok
        };
        assert_eq!(r.status, want, "{name}: request {i}");
    }
    // the synchronized input: high for deb/2 and deb - 1 clocks (glitches), then for good;
    // exactly one accepted Hall edge, the debounce after it rose
    let hs = &log.hall_sync[0];
    let highs: Vec<u64> = hs
        .chunks(2)
        .filter(|c| c.len() == 2)
        .map(|c| c[1].cycle - c[0].cycle)
        .collect();
    assert_eq!(
        highs[..2],
        [u64::from(deb) / 2, u64::from(deb) - 1],
        "{name}: glitches"
    );
    assert_eq!(log.hall_accept[0].len(), 1, "{name}: glitches accepted");
    let acc = log.hall_accept[0][0];
    assert!(
        (hs[4].cycle + u64::from(deb)..=hs[4].cycle + latest).contains(&acc),
        "{name}: accept cycle {acc}, the level from {}",
        hs[4].cycle
    );
    assert_eq!(log.go.len(), 2);
    // move 1: the cruise's edges, then the ramp from the last computed one
    let go = log.go[0];
    let move1: Vec<u64> = log
        .rises(0, true)
        .iter()
        .filter(|&&c| c < log.go[1])
        .map(|c| c - go - TICK0)
        .collect();
    let want: Vec<u64> = IntEdgeGenerator::new(cruise).collect();
    let n0 = move1.iter().zip(&want).take_while(|(a, b)| a == b).count();
    // time-stamped: the rises before the clock the accepted level began
    let latched = log
        .rises(0, true)
        .iter()
        .filter(|&&c| c < hs[4].cycle)
        .count();
    let by_accept = log.rises(0, true).iter().filter(|&&c| c < acc).count();
    assert_eq!(rep[hp].data as usize, latched, "{name}: latched position");
    assert!(by_accept >= latched + 3, "{name}: steps while filtered");
    assert!(
        n0 > by_accept && n0 <= by_accept + p.fifo_depth as usize + 2,
        "{name}: ramp after step {n0}, Hall at {latched}"
    );
    let base = want[n0 - 1];
    let ramp_edges: Vec<u64> = IntEdgeGenerator::new(ramp).map(|e| base + e).collect();
    assert_eq!(move1[n0..], ramp_edges[..], "{name}: the stop ramp");
    assert_eq!(
        rep[pos1].data as usize,
        n0 + 100,
        "{name}: position after the ramp"
    );
    let s1 = AxisState::decode(rep[st1].data).unwrap();
    assert!(
        s1.hall_flag && s1.stopped && !s1.busy && s1.run == AxisRun::Stopped,
        "{s1:?}"
    );
    // move 2: stopped by the limit: no rise after the accepted edge (+ the pin register)
    let lim_acc = log.limit_sync[0][0].cycle + latest;
    let move2 = log
        .rises(0, true)
        .iter()
        .filter(|&&c| c > log.go[1])
        .count();
    let late = log
        .rises(0, true)
        .iter()
        .filter(|&&c| c > lim_acc + 1)
        .count();
    assert_eq!(late, 0, "{name}: a STEP after the limit");
    assert_eq!(
        rep[pos2].data as usize, move2,
        "{name}: position after the limit"
    );
    assert!((50..400).contains(&move2));
    let s2 = AxisState::decode(rep[st2].data).unwrap();
    assert!(
        s2.stopped && s2.limit && s2.run == AxisRun::Stopped,
        "{s2:?}"
    );
}

/// The e-stop input stops STEP at once (combinationally, between clock edges) and
/// latches; start and clear are refused while it is latched / active; after the clear a
/// move runs exactly; the e-stop register stops STEP at the clock after its request.
/// Icarus and Verilator write the same log, to the nanosecond.
#[test]
fn estop_pin_and_register() {
    let name = "board-estop";
    let p = params(1);
    let b = board(p.clone(), 3_000_000);
    let (cruise, cm, _, _) = search_move(&p, 300);
    let mut h = Host::new();
    h.writes(&move_writes(&p, 0, &cm, 0).unwrap());
    h.write(Reg::Board(BoardReg::Enable), 1);
    h.write(Reg::Board(BoardReg::Start), 1);
    // land inside a STEP pulse (high 250 of 500 ticks), off the clock edge
    h.s.sync()
        .steps(0, 40)
        .wait(100)
        .delay_ns(7)
        .estop(true)
        .wait(50);
    let st = h.read(Reg::Axis(0, AxisReg::State));
    let clr = h.write(Reg::Board(BoardReg::Estop), 0);
    let start = h.write(Reg::Board(BoardReg::Start), 1);
    let status = h.read(Reg::Board(BoardReg::Status));
    h.s.sync().estop(false).wait(10);
    let clr2 = h.write(Reg::Board(BoardReg::Estop), 0);
    h.writes(&move_writes(&p, 0, &cm, 0).unwrap());
    h.write(Reg::Board(BoardReg::Start), 1);
    h.s.sync().idle();
    h.write(Reg::Board(BoardReg::Start), 1);
    h.s.sync().steps(0, 30);
    let reg_stop = h.write(Reg::Board(BoardReg::Estop), 1);
    h.s.sync().wait(2000);
    let st3 = h.read(Reg::Axis(0, AxisReg::State));
    h.s.sync();
    let (log, rep) = h.run_in_both(&b, name, 3_000_000);
    let want_status = |i: usize, s: Status| assert_eq!(rep[i].status, s, "{name}: request {i}");
    want_status(clr, Status::Estop);
    want_status(start, Status::Estop);
    want_status(clr2, Status::Ok);
    want_status(reg_stop, Status::Ok);
    use multistep_hdl::link::status_bits::{ESTOP, ESTOP_INPUT, PENDING};
    assert_eq!(
        rep[status].data & (ESTOP | ESTOP_INPUT | PENDING),
        ESTOP | ESTOP_INPUT,
        "{name}: latched, input active, no group"
    );
    let s = AxisState::decode(rep[st].data).unwrap();
    assert!(s.estopped && !s.busy && s.run == AxisRun::Estopped, "{s:?}");
    // the pin e-stop: STEP fell in the same nanosecond, nothing rose until the next go
    let (lvl, t_e) = log.estop_ns[log.estop_ns.iter().position(|e| e.0).unwrap()];
    assert!(lvl);
    assert_eq!(
        log.step_during_estop_ns.first(),
        Some(&(0, t_e)),
        "{name}: STEP at the e-stop"
    );
    let e_cycle = t_e / 20;
    let rises = log.rises(0, true);
    assert!(
        !rises.iter().any(|&c| c > e_cycle && c < log.go[1]),
        "{name}: STEP after e-stop"
    );
    assert!(rises.iter().filter(|&&c| c < e_cycle).count() >= 40);
    // the move after the clear is exact
    let go = log.go[1];
    let second: Vec<u64> = rises
        .iter()
        .filter(|&&c| c > go && c < log.go[2])
        .map(|c| c - go - TICK0)
        .collect();
    let want: Vec<u64> = IntEdgeGenerator::new(cruise).collect();
    assert_eq!(second, want, "{name}: the move after the clear");
    // the register e-stop: the request executes at clock edge R; STEP is inactive after
    // edge R + 1 at the latest and never rises again
    let r = log.reqs[reg_stop];
    let falls = log.rises(0, false);
    assert!(
        !rises.iter().any(|&c| c > r),
        "{name}: STEP after the e-stop write"
    );
    let last_rise = *rises.last().unwrap();
    let last_fall = *falls.last().unwrap();
    assert!(
        last_fall > last_rise && (last_fall <= r + 1 || last_fall < r),
        "{name}: fall {last_fall}, request {r}"
    );
    let s3 = AxisState::decode(rep[st3].data).unwrap();
    assert!(s3.estopped && s3.run == AxisRun::Estopped);
    // the e-stop dropped ENABLE (its default level setting)
    let en = log.enable[0].last().unwrap();
    assert!(
        !en.level && en.cycle >= r,
        "{name}: ENABLE dropped by the e-stop"
    );
}

/// Per-axis levels: axis 0's DIR inverted, axis 1's ENABLE active low. The DIR bit and the
/// position stay logical; a running axis's DIR level cannot change; the e-stop and a
/// reset force each ENABLE to its own axis's inactive level.
#[test]
fn per_axis_dir_and_enable_levels_hold_through_estop_and_reset() {
    let name = "board-axis-levels";
    let p = params(2);
    let b = board(p.clone(), 3_000_000);
    let (_, cm, _, _) = search_move(&p, 40);
    let mut h = Host::new();
    h.write(Reg::Board(BoardReg::DirInvert), 0b01);
    h.write(Reg::Board(BoardReg::EnableLow), 0b10);
    h.write(Reg::Board(BoardReg::Enable), 0b11);
    for a in 0..2 {
        h.writes(&move_writes(&p, a, &cm, 0).unwrap());
    }
    h.write(Reg::Board(BoardReg::Start), 0b11);
    h.s.sync().steps(0, 5);
    let busy = h.write(Reg::Board(BoardReg::DirInvert), 0b00);
    let other = h.write(Reg::Board(BoardReg::DirInvert), 0b101);
    h.s.sync().idle();
    let pos: Vec<usize> = (0..2)
        .map(|a| h.read(Reg::Axis(a, AxisReg::Position)))
        .collect();
    let masks = [
        h.read(Reg::Board(BoardReg::DirInvert)),
        h.read(Reg::Board(BoardReg::EnableLow)),
    ];
    h.s.sync().mark(1);
    h.write(Reg::Board(BoardReg::Estop), 1);
    h.s.sync().wait(100).mark(2);
    h.s.reset_n(false).wait(10).reset_n(true).wait(100).mark(3);
    let (log, rep) = h.run(&b, name, 3_000_000);
    assert_eq!(
        rep[busy].status,
        Status::Busy,
        "{name}: DIR level of a running axis"
    );
    assert_eq!(rep[other].status, Status::BadValue, "{name}: no axis 2");
    for (a, &i) in pos.iter().enumerate() {
        assert_eq!(rep[i].data as i32, 40, "{name}: axis {a} counts up");
    }
    assert_eq!([rep[masks[0]].data, rep[masks[1]].data], [0b01, 0b10]);
    let at = |pins: &[Vec<multistep_hdl::board_sim::PinEvent>], a: usize, mark: u32| {
        let c = log.mark(mark).unwrap();
        pins[a].iter().rev().find(|e| e.cycle <= c).map(|e| e.level)
    };
    // moving +: axis 0's DIR pin low (inverted), axis 1's high
    assert_eq!(
        [at(&log.dir, 0, 1), at(&log.dir, 1, 1)],
        [Some(false), Some(true)]
    );
    // enabled: axis 0 high, axis 1 low; forced off (e-stop, reset): the other way round
    for (mark, want) in [(1, [true, false]), (2, [false, true]), (3, [false, true])] {
        let got = [at(&log.enable, 0, mark), at(&log.enable, 1, mark)];
        assert_eq!(got, want.map(Some), "{name}: ENABLE pins at mark {mark}");
    }
}

/// Bad frames get an error reply and change nothing: a bad CRC, an unknown command, an
/// unknown register, writes that would corrupt the running move (among them a commit into
/// the slot it runs and a control word flipping its DIR); garbage without a sync byte and
/// a truncated frame get no reply. A commit into another slot and a control word keeping
/// DIR are taken. The move's edges are exact throughout.
#[test]
fn bad_frames_are_rejected_and_change_nothing() {
    let name = "board-bad";
    let p = params(1);
    let b = board(p.clone(), 3_000_000);
    let (cruise, cm, _, _) = search_move(&p, 300);
    let w = p.widths().unwrap();
    let mut h = Host::new();
    h.writes(&move_writes(&p, 0, &cm, 0).unwrap());
    h.write(Reg::Board(BoardReg::Start), 1);
    h.s.sync().steps(0, 10);
    let before = h.read(Reg::Board(BoardReg::PulseWidth));
    // a bad CRC and an unknown command (raw frames, each answered)
    let mut f = Request::write(h.seq(), Reg::Board(BoardReg::PulseWidth), 5).encode();
    f[10] ^= 0x40;
    let first_bad = h.frame(&f);
    let mut cf = Request::write(h.seq(), Reg::Board(BoardReg::PulseWidth), 5).encode();
    cf[2] = 0x07;
    let crc = multistep_hdl::link::crc16(&cf[..9]).to_be_bytes();
    cf[9..].copy_from_slice(&crc);
    h.frame(&cf);
    let unknown = h.read(Reg::Board(BoardReg::Start)); // write only
    let ro = h.write(Reg::Board(BoardReg::Id), 1);
    let nowhere = h.read(Reg::Axis(5, AxisReg::State));
    let mut busy = vec![
        h.write(Reg::Core(multistep_hdl::link::core_addr(&w, true, 0, 0)), 0),
        h.write(Reg::Core(multistep_hdl::link::core_addr(&w, true, 0, 1)), 0),
        h.write(Reg::Axis(0, AxisReg::Position), 77),
        h.write(Reg::Board(BoardReg::PulseWidth), 5),
        h.write(Reg::Board(BoardReg::Start), 1),
    ];
    let bad_mask = h.write(Reg::Board(BoardReg::Start), 0b10);
    // what a load while the move runs writes: a commit into a slot the calculator is not
    // in, a control word keeping DIR (its last slot still 0) and the stop ramp's slot
    // are taken
    let taken = [
        h.write(Reg::Core(multistep_hdl::link::core_addr(&w, true, 0, 0)), 1),
        h.write(
            Reg::Core(multistep_hdl::link::core_addr(&w, true, 0, 1)),
            1 << 31,
        ),
        h.write(Reg::Axis(0, AxisReg::StopSlot), 2),
    ];
    h.s.sync();
    // garbage without a sync byte, and a truncated frame ended by a pause: no replies
    h.s.bytes(&[0x00, 0x5A, 0xFF, 0x13]);
    h.s.bytes(&Request::read(99, Reg::Board(BoardReg::Id)).encode()[..6])
        .wait(4000);
    let after = h.read(Reg::Board(BoardReg::PulseWidth));
    let status = h.read(Reg::Board(BoardReg::Status));
    h.s.sync().idle();
    let pos = h.read(Reg::Axis(0, AxisReg::Position));
    let slot = h.read(Reg::Axis(0, AxisReg::StopSlot));
    h.s.sync();
    let (log, rep) = h.run(&b, name, 3_000_000);
    assert_eq!(rep[first_bad].status, Status::BadCrc);
    assert_eq!(rep[first_bad + 1].status, Status::BadCommand);
    for i in [unknown, ro, nowhere] {
        assert_eq!(rep[i].status, Status::BadAddress, "{name}: request {i}");
    }
    busy.push(usize::MAX);
    for &i in &busy[..busy.len() - 1] {
        assert_eq!(rep[i].status, Status::Busy, "{name}: request {i}");
    }
    assert_eq!(rep[bad_mask].status, Status::BadValue);
    for i in taken {
        assert_eq!(rep[i].status, Status::Ok, "{name}: request {i}");
    }
    assert_eq!(
        (rep[before].data, rep[after].data),
        (0, 0),
        "{name}: pulse width unchanged"
    );
    assert_eq!(
        multistep_hdl::link::status_bits::bad_frames(rep[status].data),
        2,
        "{name}: two bad frames counted"
    );
    assert_eq!(
        (rep[pos].data, rep[slot].data),
        (300, 2),
        "{name}: position and slot"
    );
    let go = log.go[0];
    let rises: Vec<u64> = log.rises(0, true).iter().map(|c| c - go - TICK0).collect();
    let want: Vec<u64> = IntEdgeGenerator::new(cruise).collect();
    assert_eq!(rises, want, "{name}: the move is untouched");
    assert_eq!(log.go.len(), 1);
}

/// The session register holds the host's token until a reset clears it (it is 0 after
/// configuration too), whatever the timing of the host's bytes; the reset restores the
/// registers' defaults.
#[test]
fn the_session_is_the_hosts_token_until_a_reset() {
    let name = "board-session";
    let b = board(params(1), 3_000_000);
    let mut h = Host::new();
    let s0 = h.read(Reg::Board(BoardReg::Session));
    let claim = h.write(Reg::Board(BoardReg::Session), 0x1234_5678);
    let s1 = h.read(Reg::Board(BoardReg::Session));
    h.write(Reg::Board(BoardReg::PulseWidth), 9);
    let pw1 = h.read(Reg::Board(BoardReg::PulseWidth));
    h.s.sync().reset_n(false).wait(3).reset_n(true).wait(333);
    let s2 = h.read(Reg::Board(BoardReg::Session));
    let pw2 = h.read(Reg::Board(BoardReg::PulseWidth));
    h.write(Reg::Board(BoardReg::Session), 0xCAFE);
    let s3 = h.read(Reg::Board(BoardReg::Session));
    h.s.sync();
    let (_, rep) = h.run(&b, name, 1_000_000);
    let v = |i: usize| rep[i].data;
    assert_eq!(rep[claim].status, Status::Ok);
    assert_eq!(
        (v(pw1), v(pw2)),
        (9, 0),
        "{name}: reset restores the defaults"
    );
    assert_eq!(
        (v(s0), v(s1), v(s2), v(s3)),
        (0, 0x1234_5678, 0, 0xCAFE),
        "{name}: 0 at power-up, the token, 0 after the reset, the next token"
    );
}

/// `Ticks` reads the free-running count (what the host fits the board's crystal
/// against): two reads 200 000 clocks apart differ by that plus the frames between them
/// (a reply and a request at 3 Mbaud, under 5 000 clocks); a reset does not restart it.
#[test]
fn ticks_reads_the_free_running_count_through_a_reset() {
    let name = "board-ticks";
    let b = board(params(1), 3_000_000);
    let mut h = Host::new();
    let t1 = h.read(Reg::Board(BoardReg::Ticks));
    h.s.sync().wait(200_000);
    let t2 = h.read(Reg::Board(BoardReg::Ticks));
    h.s.sync().reset_n(false).wait(3).reset_n(true).wait(333);
    let t3 = h.read(Reg::Board(BoardReg::Ticks));
    h.s.sync();
    let (_, rep) = h.run(&b, name, 2_000_000);
    let v = |i: usize| {
        assert_eq!(rep[i].status, Status::Ok, "{name}");
        rep[i].data
    };
    let (a, b2, c) = (v(t1), v(t2), v(t3));
    assert!(
        (200_000..205_000).contains(&(b2 - a)),
        "{name}: {a} then {b2} after 200 000 clocks"
    );
    assert!(c > b2, "{name}: {c} after the reset, {b2} before");
}

/// A frame sent again as it was (a host that lost its reply) is answered from the reply
/// the board kept and not executed again: the retransmitted `Start` answers ok (executed
/// again it would be refused busy) and the group starts once; the same write under the
/// next seq is a new request (refused busy). A damaged copy in between (bad CRC) leaves
/// the kept reply. A retransmitted read answers what was read.
#[test]
fn a_retransmitted_frame_is_answered_and_not_executed_again() {
    let name = "board-again";
    let p = params(1);
    let b = board(p.clone(), 3_000_000);
    let (cruise, cm, _, _) = search_move(&p, 60);
    let mut h = Host::new();
    h.writes(&move_writes(&p, 0, &cm, 0).unwrap());
    let start = Request::write(h.seq(), Reg::Board(BoardReg::Start), 1);
    let first = h.push(start);
    let again = h.again(&start);
    // a damaged copy between: refused, and the kept reply stays
    let mut bad = start.encode();
    bad[10] ^= 0x40;
    let damaged = h.again_bytes(&bad, start.seq);
    let twice = h.again(&start);
    let new = h.write(Reg::Board(BoardReg::Start), 1);
    h.s.sync().steps(0, 10);
    let read = Request::read(h.seq(), Reg::Axis(0, AxisReg::Position));
    let pos = h.push(read);
    h.s.sync().steps(0, 10);
    let pos_again = h.again(&read);
    let pos_new = h.read(Reg::Axis(0, AxisReg::Position));
    h.s.sync().idle();
    let (log, rep) = h.run(&b, name, 2_000_000);
    for i in [first, again, twice] {
        assert_eq!(rep[i].status, Status::Ok, "{name}: request {i}");
    }
    assert_eq!(
        rep[damaged].status,
        Status::BadCrc,
        "{name}: a damaged copy"
    );
    assert_eq!(rep[new].status, Status::Busy, "{name}: a new start");
    assert_eq!(log.go.len(), 1, "{name}: one group start");
    assert_eq!(rep[pos_again].data, rep[pos].data, "{name}: the kept reply");
    assert!(rep[pos_new].data > rep[pos].data, "{name}: read anew");
    let want: Vec<u64> = IntEdgeGenerator::new(cruise).collect();
    let rises: Vec<u64> = log
        .rises(0, true)
        .iter()
        .map(|c| c - log.go[0] - TICK0)
        .collect();
    assert_eq!(rises, want, "{name}: the move is untouched");
}

/// `verilator --lint-only -Wall` is clean for the board at K = 1, 2, 5 and 8.
#[test]
fn board_lint_is_clean() {
    for k in [1, 2, 5, 8] {
        let dir = tempfile::tempdir().unwrap();
        multistep_hdl::board_sim::lint(&board(params(k), 3_000_000), dir.path())
            .unwrap_or_else(|e| panic!("K = {k}: {e}"));
    }
    // without the SYNC line (Arm, Fire and SyncTick left out)
    let dir = tempfile::tempdir().unwrap();
    let mut b = board(params(2), 3_000_000);
    b.sync = false;
    multistep_hdl::board_sim::lint(&b, dir.path()).unwrap_or_else(|e| panic!("no SYNC: {e}"));
    // with a chain unit per axis (the ULX3S-85F build)
    let dir = tempfile::tempdir().unwrap();
    let mut b = board(params(2), 3_000_000);
    (b.chains, b.stream_buffer_bits) = (true, 12);
    multistep_hdl::board_sim::lint(&b, dir.path()).unwrap_or_else(|e| panic!("chains: {e}"));
}

/// One group at a time: a start while another group waits for its start (here: for its
/// DIR setup time) is refused and the waiting group runs exactly; the refused axis starts
/// afterwards.
#[test]
fn start_while_a_group_waits_is_refused() {
    let name = "board-pending";
    let p = params(2);
    let b = board(p.clone(), 3_000_000);
    let (cruise, cm, _, _) = search_move(&p, 60);
    let mut h = Host::new();
    h.write(Reg::Board(BoardReg::DirSetup), 20_000);
    h.writes(&move_writes(&p, 0, &cm, 0).unwrap());
    h.writes(&move_writes(&p, 1, &cm, 0).unwrap());
    let first = h.write(Reg::Board(BoardReg::Start), 0b01);
    let second = h.write(Reg::Board(BoardReg::Start), 0b10);
    h.s.sync().idle();
    let third = h.write(Reg::Board(BoardReg::Start), 0b10);
    h.s.sync().idle();
    let (log, rep) = h.run(&b, name, 2_000_000);
    assert_eq!(rep[first].status, Status::Ok);
    assert_eq!(
        rep[second].status,
        Status::Busy,
        "{name}: start while a group waits"
    );
    assert_eq!(rep[third].status, Status::Ok);
    assert_eq!(log.go.len(), 2, "{name}: two group starts");
    let want: Vec<u64> = IntEdgeGenerator::new(cruise).collect();
    for (a, go) in [(0usize, log.go[0]), (1, log.go[1])] {
        let rises: Vec<u64> = log.rises(a, true).iter().map(|c| c - go - TICK0).collect();
        assert_eq!(rises, want, "{name}: axis {a}");
    }
}
