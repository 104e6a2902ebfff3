//! `multistep hdl regs`: the frames it prints decode to exactly the link library's
//! register writes for the move; moves the board cannot run are one `error:` line, exit 2.

use multistep_core::int::{IntClock, IntPhaseMove, IntProfile};
use multistep_hdl::boards::Board;
use multistep_hdl::link::{
    move_writes, rolling_writes, start_write, BoardReg, Command, Reg, Request,
};
use multistep_hdl::{AxisMove, CoreParams};
use std::process::Command as Process;

fn multistep(args: &[&str]) -> std::process::Output {
    Process::new(env!("CARGO_BIN_EXE_multistep"))
        .args(args)
        .output()
        .unwrap()
}

/// The listing's rows: seq, addr, data and the decoded frame.
fn rows(text: &str) -> Vec<(u8, u16, u32, Request)> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let bytes: Vec<u8> = (0..f[3].len() / 2)
                .map(|i| u8::from_str_radix(&f[3][2 * i..2 * i + 2], 16).unwrap())
                .collect();
            (
                f[0].parse().unwrap(),
                u16::from_str_radix(f[1], 16).unwrap(),
                u32::from_str_radix(f[2], 16).unwrap(),
                Request::decode(&bytes).unwrap(),
            )
        })
        .collect()
}

/// A phase trapezoid (phase ticks, start speed) as the registers of `board`'s core
/// (its default axes), moving forward.
fn planned(board: &str, steps: u64, ticks: [u64; 3], start_speed: u64) -> (CoreParams, AxisMove) {
    let b = Board::by_name(board).unwrap();
    let p = b.params(b.default_axes).unwrap();
    let m = IntPhaseMove {
        steps,
        accel_ticks: ticks[0],
        cruise_ticks: ticks[1],
        decel_ticks: ticks[2],
        start_speed,
        end_speed: 0,
    };
    let prof = IntProfile::phase(&m, IntClock::hz(p.clock_hz as u64)).unwrap();
    let am = AxisMove::from_profile(&prof, true, &p)
        .or_else(|_| AxisMove::rolling(&prof, true, &p))
        .unwrap();
    (p, am)
}

#[test]
fn frames_are_the_link_librarys_writes() {
    let o = multistep(&[
        "hdl",
        "regs",
        "--board",
        "ulx3s-25f",
        "--axis",
        "2",
        "--pulse-width",
        "10",
        "--seq",
        "250",
        "--steps",
        "1000",
        "--accel-time",
        "0.01",
        "--cruise-time",
        "0.01",
        "--decel-time",
        "0.01",
        "--start-speed",
        "500",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let got = rows(&text);
    let (p, am) = planned("ulx3s-25f", 1000, [500_000; 3], 500);
    let mut want = vec![(Reg::Board(BoardReg::PulseWidth), 10)];
    want.extend(
        move_writes(&p, 2, &am, 10)
            .unwrap()
            .iter()
            .map(|w| (w.reg, w.data)),
    );
    let s = start_write(1 << 2);
    want.push((s.reg, s.data));
    assert_eq!(got.len(), want.len(), "{text}");
    for (i, ((seq, addr, data, req), (reg, d))) in got.iter().zip(&want).enumerate() {
        let seq_want = 250u8.wrapping_add(i as u8);
        assert_eq!((*seq, req.seq), (seq_want, seq_want), "row {i}");
        assert_eq!((*addr, req.addr), (reg.addr(), reg.addr()), "row {i}");
        assert_eq!((*data, req.data), (*d, *d), "row {i}");
        assert_eq!(req.command, Command::Write);
    }
    assert!(
        text.contains("core.stage.y0[0]") && text.contains("Start"),
        "{text}"
    );
}

#[test]
fn segments_and_limits_moves_list_too() {
    for args in [
        vec!["--segment", "0:0.01:500", "--segment", "100000:0.01:1000"],
        vec!["--steps", "2000", "--vmax", "50000", "--amax", "2000000"],
    ] {
        let mut a = vec!["hdl", "regs", "--board", "icebreaker"];
        a.extend(args.iter());
        let o = multistep(&a);
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(rows(&String::from_utf8(o.stdout).unwrap()).len() > 18);
    }
}

/// The iCEBreaker's 20 tick bits: a 5000-step move with 0.1 s ramps (1.8 M ticks each)
/// is loaded as four pieces, split by the host. With a 0.8 s cruise too it needs 18, more
/// than the 16 slots: the first 16, the start, then pieces 16 and 17, each after a
/// `# piece i: once the axis has made N steps` line, as the link library loads them while
/// the move runs. A move of more than 4096 pieces is one error.
#[test]
fn ramps_longer_than_the_tick_bits_are_split() {
    let ramps = [
        "--steps",
        "5000",
        "--accel-time",
        "0.1",
        "--decel-time",
        "0.1",
    ];
    let mut a = vec!["hdl", "regs", "--board", "icebreaker"];
    a.extend(ramps);
    let o = multistep(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let got = rows(&text);
    let (p, am) = planned("icebreaker", 5000, [1_800_000, 0, 1_800_000], 0);
    assert_eq!(am.pieces.len(), 4);
    let mut want: Vec<(u16, u32)> = move_writes(&p, 0, &am, 0)
        .unwrap()
        .iter()
        .map(|w| (w.reg.addr(), w.data))
        .collect();
    let s = start_write(1);
    want.push((s.reg.addr(), s.data));
    let got: Vec<(u16, u32)> = got.iter().map(|r| (r.1, r.2)).collect();
    assert_eq!(got, want, "{text}");
    assert!(!text.contains("# piece"), "{text}");

    a.extend(["--cruise-time", "0.8"]);
    let o = multistep(&a);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let (p, am) = planned("icebreaker", 5000, [1_800_000, 14_400_000, 1_800_000], 0);
    assert_eq!(am.pieces.len(), 18);
    let (now, later) = rolling_writes(&p, 0, &am, 0, None).unwrap();
    let mut want: Vec<(u16, u32)> = now.iter().map(|w| (w.reg.addr(), w.data)).collect();
    want.push((s.reg.addr(), s.data));
    for l in &later {
        want.extend(l.writes.iter().map(|w| (w.reg.addr(), w.data)));
    }
    let got: Vec<(u16, u32)> = rows(&text).iter().map(|r| (r.1, r.2)).collect();
    assert_eq!(got, want, "{text}");
    // the last control word names piece 17's slot (1) the move's last
    assert_eq!(got.last(), Some(&(0x1081, 0x8000_0001)), "{text}");
    let notes: Vec<(usize, u64)> = (text.lines())
        .filter_map(|l| l.strip_prefix("# piece "))
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            (
                w[0].trim_end_matches(':').parse().unwrap(),
                w[6].parse().unwrap(),
            )
        })
        .collect();
    let slots = p.pieces as usize;
    assert_eq!(notes, am.late_pieces(slots).collect::<Vec<_>>());
    assert_eq!(notes[0], (16, am.pieces[0].steps));
    assert_eq!(notes.len(), 2);

    let long = "hdl regs --board icebreaker --steps 600000 --vmax 2000 --amax 40000";
    let o = multistep(&long.split_whitespace().collect::<Vec<_>>());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("a rolling load holds 1..=4096"), "{err}");
}

#[test]
fn moves_the_board_cannot_run_are_errors() {
    let phase = [
        "--steps",
        "1000",
        "--accel-time",
        "0.01",
        "--cruise-time",
        "0.01",
        "--decel-time",
        "0.01",
    ];
    for (extra, msg) in [
        (
            vec!["--board", "ulx3s-25f", "--profile", "sine"],
            "trapezoids",
        ),
        (vec!["--board", "nope"], "unknown board"),
        (vec!["--board", "ulx3s-25f", "--axis", "8"], "axis 8"),
        (
            vec!["--board", "ulx3s-25f", "--start-speed", "0.5"],
            "whole",
        ),
        (
            vec!["--board", "ulx3s-25f", "--pulse-width", "5000"],
            "pulse",
        ),
    ] {
        let mut a = vec!["hdl", "regs"];
        a.extend(extra.iter());
        a.extend(phase.iter());
        let o = multistep(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {err}");
        assert!(
            err.starts_with("error:") && err.contains(msg),
            "{extra:?}: {err}"
        );
        assert_eq!(err.lines().count(), 1, "{err}");
    }
}

/// `--stream`: a sine move (which the board cannot compute) as DIR, arm, bulk writes and
/// start; the bulk frames decode, their bytes are the whole code, and the code decodes to
/// exactly plan's edges.
#[test]
fn streamed_moves_list_their_bulk_writes() {
    use multistep_core::stream::StreamDecoder;
    use multistep_hdl::link::{AxisReg, BulkWrite};
    let args = "hdl regs --board ulx3s-25f --axis 1 --stream --profile sine --steps 3000 \
                --accel-time 0.01 --cruise-time 0.02 --decel-time 0.01";
    let o = multistep(&args.split_whitespace().collect::<Vec<_>>());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8(o.stdout).unwrap();
    let mut code = Vec::new();
    let (mut arms, mut starts, mut later) = (0, 0, 0);
    for l in text.lines() {
        if l.starts_with("# from move tick") {
            later += 1;
            continue;
        }
        if l.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = l.split_whitespace().collect();
        let bytes: Vec<u8> = (0..f[3].len() / 2)
            .map(|i| u8::from_str_radix(&f[3][2 * i..2 * i + 2], 16).unwrap())
            .collect();
        if bytes[2] == 3 {
            let b = BulkWrite::decode(&bytes).unwrap();
            assert_eq!(b.addr, Reg::Axis(1, AxisReg::StreamData).addr());
            code.extend(b.data);
        } else {
            let r = Request::decode(&bytes).unwrap();
            if r.addr == Reg::Axis(1, AxisReg::StreamSteps).addr() {
                assert_eq!(r.data, 3000);
                arms += 1;
            }
            if r.addr == Reg::Board(BoardReg::Start).addr() {
                assert_eq!(r.data, 2);
                starts += 1;
            }
        }
    }
    assert_eq!((arms, starts), (1, 1));
    assert!(later > 0, "bulk writes after the start: {text}");
    let mut d = StreamDecoder::new();
    let mut periods = Vec::new();
    for b in code {
        d.byte(b, &mut |p| periods.push(u64::from(p))).unwrap();
    }
    let edges: Vec<u64> = periods
        .iter()
        .scan(0, |t, p| {
            *t += p;
            Some(*t)
        })
        .collect();
    let mv = multistep_core::PhaseMove::new(3000, multistep_core::Family::Sine, 0.01, 0.02, 0.01);
    let want: Vec<u64> = multistep_core::edges(&multistep_core::Move::Phase(mv), 50e6)
        .unwrap()
        .collect();
    assert_eq!(edges, want);
}
