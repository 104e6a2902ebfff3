//! Hardware in the loop: the board's RTL in Verilator behind a pseudo-terminal, driven by
//! the host link over `serialport` as a real host would. Needs `verilator` and `g++`
//! (skipped with a message when missing, unless CI is set: then it fails).

use multistep_core::int::{IntClock, IntEdgeGenerator, IntLimitsMove, IntProfile, IntSegment};
use multistep_hdl::link::{
    move_writes, start_write, AxisReg, BoardReg, BuildId, HostLink, LinkError, Reg,
};
use multistep_hdl::AxisMove;
use multistep_hil::{BoardSim, Options, SensorOptions};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Clocks from the group's tick 0 to a STEP pin's rise at move tick t (docs/HDL.md, "Tick
/// 0 on the board").
const TICK0: u64 = 1;

fn tools_present() -> bool {
    let have = multistep_hdl::tools::find("verilator", "verilator").is_ok()
        && multistep_hdl::tools::find("g++", "g++").is_ok();
    if !have {
        let ci = std::env::var("CI").is_ok_and(|v| v == "true");
        assert!(
            !ci,
            "verilator and g++ are needed under CI (apt-get install -y verilator g++)"
        );
        eprintln!("SKIPPED: verilator or g++ missing (apt-get install -y verilator g++)");
    }
    have
}

/// Models built once per target directory, shared by the tests.
fn cache() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("verilator")
}

fn start(axes: u32, sensors: Vec<SensorOptions>, edges: Option<PathBuf>) -> BoardSim {
    BoardSim::start(&Options {
        board: "ulx3s-25f".into(),
        axes: Some(axes),
        sensors,
        edges,
        cache_dir: Some(cache()),
        ..Options::default()
    })
    .expect("board-sim starts")
}

type Port = Box<dyn serialport::SerialPort>;

fn link(sim: &BoardSim, timeout_ms: u64) -> HostLink<Port> {
    let port = serialport::new(&sim.pty_path, sim.board.baud)
        .timeout(Duration::from_millis(timeout_ms))
        .open()
        .expect("the pty opens as a serial port");
    HostLink::new(port)
}

fn wait_idle(l: &mut HostLink<Port>) {
    let t0 = Instant::now();
    while l.read(Reg::Board(BoardReg::Busy)).unwrap() != 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(300),
            "the move never ends"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn edges_log(path: &std::path::Path, axes: usize) -> (Vec<u64>, Vec<Vec<u64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut go = Vec::new();
    let mut rises = vec![Vec::new(); axes];
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["#", "go", c] => go.push(c.parse().unwrap()),
            [a, c] => rises[a.parse::<usize>().unwrap()].push(c.parse().unwrap()),
            _ => panic!("bad edge line {line:?}"),
        }
    }
    (go, rises)
}

#[test]
fn two_axis_move_over_the_pty_is_exact() {
    if !tools_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("edges.txt");
    let sim = start(2, Vec::new(), Some(log.clone()));
    let p = sim.board.core.clone();
    let mut l = link(&sim, 2000);
    assert_eq!(
        l.build_id().unwrap(),
        BuildId::of(&p, sim.board.baud).unwrap()
    );
    let clock = IntClock::hz(p.clock_hz as u64);
    let trap = IntProfile::limits(
        &IntLimitsMove {
            steps: 1500,
            vmax: 40_000,
            amax: 2_000_000,
            start_speed: 0,
            end_speed: 0,
        },
        clock,
    )
    .unwrap();
    let chain = IntProfile::segments(
        &[
            IntSegment {
                v0: 10_000,
                ticks: 500_000,
                steps: 100,
            },
            IntSegment {
                v0: 10_000,
                ticks: 500_000,
                steps: 150,
            },
            IntSegment {
                v0: 20_000,
                ticks: 500_000,
                steps: 200,
            },
        ],
        clock,
    )
    .unwrap();
    let m0 = AxisMove::from_profile(&trap, true, &p).unwrap();
    let m1 = AxisMove::from_profile(&chain, false, &p).unwrap();
    let mut w = move_writes(&p, 0, &m0, 0).unwrap();
    w.extend(move_writes(&p, 1, &m1, 0).unwrap());
    w.push(start_write(0b11));
    l.write_all(&w).unwrap();
    wait_idle(&mut l);
    let pos = |l: &mut HostLink<Port>, a| l.read(Reg::Axis(a, AxisReg::Position)).unwrap() as i32;
    assert_eq!(pos(&mut l, 0), 1500);
    assert_eq!(pos(&mut l, 1), -450);
    sim.quit().unwrap();
    let (go, rises) = edges_log(&log, 2);
    assert_eq!(go.len(), 1, "one group start");
    for (a, prof) in [trap, chain].into_iter().enumerate() {
        let want: Vec<u64> = IntEdgeGenerator::new(prof)
            .map(|t| go[0] + t + TICK0)
            .collect();
        assert_eq!(rises[a].len(), want.len(), "axis {a}: rises");
        assert_eq!(rises[a], want, "axis {a}: every rise at go + t + 1");
    }
}
