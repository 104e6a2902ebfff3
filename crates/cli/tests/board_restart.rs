//! `multistep serve --board-link` killed (SIGKILL) while the FPGA board's RTL
//! (`multistep board-sim`) runs a move, and started again on the same data: the board kept
//! the host's session token, so the new service adopts what it is doing. A computed move
//! runs to its end and its position is trusted; a streamed one, whose code died with the
//! old service, and one the old service was loading as it ran, are halted at once with
//! their count exact and the fault `host_restarted`.

mod common;

use common::Proc;
use multistep_controller::client::Client;
use multistep_controller::{AxisState, AxisStatus};
use multistep_hdl::link::{position_count, AxisReg, HostLink, Reg};
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");

/// Axis X homes onto a sensor edge at -300 (home_offset 500), as in board_link.rs.
const CONFIG: &str = r#"[board]
name = "t"
[[axis]]
name = "X"
vmax = 4000.0
amax = 40000.0
home_dir = -1
home_offset = 500
home_speed = 2000.0
home_slow_speed = 500.0
home_backoff = 40
home_search = 500
debounce = 0.00002
[axis.sim]
sensor_at = -300
sensor_width = 200
"#;

/// The device of board-sim's `pty DEVICE` line.
fn pty_of(line: &str) -> String {
    line.strip_prefix("pty ")
        .unwrap_or_else(|| panic!("board-sim said: {line}"))
        .to_string()
}

struct Rig {
    dir: tempfile::TempDir,
    _board: Proc,
    pty: String,
    serve: Proc,
    client: Client,
}

impl Rig {
    /// board-sim (ULX3S build, one axis, in real time: a killed service leaves the board
    /// running at the wall clock's pace) and `serve` on it.
    fn new() -> Rig {
        Rig::on("ulx3s-25f")
    }

    /// The same with `board`'s build.
    fn on(board: &str) -> Rig {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("board.toml");
        std::fs::write(&config, CONFIG).unwrap();
        let cache = Path::new(env!("CARGO_TARGET_TMPDIR")).join("verilator");
        let (board, first) = Proc::spawn(
            Command::new(BIN)
                .args(["board-sim", "--board", board, "--axes", "1", "--realtime"])
                .arg("--config")
                .arg(&config)
                .arg("--cache-dir")
                .arg(cache),
            1,
        );
        let pty = pty_of(&first[0]);
        let (serve, client) = Rig::serve(dir.path(), &pty);
        Rig {
            dir,
            _board: board,
            pty,
            serve,
            client,
        }
    }

    fn serve(dir: &Path, pty: &str) -> (Proc, Client) {
        common::serve_on_link(BIN, dir, &format!("serial:{pty},timeout=3"))
    }

    /// `serve` killed with SIGKILL and started again on the same data and board.
    fn restart_after_kill9(&mut self) {
        self.serve.kill9();
        (self.serve, self.client) = Rig::serve(self.dir.path(), &self.pty);
    }

    fn req(&mut self, line: &str) -> Vec<String> {
        self.client
            .request(line)
            .unwrap_or_else(|e| panic!("{line}: {e}"))
    }

    fn x(&mut self) -> AxisStatus {
        self.client.status().unwrap().remove(0)
    }

    /// Polls X until `done` holds of its status (a generous deadline: the RTL runs slower
    /// than the board on a busy machine).
    fn x_until(&mut self, what: &str, done: impl Fn(&AxisStatus) -> bool) -> AxisStatus {
        let t0 = Instant::now();
        loop {
            let s = self.x();
            if done(&s) {
                return s;
            }
            assert!(t0.elapsed() < Duration::from_secs(300), "{what}: {s:?}");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn x_idle(&mut self) -> AxisStatus {
        self.x_until("X never came to rest", |s| {
            !matches!(s.state, AxisState::Moving | AxisState::Homing)
        })
    }

    /// X homed: trusted at a known place.
    fn home(&mut self) -> i64 {
        self.req("home X");
        let h = self.x_idle();
        assert!(h.homed && h.trusted, "{h:?}");
        h.position
    }

    /// The service stopped, X's counter read over the link itself.
    fn counter(&mut self) -> i64 {
        self.serve.kill9();
        let port = serialport::new(&self.pty, 3_000_000)
            .timeout(Duration::from_secs(3))
            .open()
            .expect("the pty opens");
        let raw = HostLink::new(port)
            .read(Reg::Axis(0, AxisReg::Position))
            .expect("the board answers");
        position_count(raw, 0)
    }
}

/// A computed move (a trapezoid of three 0.3 s phases at 1000 steps/s: the board's
/// datapath runs it) under way when `serve` dies: the new `serve` shows it moving until it
/// ends, then idle at its target with the position trusted, and the next move runs.
#[test]
fn a_computed_move_under_way_runs_to_its_end_under_the_restarted_serve() {
    let mut r = Rig::new();
    let at = r.home();
    r.req("move X 600 accel=0.3 cruise=0.3 decel=0.3");
    r.x_until("X never moved", |s| s.position > at + 20);
    r.restart_after_kill9();
    let first = r.x();
    assert!(
        first.state == AxisState::Moving || first.position == at + 600,
        "adopted: moving, or already at its target: {first:?}"
    );
    let x = r.x_idle();
    assert_eq!(
        (x.state, x.position, x.trusted, x.homed, x.fault.as_deref()),
        (AxisState::Idle, at + 600, true, true, None),
        "{x:?}"
    );
    r.req("move X -100");
    let x = r.x_idle();
    assert_eq!((x.position, x.trusted), (at + 500, true), "{x:?}");
    assert_eq!(r.counter(), at + 500, "the board's Position register");
}

/// A move of more pieces than slots on the iCEBreaker (no replay units), loaded as it runs
/// by the host, under way when `serve` dies: the board holds only the pieces sent, so the
/// new `serve` halts the axis at once, as a stream's, and says `host_restarted`; the
/// count stays exact and the next move runs.
#[test]
fn a_move_loaded_as_it_runs_is_halted_exact_by_the_restarted_serve() {
    let mut r = Rig::on("icebreaker");
    r.req("move X 5000 vmax=2000");
    r.x_until("X never moved", |s| s.position > 200);
    r.restart_after_kill9();
    let x = r.x_idle();
    assert_eq!(x.state, AxisState::Fault, "{x:?}");
    let why = x.fault.as_deref().unwrap_or("");
    assert!(why.starts_with("host_restarted"), "{x:?}");
    assert!(x.position > 200 && x.position < 5000, "{x:?}");
    r.req("stop X");
    r.req("move X 100");
    let y = r.x_idle();
    assert_eq!(
        (y.state, y.position),
        (AxisState::Idle, x.position + 100),
        "{y:?}"
    );
    assert_eq!(r.counter(), y.position, "the board's Position register");
}

/// A streamed move (sine: the host codes its edges) under way when `serve` dies: the board
/// soon runs out of code; the new `serve` halts the axis at once, says `host_restarted`,
/// keeps the count exact and trusted, and `stop` and the next move work.
#[test]
fn a_streamed_move_under_way_is_halted_exact_by_the_restarted_serve() {
    let mut r = Rig::new();
    let at = r.home();
    r.req("move X 3000 profile=sine accel=0.5 cruise=0.5 decel=0.5");
    r.x_until("X never moved", |s| s.position > at + 200);
    r.restart_after_kill9();
    let x = r.x_idle();
    assert_eq!(x.state, AxisState::Fault, "{x:?}");
    assert!(
        x.fault
            .as_deref()
            .unwrap_or("")
            .starts_with("host_restarted"),
        "{x:?}"
    );
    assert!(x.trusted && x.homed, "the count is exact: {x:?}");
    assert!(x.position > at && x.position < at + 3000, "{x:?}");
    let info = r.req("info");
    assert!(
        info.iter().any(|l| l.contains("host_restarted")),
        "info: {info:?}"
    );
    r.req("stop X");
    r.req("move X 100");
    let y = r.x_idle();
    assert_eq!(
        (y.state, y.position, y.trusted),
        (AxisState::Idle, x.position + 100, true),
        "{y:?}"
    );
    assert_eq!(
        r.counter(),
        x.position + 100,
        "the board's Position register"
    );
}

/// Two boards (`board-sim --boards 2`, their SYNC pins wired together), each armed with a
/// share of a group; board b's link is cut, so the stop that should disarm its share
/// fails. Once the link answers again b's `serve` disarms it (`fault=disarmed`): a later
/// group armed and fired on board a alone does not start b's stale share.
#[test]
fn a_share_left_armed_behind_a_cut_link_never_fires_with_a_later_group() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("board.toml");
    std::fs::write(&config, CONFIG).unwrap();
    let cache = Path::new(env!("CARGO_TARGET_TMPDIR")).join("verilator");
    let (mut sim, ptys) = Proc::spawn(
        Command::new(BIN)
            .args([
                "board-sim",
                "--board",
                "ulx3s-25f",
                "--axes",
                "1",
                "--boards",
                "2",
            ])
            .arg("--cache-dir")
            .arg(cache),
        2,
    );
    let mut board = |line: &str| sim.send(line);
    let (da, db) = (dir.path().join("a"), dir.path().join("b"));
    for d in [&da, &db] {
        std::fs::create_dir(d).unwrap();
        std::fs::copy(&config, d.join("board.toml")).unwrap();
    }
    let (_sa, mut a) = Rig::serve(&da, &pty_of(&ptys[0]));
    let (_sb, mut b) = Rig::serve(&db, &pty_of(&ptys[1]));
    a.request("arm move X=200").unwrap();
    b.request("arm move X=200").unwrap();
    board("@1 cut");
    assert!(b.request("stop X").is_err(), "b's link is cut");
    board("@1 restore");
    let t0 = Instant::now();
    let bx = loop {
        let x = b.status().unwrap().remove(0);
        // "board link … down" while it is cut
        if !x.fault.as_deref().unwrap_or("").starts_with("board link") {
            break x;
        }
        assert!(t0.elapsed() < Duration::from_secs(120), "b's link: {x:?}");
        std::thread::sleep(Duration::from_millis(50));
    };
    assert!(
        bx.fault.as_deref().unwrap_or("").starts_with("disarmed"),
        "{bx:?}"
    );
    // a's own share stopped (as a failing `ctl group` does), then a group on a alone
    a.request("stop X").unwrap();
    a.request("arm move X=100").unwrap();
    let t0 = Instant::now();
    while !a.request("synctick").unwrap()[0].contains("ready=1") {
        assert!(t0.elapsed() < Duration::from_secs(60), "a never got ready");
        std::thread::sleep(Duration::from_millis(5));
    }
    a.request("fire").unwrap();
    let t0 = Instant::now();
    let ax = loop {
        let x = a.status().unwrap().remove(0);
        if x.state != AxisState::Moving {
            break x;
        }
        assert!(t0.elapsed() < Duration::from_secs(120), "a's X: {x:?}");
        std::thread::sleep(Duration::from_millis(5));
    };
    assert_eq!(ax.position, 100, "{ax:?}");
    let bx = b.status().unwrap().remove(0);
    assert_eq!(
        (bx.position, bx.state == AxisState::Moving),
        (0, false),
        "b's stale share stayed put: {bx:?}"
    );
}
