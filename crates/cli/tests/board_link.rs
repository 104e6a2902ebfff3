//! The controller's behaviour on both pin backends, as real processes: `multistep serve`
//! on the simulated board, and `multistep serve --board-link` on the FPGA board's RTL run
//! by `multistep board-sim` (hardware in the loop). The same script gets the same answers
//! on both; on the board every position reported trusted equals the board's counter.
//! Two boards on one SYNC line (`board-sim --boards 2`), one `serve` each: `ctl group`
//! across both starts on one fall of the line.

use multistep_controller::client::{Client, Endpoint};
use multistep_controller::{AxisState, AxisStatus};
use multistep_hdl::link::{AxisReg, HostLink, Reg};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");

/// Which pins stand behind the service.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pins {
    Sim,
    Hil,
}

/// `multistep board-sim`: the board's RTL behind a pseudo-terminal.
struct BoardSim {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    pty: String,
}

impl BoardSim {
    /// The ULX3S build (50 MHz, 0.33 s pieces) with `axes` axes, each sensor as the
    /// board config's `sim.*` settings describe it (the simulated board's too).
    fn start(axes: usize, config: &Path) -> BoardSim {
        let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("verilator");
        let mut child = Command::new(BIN)
            .args([
                "board-sim",
                "--board",
                "ulx3s-25f",
                "--axes",
                &axes.to_string(),
            ])
            .arg("--config")
            .arg(config)
            .arg("--cache-dir")
            .arg(cache)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn multistep board-sim");
        let stdin = child.stdin.take().unwrap();
        let mut stdout = BufReader::new(child.stdout.take().unwrap());
        let mut first = String::new();
        stdout.read_line(&mut first).unwrap();
        let pty = first
            .trim()
            .strip_prefix("pty ")
            .unwrap_or_else(|| panic!("board-sim said: {first}"))
            .to_string();
        BoardSim {
            child,
            stdin,
            stdout,
            pty,
        }
    }

    fn send(&mut self, line: &str) {
        writeln!(self.stdin, "{line}").unwrap();
        self.stdin.flush().unwrap();
    }

    /// The board's state as board-sim reports it (one JSON line).
    fn state(&mut self) -> serde_json::Value {
        self.send("state");
        let mut line = String::new();
        self.stdout.read_line(&mut line).unwrap();
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("state: {e}: {line}"))
    }
}

impl Drop for BoardSim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

struct Server {
    child: Child,
    addr: String,
}

impl Server {
    fn start(data: &Path, config: &Path, link: Option<&str>) -> Server {
        let mut cmd = Command::new(BIN);
        cmd.args(["serve", "--listen", "127.0.0.1:0", "--data"])
            .arg(data)
            .arg("--board-config")
            .arg(config)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        if let Some(l) = link {
            cmd.args(["--board-link", l]);
        }
        let mut child = cmd.spawn().expect("spawn multistep serve");
        let mut first = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut first)
            .unwrap();
        let addr = first.trim().rsplit("tcp://").next().unwrap().to_string();
        assert!(addr.contains(':'), "serve said: {first}");
        Server { child, addr }
    }

    fn kill9(&mut self) {
        self.child.kill().unwrap();
        self.child.wait().unwrap();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A service on its pins, with the board's RTL behind it for [`Pins::Hil`].
struct Rig {
    pins: Pins,
    dir: tempfile::TempDir,
    config: PathBuf,
    board: Option<BoardSim>,
    server: Server,
    client: Client,
    /// Positions reported trusted that differed from the board's counter.
    mismatches: usize,
    /// Each axis's last idle position and whether it was trusted.
    last: [Option<(i64, bool)>; 2],
    checked: bool,
}

/// A board whose axes home onto a Hall sensor whose edge is at -300 (home_offset 500): short
/// moves (every piece within the board's 0.33 s) so the RTL simulation runs them in seconds.
const CONFIG: &str = "[board]\nname = \"t\"\n";

/// One axis of [`CONFIG`] (every axis the same).
const AXIS: &str = r#"
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

/// [`CONFIG`] with the axes X and Y.
fn config() -> String {
    let axis = |n: &str| format!("[[axis]]\nname = \"{n}\"{AXIS}");
    format!("{CONFIG}{}{}", axis("X"), axis("Y"))
}

impl Rig {
    fn new(pins: Pins) -> Rig {
        Rig::with_config(pins, &config())
    }

    /// With the board config `text`.
    fn with_config(pins: Pins, text: &str) -> Rig {
        let dir = tempfile::tempdir().unwrap();
        let config = dir.path().join("board.toml");
        std::fs::write(&config, text).unwrap();
        let board = (pins == Pins::Hil).then(|| BoardSim::start(2, &config));
        let link = board.as_ref().map(|b| format!("serial:{}", b.pty));
        let server = Server::start(&dir.path().join("data"), &config, link.as_deref());
        let client = Client::connect(&Endpoint::Tcp(server.addr.clone())).unwrap();
        Rig {
            pins,
            dir,
            config,
            board,
            server,
            client,
            mismatches: 0,
            last: [None; 2],
            checked: false,
        }
    }

    fn restart_after_kill9(&mut self) {
        self.server.kill9();
        let link = self.board.as_ref().map(|b| format!("serial:{}", b.pty));
        self.server = Server::start(&self.dir.path().join("data"), &self.config, link.as_deref());
        self.client = Client::connect(&Endpoint::Tcp(self.server.addr.clone())).unwrap();
    }

    fn req(&mut self, line: &str) -> Vec<String> {
        self.client
            .request(line)
            .unwrap_or_else(|e| panic!("{:?}: {line}: {e}", self.pins))
    }

    /// The axis's status; on the board a trusted position is checked against its counter.
    fn status(&mut self, axis: &str) -> AxisStatus {
        let s = self
            .client
            .status()
            .unwrap()
            .into_iter()
            .find(|s| s.axis == axis)
            .unwrap();
        if s.state == AxisState::Idle {
            self.last[s.number] = Some((s.position, s.trusted));
        }
        s
    }

    /// Stops the service and reads the board's counters over the link itself: every
    /// position last reported idle and trusted must equal its axis's counter.
    fn check_counters(&mut self) {
        let Some(b) = &self.board else { return };
        self.server.kill9();
        let port = serialport::new(&b.pty, 3_000_000)
            .timeout(Duration::from_millis(2000))
            .open()
            .expect("the pty opens");
        let mut l = HostLink::new(port);
        for (a, last) in self.last.iter().enumerate() {
            let counter = l
                .read(Reg::Axis(a as u32, AxisReg::Position))
                .expect("the board answers") as i32 as i64;
            if let Some((pos, true)) = last {
                if *pos != counter {
                    self.mismatches += 1;
                    eprintln!("axis {a}: reported {pos} trusted, the board counts {counter}");
                }
            }
        }
        self.checked = true;
    }

    fn wait_idle(&mut self, axis: &str) -> AxisStatus {
        let t0 = Instant::now();
        loop {
            let s = self.status(axis);
            if s.state != AxisState::Moving && s.state != AxisState::Homing {
                return s;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(300),
                "{:?}: {axis} never stopped: {s:?}",
                self.pins
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Waits until the axis is idle and its board answers.
    fn wait_reachable(&mut self, axis: &str) -> AxisStatus {
        let t0 = Instant::now();
        loop {
            let s = self.wait_idle(axis);
            if !s.fault.as_deref().unwrap_or("").contains("link") {
                return s;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(60),
                "the link never came back: {s:?}"
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    fn home(&mut self, axis: &str) -> AxisStatus {
        self.req(&format!("home {axis}"));
        self.wait_idle(axis)
    }
}

impl Drop for Rig {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            if !self.checked {
                self.check_counters();
            }
            assert_eq!(
                self.mismatches, 0,
                "{:?}: positions reported trusted that differ from the board's counter",
                self.pins
            );
        }
    }
}

/// Runs `script` on both backends and returns its answers, which must agree.
fn on_both<T: PartialEq + std::fmt::Debug>(script: impl Fn(Pins) -> T) -> T {
    let sim = script(Pins::Sim);
    let hil = script(Pins::Hil);
    assert_eq!(sim, hil, "the simulated board and the RTL disagree");
    sim
}

#[test]
fn moves_and_groups_give_the_same_positions_on_both_backends() {
    let got = on_both(|pins| {
        let mut r = Rig::new(pins);
        r.req("move X 1200");
        let x = r.wait_idle("X");
        r.req("group move X=-300 Y=700");
        let st = r.client.status().unwrap();
        assert_eq!(st[0].move_start, st[1].move_start, "{pins:?}: one start");
        let x2 = r.wait_idle("X");
        let y = r.wait_idle("Y");
        (x.position, x2.position, y.position, x2.state, y.state)
    });
    assert_eq!(got, (1200, 900, 700, AxisState::Idle, AxisState::Idle));
}

#[test]
fn homing_finds_the_sensor_and_a_slip_shows_as_drift() {
    let got = on_both(|pins| {
        let mut r = Rig::new(pins);
        let h = r.home("X");
        assert!(h.homed && h.trusted, "{pins:?}: {h:?}");
        // Lose 30 steps the count does not see, then pass the sensor again.
        match pins {
            Pins::Sim => {
                r.req("sim X slip 30");
            }
            Pins::Hil => r.board.as_mut().unwrap().send("slip 0 30"),
        }
        r.req("move X 1000");
        r.wait_idle("X");
        r.req("move X -1400");
        let x = r.wait_idle("X");
        (h.position, x.drift.map(|d| d.abs() >= 25), x.trusted)
    });
    assert_eq!(got, (500, Some(true), false));
}

#[test]
fn estop_halts_and_reset_clears() {
    let got = on_both(|pins| {
        let mut r = Rig::new(pins);
        r.req("move X 1200");
        std::thread::sleep(Duration::from_millis(150));
        r.req("estop");
        let x = r.status("X");
        let refused = r.client.request("move Y 10").is_err();
        r.req("reset");
        r.req("move Y 10");
        let y = r.wait_idle("Y");
        (x.state, x.trusted, refused, y.position)
    });
    assert_eq!(got, (AxisState::Fault, false, true, 10));
}

#[test]
fn kill_9_of_serve_keeps_idle_axes_and_untrusts_the_moving_one() {
    let got = on_both(|pins| {
        let mut r = Rig::new(pins);
        r.req("home Y");
        r.wait_idle("Y");
        r.req("move Y 300");
        r.wait_idle("Y");
        r.req("move X 1200");
        std::thread::sleep(Duration::from_millis(150));
        r.restart_after_kill9();
        let y = r.status("Y");
        let x = r.wait_idle("X");
        (y.position, y.trusted, x.trusted)
    });
    assert_eq!(got, (800, true, false));
}

#[test]
fn a_board_reset_mid_move_and_a_cut_link_are_reported_and_survived() {
    let mut r = Rig::new(Pins::Hil);
    r.home("X");
    r.req("move X 1200");
    std::thread::sleep(Duration::from_millis(150));
    r.board.as_mut().unwrap().send("reset");
    // The frame in flight at the reset goes unanswered: the link may fail for a moment.
    let x = r.wait_reachable("X");
    assert!(!x.trusted && !x.homed, "{x:?}");
    assert_eq!(x.state, AxisState::Fault, "{x:?}");
    assert!(x.fault.as_deref().unwrap_or("").contains("reset"), "{x:?}");
    assert!(r.req("info").iter().any(|l| l.contains("reset")));
    r.board.as_mut().unwrap().send("cut");
    std::thread::sleep(Duration::from_millis(1500));
    let x = r.status("X");
    assert_eq!(x.state, AxisState::Fault, "{x:?}");
    assert!(x.fault.as_deref().unwrap_or("").contains("link"), "{x:?}");
    assert!(!x.trusted, "{x:?}");
    r.board.as_mut().unwrap().send("restore");
    r.wait_reachable("X");
    r.req("reset");
    let before = r.status("X").position;
    r.req("move X 50");
    let x = r.wait_idle("X");
    assert_eq!((x.position, x.state), (before + 50, AxisState::Idle));
}

#[test]
fn homing_under_bouncing_and_glitching_sensors_lands_on_the_edge() {
    // Bounces and glitches of 10 µs, shorter than the 20 µs debounce.
    let noisy = config().replace(
        "sensor_width = 200\n",
        "sensor_width = 200\nbounce_count = 3\nbounce_time = 0.00001\n\
         glitch_rate = 300.0\nglitch_max = 0.00001\nglitch_gap = 0.001\n",
    );
    let got = on_both(|pins| {
        let mut r = Rig::with_config(pins, &noisy);
        let h = r.home("X");
        if let Some(b) = r.board.as_mut() {
            let mech = b.state()["axes"][0]["position"].as_f64().unwrap();
            assert!(
                (mech + 300.0).abs() <= 3.0,
                "home is the edge at -300, the motor is at {mech}"
            );
        }
        (h.position, h.homed, h.trusted, h.fault)
    });
    assert_eq!(got, (500, true, true, None));
}

#[test]
fn stop_ends_a_move_short_of_its_target_with_the_count_trusted() {
    let got = on_both(|pins| {
        let mut r = Rig::new(pins);
        r.home("X");
        r.req("move X 1200");
        std::thread::sleep(Duration::from_millis(150));
        r.req("stop X");
        let x = r.wait_idle("X");
        // The simulated board ramps down at amax; the board halts at once (its count
        // stays exact: it counts the STEPs it gave).
        (x.state, x.trusted, x.position > 500 && x.position < 1700)
    });
    assert_eq!(got, (AxisState::Idle, true, true));
}

#[test]
fn a_bad_or_missing_board_link_stops_serve_with_one_error_line() {
    let dir = tempfile::tempdir().unwrap();
    for (link, want) in [
        ("tcp:127.0.0.1:9", "serial:DEVICE"),
        ("serial:/dev/x@12", "serial:DEVICE"),
        ("serial:/nonexistent/tty", "/nonexistent/tty"),
    ] {
        let out = Command::new(BIN)
            .args([
                "serve",
                "--listen",
                "127.0.0.1:0",
                "--board-link",
                link,
                "--data",
            ])
            .arg(dir.path().join("data"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{link}");
        assert_eq!(err.lines().count(), 1, "{link}: {err}");
        assert!(
            err.starts_with("error:") && err.contains(want),
            "{link}: {err}"
        );
    }
}

#[test]
fn a_sync_group_starts_together_and_reaches_its_targets_on_both_backends() {
    let got = on_both(|pins| {
        let mut r = Rig::new(pins);
        r.req("group move X=800 Y=-300 sync");
        let st = r.client.status().unwrap();
        assert_eq!(st[0].move_start, st[1].move_start, "{pins:?}: one start");
        let x = r.wait_idle("X");
        let y = r.wait_idle("Y");
        (x.position, y.position)
    });
    assert_eq!(got, (800, -300));
}

/// Two axes that move 200 steps in 0.02 s (a triangle at 1e6 steps/s²).
const SYNC_CONFIG: &str = r#"[board]
name = "t"
[[axis]]
name = "X"
vmax = 20000.0
amax = 1000000.0
[[axis]]
name = "Y"
vmax = 20000.0
amax = 1000000.0
"#;

struct Killed(Child);
impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A service named `name` on the board at `pty` (None: the simulated board).
fn sync_serve(dir: &Path, name: &str, pty: Option<&str>) -> Server {
    let config = dir.join(format!("{name}.toml"));
    std::fs::write(&config, SYNC_CONFIG).unwrap();
    let link = pty.map(|p| format!("serial:{p}"));
    Server::start(&dir.join(format!("{name}-data")), &config, link.as_deref())
}

fn ctl(addrs: &[String], args: &[&str]) -> std::process::Output {
    let mut cmd = Command::new(BIN);
    cmd.arg("ctl");
    for (n, a) in ["a", "b"].iter().zip(addrs) {
        cmd.arg("--board").arg(format!("{n}=tcp://{a}"));
    }
    cmd.args(args).output().unwrap()
}

/// The edge log of one board: its clock (period, start, ps), the group starts and axis
/// 0's STEP rises (cycles).
fn edges(path: &Path) -> ((f64, f64), Vec<u64>, Vec<u64>) {
    let text = std::fs::read_to_string(path).unwrap();
    let (mut clock, mut go, mut rises) = (None, Vec::new(), Vec::new());
    for line in text.lines() {
        match line.split_whitespace().collect::<Vec<_>>().as_slice() {
            ["#", "clock", p, s] => clock = Some((p.parse().unwrap(), s.parse().unwrap())),
            ["#", "go", c] => go.push(c.parse().unwrap()),
            ["0", c] => rises.push(c.parse().unwrap()),
            _ => {}
        }
    }
    (clock.expect("a clock line"), go, rises)
}

#[test]
fn a_group_across_two_boards_starts_on_one_sync_fall() {
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("verilator");
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("edges");
    // Board 1's clock runs 50 ppm fast and starts 123.4 µs after board 0's.
    let mut sim = Command::new(BIN)
        .args(
            "board-sim --board ulx3s-25f --axes 2 --boards 2 --ppm 0,50 --power-up-us 0,123.4"
                .split(' '),
        )
        .arg("--edges")
        .arg(&log)
        .arg("--cache-dir")
        .arg(&cache)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut stdin = sim.stdin.take().unwrap();
    let mut out = BufReader::new(sim.stdout.take().unwrap());
    let mut sim = Killed(sim);
    let mut ptys = Vec::new();
    for _ in 0..2 {
        let mut line = String::new();
        out.read_line(&mut line).unwrap();
        ptys.push(
            line.strip_prefix("pty ")
                .expect("pty lines")
                .trim()
                .to_string(),
        );
    }
    let sa = sync_serve(dir.path(), "a", Some(&ptys[0]));
    let sb = sync_serve(dir.path(), "b", Some(&ptys[1]));
    let addrs = [sa.addr.clone(), sb.addr.clone()];

    let o = ctl(&addrs, &["group", "a:X=200", "b:X=200", "b:Y=-120"]);
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        o.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for want in ["a:X target=200", "b:X target=200", "b:Y target=-120"] {
        assert!(text.lines().any(|l| l == want), "{want}: {text}");
    }
    let offset = |board: &str| -> i64 {
        let l = text
            .lines()
            .find(|l| l.starts_with(&format!("{board} synctick=")))
            .unwrap_or_else(|| panic!("no synctick of {board}: {text}"));
        l.rsplit("offset=").next().unwrap().parse().unwrap()
    };
    assert_eq!(offset("a"), 0, "{text}");
    let offset_b = offset("b");

    let o = ctl(&addrs, &["wait", "a:X", "b:X", "b:Y", "--timeout", "120"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = ctl(&addrs, &["status", "--json"]);
    let st: Vec<AxisStatus> = serde_json::from_slice(&o.stdout).unwrap();
    let pos = |a: &str| st.iter().find(|s| s.axis == a).unwrap().position;
    assert_eq!(
        [pos("a:X"), pos("a:Y"), pos("b:X"), pos("b:Y")],
        [200, 0, 200, -120]
    );

    writeln!(stdin, "quit").unwrap();
    drop(stdin);
    sim.0.wait().unwrap();
    let (mut go_ps, mut rise_ps, mut go_cycle) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..2 {
        let ((period, start), go, rises) = edges(&log.with_extension(i.to_string()));
        assert_eq!(go.len(), 1, "board {i}: one group start");
        assert_eq!(rises.len(), 200, "board {i}: 200 steps of X");
        go_ps.push(start + go[0] as f64 * period);
        rise_ps.push(start + rises[0] as f64 * period);
        go_cycle.push(go[0] as i64);
    }
    // go is the edge after the one SyncTick latched at, on both boards: the printed
    // offset is the difference of the boards' go cycles
    assert_eq!(offset_b, go_cycle[0] - go_cycle[1], "{text}");
    // tick 0 within one clock period (20 ns); the first STEP rises within 1 µs
    let (start_skew, rise_skew) = (go_ps[1] - go_ps[0], rise_ps[1] - rise_ps[0]);
    eprintln!("through serve/ctl: start skew {start_skew:.0} ps, first STEP rises {rise_skew:.0} ps apart, offset {offset_b}");
    assert!(start_skew.abs() < 20_000.0, "start skew {start_skew} ps");
    assert!(rise_skew.abs() < 1e6, "first rises {rise_skew} ps apart");
}

#[test]
fn simulated_boards_refuse_a_group_across_boards() {
    let dir = tempfile::tempdir().unwrap();
    let sa = sync_serve(dir.path(), "a", None);
    let sb = sync_serve(dir.path(), "b", None);
    let addrs = [sa.addr.clone(), sb.addr.clone()];
    let o = ctl(&addrs, &["group", "a:X=200", "b:X=200"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("has no SYNC line"), "{err}");
    // nothing moved or stays armed
    let o = ctl(&addrs, &["status", "--json"]);
    let st: Vec<AxisStatus> = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        st.iter()
            .all(|s| s.position == 0 && s.state.name() == "idle"),
        "{st:?}"
    );
}
