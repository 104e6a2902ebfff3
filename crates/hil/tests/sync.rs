//! Two verilated boards in one process on one time base, SYNC wired between them, board 1
//! powered up later and its clock 50 ppm fast: a group armed on both and fired from board
//! 0 starts on both within one clock period; the SyncTicks give board 1's offset at the
//! fall and, from two fires, its rate. Needs `verilator` and `g++` (skipped with a message
//! when missing, unless CI is set).

use multistep_core::int::{IntClock, IntEdgeGenerator, IntLimitsMove, IntProfile};
use multistep_hdl::link::{self, move_writes, BoardReg, HostLink, Reg};
use multistep_hdl::AxisMove;
use multistep_hil::multi::{BoardClock, MultiBoardSim, MultiOptions};
use multistep_hil::Options;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn tools_present() -> bool {
    let have = multistep_hdl::tools::find("verilator", "verilator").is_ok()
        && multistep_hdl::tools::find("g++", "g++").is_ok();
    if !have {
        let ci = std::env::var("CI").is_ok_and(|v| v == "true");
        assert!(!ci, "verilator and g++ are needed under CI");
        eprintln!("SKIPPED: verilator or g++ missing (apt-get install -y verilator g++)");
    }
    have
}

type Port = Box<dyn serialport::SerialPort>;

fn link(path: &str, baud: u32) -> HostLink<Port> {
    let port = serialport::new(path, baud)
        .timeout(Duration::from_millis(5000))
        .open()
        .expect("the pty opens as a serial port");
    HostLink::new(port)
}

/// The edge log: the clock line, the group starts and axis 0's rises (cycles).
fn edges(path: &Path) -> (BoardClock, Vec<u64>, Vec<u64>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut clock = None;
    let (mut go, mut rises) = (Vec::new(), Vec::new());
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["#", "clock", p, s] => {
                clock = Some(BoardClock {
                    period_ps: p.parse().unwrap(),
                    start_ps: s.parse().unwrap(),
                })
            }
            ["#", "go", c] => go.push(c.parse().unwrap()),
            ["0", c] => rises.push(c.parse().unwrap()),
            _ => panic!("bad edge line {line:?}"),
        }
    }
    (clock.expect("a clock line"), go, rises)
}

fn wait_status(l: &mut HostLink<Port>, mask: u32, want: u32) {
    let t0 = Instant::now();
    while l.read(Reg::Board(BoardReg::Status)).unwrap() & mask != want {
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "status never {want:#x}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn two_boards_on_one_sync_line_start_together() {
    if !tools_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let logs: Vec<PathBuf> = (0..2)
        .map(|i| dir.path().join(format!("edges{i}.txt")))
        .collect();
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("verilator");
    let board = |i: usize| Options {
        board: "ulx3s-25f".into(),
        axes: Some(2),
        edges: Some(logs[i].clone()),
        cache_dir: Some(cache.clone()),
        ..Options::default()
    };
    let (ppm, up_us) = ([0.0, 50.0], [0.0, 123.4]);
    let sim = MultiBoardSim::start(&MultiOptions {
        boards: vec![board(0), board(1)],
        ppm: ppm.to_vec(),
        power_up_us: up_us.to_vec(),
    })
    .expect("board-sim starts");
    let p = sim.boards[0].core.clone();
    let mut l: Vec<HostLink<Port>> = (0..2)
        .map(|i| link(&sim.pty_paths[i], sim.boards[i].baud))
        .collect();
    let clock = IntClock::hz(p.clock_hz as u64);
    let prof = IntProfile::limits(
        &IntLimitsMove {
            steps: 1000,
            vmax: 50_000,
            amax: 4_000_000,
            start_speed: 0,
            end_speed: 0,
        },
        clock,
    )
    .unwrap();
    let m = AxisMove::from_profile(&prof, true, &p).unwrap();
    for h in &mut l {
        h.write_all(&move_writes(&p, 0, &m, 0).unwrap()).unwrap();
        h.write_all(&[link::arm_write(1)]).unwrap();
    }
    // armed and ready on both, then fire from board 0
    let first = link::fire_armed(&mut l, 0, 10_000, || {
        std::thread::sleep(Duration::from_millis(5))
    })
    .unwrap();
    for h in &mut l {
        wait_status(h, link::status_bits::PENDING | link::status_bits::ARMED, 0);
        let t0 = Instant::now();
        while h.read(Reg::Board(BoardReg::Busy)).unwrap() != 0 {
            assert!(
                t0.elapsed() < Duration::from_secs(300),
                "the move never ends"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    // a second fire, from board 1, with nothing armed: only the counts
    l[1].write(Reg::Board(BoardReg::Fire), 1).unwrap();
    std::thread::sleep(Duration::from_millis(20));
    let second: Vec<u32> = l
        .iter_mut()
        .map(|h| h.read(Reg::Board(BoardReg::SyncTick)).unwrap())
        .collect();
    for h in &mut l {
        assert_eq!(
            h.read(Reg::Axis(0, multistep_hdl::link::AxisReg::Position))
                .unwrap(),
            1000
        );
    }
    drop(l);
    sim.quit().unwrap();

    let want: Vec<u64> = IntEdgeGenerator::new(prof).collect();
    let mut go_ps = Vec::new();
    let mut rise_ps = Vec::new();
    for (i, log) in logs.iter().enumerate() {
        let (c, go, rises) = edges(log);
        assert_eq!(go.len(), 1, "board {i}: one group start");
        // the group's tick 0 is the edge after the one SyncTick latched at
        assert_eq!(go[0], u64::from(first[i]) + 1, "board {i}: go at SyncTick");
        let exact: Vec<u64> = want.iter().map(|t| go[0] + t + 1).collect();
        assert_eq!(rises, exact, "board {i}: every rise at go + t + 1");
        go_ps.push(c.time_ps(go[0] as f64));
        rise_ps.push(c.time_ps(rises[0] as f64));
    }
    // the group's tick 0 on both boards within one clock period; the first rises differ
    // by that plus the rate difference over the first step's t + 1 ticks
    let skew_ps = go_ps[1] - go_ps[0];
    let period = 1e12 / p.clock_hz;
    assert!(skew_ps.abs() < period, "start skew {skew_ps} ps");
    let rise_skew = rise_ps[1] - rise_ps[0];
    // board 1's count behind board 0's at the fall: its power-up, less its faster clock
    let c: Vec<BoardClock> = logs.iter().map(|l| edges(l).0).collect();
    let fall = go_ps[0] - 2.5 * period;
    let count = |i: usize| ((fall - c[i].start_ps) / c[i].period_ps).floor() as i64;
    let offset = link::sync_offsets(&first)[1];
    assert!(
        (offset - (count(0) - count(1))).abs() <= 1,
        "offset {offset}"
    );
    let (d0, d1) = (
        f64::from(second[0] - first[0]),
        f64::from(second[1] - first[1]),
    );
    let rate_ppm = (d1 / d0 - 1.0) * 1e6;
    let resolution = 2.0 / d0 * 1e6;
    assert!((rate_ppm - 50.0).abs() <= resolution, "rate {rate_ppm} ppm");
    eprintln!(
        "cross-board start: start skew {skew_ps:.0} ps, first-rise skew {rise_skew:.0} ps (first step at tick {}), offset {offset} ticks, rate {rate_ppm:.3} ppm (+-{resolution:.3}) over {d0} ticks",
        want[0]
    );
}
