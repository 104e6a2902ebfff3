//! The controller as a real process: `multistep serve` spawned, driven over TCP, a serial
//! pseudo-terminal and `multistep ctl`, killed with SIGKILL and restarted.

mod common;

use common::EchoedStderr;
use multistep_controller::client::{Client, ClientError, Endpoint};
use multistep_controller::{AxisState, AxisStatus};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");

struct Server {
    child: Child,
    addr: String,
    /// Its stderr when piped: shown under a failing test only.
    stderr: Option<EchoedStderr>,
}

impl Server {
    fn start(data: &Path, config: Option<&Path>, time_scale: f64, extra: &[&str]) -> Server {
        Server::start_with(
            data,
            config,
            time_scale,
            extra,
            "127.0.0.1:0",
            Stdio::piped(),
        )
    }

    /// With the listen address and where stderr goes given (piped: echoed, see
    /// [`EchoedStderr`]).
    fn start_with(
        data: &Path,
        config: Option<&Path>,
        time_scale: f64,
        extra: &[&str],
        listen: &str,
        stderr: Stdio,
    ) -> Server {
        let mut cmd = Command::new(BIN);
        cmd.args([
            "serve",
            "--listen",
            listen,
            "--time-scale",
            &time_scale.to_string(),
        ])
        .arg("--data")
        .arg(data)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(stderr);
        if let Some(c) = config {
            cmd.arg("--board-config").arg(c);
        }
        let mut child = cmd.spawn().expect("spawn multistep serve");
        let stderr = child.stderr.take().map(EchoedStderr::start);
        let mut first = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut first)
            .unwrap();
        let addr = first.trim().rsplit("tcp://").next().unwrap();
        // A board listening on every interface is reached here over loopback.
        let addr = addr.replace("0.0.0.0:", "127.0.0.1:");
        assert!(addr.contains(':'), "serve said: {first}");
        Server {
            child,
            addr,
            stderr,
        }
    }

    fn client(&self) -> Client {
        Client::connect(&Endpoint::Tcp(self.addr.clone())).unwrap()
    }

    fn kill9(&mut self) {
        self.child.kill().unwrap(); // SIGKILL
        self.child.wait().unwrap();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(e) = &self.stderr {
            e.flush_if_failing();
        }
    }
}

fn status(c: &mut Client, axis: &str) -> AxisStatus {
    c.status()
        .unwrap()
        .into_iter()
        .find(|s| s.axis == axis)
        .unwrap()
}

fn wait_idle(c: &mut Client, axis: &str) -> AxisStatus {
    wait_for(c, axis, |s| {
        s.state != AxisState::Moving && s.state != AxisState::Homing
    })
}

/// Polls `axis` until `want` holds of its status: a deadline that only a hang reaches.
fn wait_for(c: &mut Client, axis: &str, want: impl Fn(&AxisStatus) -> bool) -> AxisStatus {
    let t0 = Instant::now();
    loop {
        let s = status(c, axis);
        if want(&s) {
            return s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "{axis} never got there: {s:?}"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Runs `multistep ctl --board B… ARGS`: (exit code, stdout, stderr).
fn run_ctl(boards: &[String], args: &[&str]) -> (Option<i32>, String, String) {
    let mut cmd = Command::new(BIN);
    cmd.arg("ctl");
    for b in boards {
        cmd.args(["--board", b]);
    }
    let out = cmd.args(args).output().unwrap();
    (
        out.status.code(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

fn write_config(dir: &Path, text: &str) -> std::path::PathBuf {
    let p = dir.join("board.toml");
    std::fs::write(&p, text).unwrap();
    p
}

const TWO_AXES: &str = r#"
[board]
name = "t"
[[axis]]
name = "X"
vmax = 4000.0
amax = 20000.0
[[axis]]
name = "Y"
vmax = 4000.0
amax = 20000.0
"#;

#[test]
fn concurrent_clients_each_get_exactly_one_answer_per_command() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Server::start(dir.path(), None, 50.0, &[]);
    let threads: Vec<_> = (0..8)
        .map(|k| {
            let addr = srv.addr.clone();
            std::thread::spawn(move || {
                let mut c = Client::connect(&Endpoint::Tcp(addr)).unwrap();
                let mut oks = 0;
                for j in 0..100 {
                    match (k + j) % 4 {
                        0 => assert_eq!(c.status().unwrap().len(), 4),
                        1 => assert_eq!(c.request("get Y vmax").unwrap(), vec!["vmax=4000.0"]),
                        2 => match c.request("move Q 10") {
                            Err(ClientError::Refused(r)) => assert_eq!(r.code, 4),
                            other => panic!("{other:?}"),
                        },
                        _ => {
                            // Every client moves its own axis now and then; a busy axis is refused.
                            let axis = ["X", "Y", "Z", "A"][k % 4];
                            match c.request(&format!("move {axis} 10")) {
                                Ok(_) => oks += 1,
                                Err(ClientError::Refused(r)) => {
                                    assert_eq!(r.code, 6, "{}", r.message)
                                }
                                Err(e) => panic!("{e}"),
                            }
                        }
                    }
                }
                oks
            })
        })
        .collect();
    let oks: usize = threads.into_iter().map(|t| t.join().unwrap()).sum();
    assert!(oks > 0);
    let mut c = srv.client();
    for a in ["X", "Y", "Z", "A"] {
        wait_idle(&mut c, a);
    }
    let total: i64 = c.status().unwrap().iter().map(|s| s.position).sum();
    assert_eq!(
        total,
        10 * oks as i64,
        "every accepted move was made exactly once"
    );
}

#[test]
fn kill_9_mid_move_restores_idle_axes_exactly_and_the_moving_axis_untrusted_until_homed() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write_config(dir.path(), TWO_AXES);
    let data = dir.path().join("data");
    let mut srv = Server::start(&data, Some(&cfg), 50.0, &[]);
    let mut c = srv.client();
    c.request("home X").unwrap();
    c.request("home Y").unwrap();
    wait_idle(&mut c, "X");
    wait_idle(&mut c, "Y");
    c.request("move Y -1234").unwrap();
    let y = wait_idle(&mut c, "Y");
    assert!(y.homed && y.trusted && y.position == -1234);
    c.request("set Y vmax 3000").unwrap();
    c.request("preset gentle vmax=100 amax=1000").unwrap();
    c.request("save spot Y").unwrap();
    // 400 000 steps at 4000 steps/s: 100 s simulated, 2 s of wall time at ×50.
    c.request("move X 400000").unwrap();
    let x = wait_for(&mut c, "X", |x| x.position > 0);
    assert_eq!(x.state, AxisState::Moving);
    assert!(x.position > 0 && x.position < 400_000);
    srv.kill9();

    let srv = Server::start(&data, Some(&cfg), 50.0, &[]);
    let mut c = srv.client();
    let y = status(&mut c, "Y");
    assert_eq!(
        (y.position, y.homed, y.trusted, y.state),
        (-1234, true, true, AxisState::Idle)
    );
    let x = status(&mut c, "X");
    assert_eq!(x.state, AxisState::Idle);
    assert!(!x.trusted && !x.homed, "{x:?}");
    assert_eq!(c.request("get Y vmax").unwrap(), ["vmax=3000.0"]);
    assert_eq!(c.request("presets").unwrap(), ["gentle vmax=100 amax=1000"]);
    assert_eq!(c.request("positions").unwrap(), ["spot Y=-1234"]);
    c.request("home X").unwrap();
    let x = wait_idle(&mut c, "X");
    assert!(x.trusted && x.homed, "{x:?}");
    assert_eq!(x.position, 0);
    assert_eq!(
        x.sim_position, 0,
        "the count agrees with the mechanics again"
    );
}

#[test]
fn homing_through_the_service_under_glitchy_sensors_over_seeds() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("[board]\nname = \"g\"\n");
    for k in 0..8 {
        text += &format!(
            "[[axis]]\nname = \"H{k}\"\nhome_offset = 500\nhome_dir = {}\n\
             [axis.sim]\nsensor_at = {}\nsensor_width = 300\nbounce_count = 3\nbounce_time = 0.0007\n\
             glitch_rate = 400.0\nglitch_max = 0.0012\nglitch_gap = 0.002\nseed = {}\n",
            if k % 2 == 0 { -1 } else { 1 },
            100 * k - 300,
            1000 + k
        );
    }
    let cfg = write_config(dir.path(), &text);
    let srv = Server::start(&dir.path().join("data"), Some(&cfg), 100.0, &[]);
    let mut c = srv.client();
    for round in 0..3i64 {
        for k in 0..8i64 {
            let dist = if k % 2 == 0 {
                3000 + 700 * round
            } else {
                -3000 - 700 * round
            };
            c.request(&format!("sim H{k} slip {dist}")).unwrap();
            c.request(&format!("home H{k}")).unwrap();
        }
        for k in 0..8i64 {
            let s = wait_idle(&mut c, &format!("H{k}"));
            assert!(s.homed && s.trusted && s.fault.is_none(), "{s:?}");
            assert_eq!(s.position, 500);
            let err = s.sim_position - (100 * k - 300);
            assert!(
                err.abs() <= 1,
                "round {round} axis H{k}: {err} microsteps off"
            );
        }
    }
}

#[test]
fn bad_input_gets_error_answers_and_the_connection_stays_usable() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Server::start(dir.path(), None, 10.0, &[]);
    let mut s = std::net::TcpStream::connect(&srv.addr).unwrap();
    let mut input = Vec::new();
    input.extend_from_slice(b"move NOPE 5\n\xff\xfe\xfd\n");
    input.extend(std::iter::repeat_n(b'z', 100_000));
    input.extend_from_slice(b"\nmoveto X 1 vmax=abc\nset X soft_max 10\nmoveto X 11\nhome X\nmove X 5\nstop X\nfrobnicate\nversion\n");
    s.write_all(&input).unwrap();
    s.shutdown(std::net::Shutdown::Write).unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    let codes: Vec<&str> = out
        .lines()
        .filter(|l| *l == "ok" || l.starts_with("error:"))
        .map(|l| l.split(' ').next().unwrap())
        .collect();
    assert_eq!(
        codes,
        [
            "error:4", "error:2", "error:1", "error:3", "ok", "error:5", "ok", "error:6", "ok",
            "error:3", "ok"
        ],
        "{out}"
    );
    assert!(out.contains("multistep-controller"));
}

#[test]
fn ctl_drives_two_boards_of_the_telescope_example() {
    let dir = tempfile::tempdir().unwrap();
    let ex = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/telescope");
    let a = Server::start(
        &dir.path().join("a"),
        Some(&ex.join("board-a.toml")),
        50.0,
        &[],
    );
    let b = Server::start(
        &dir.path().join("b"),
        Some(&ex.join("board-b.toml")),
        50.0,
        &[],
    );
    let boards = [format!("a=tcp://{}", a.addr), format!("b=tcp://{}", b.addr)];
    let ctl = |args: &[&str]| run_ctl(&boards, args);
    // A wave plate (period 90° = 4000 microsteps): 350° is 80° (3556), 10° back from 1000.
    assert_eq!(ctl(&["moveto", "b:wp11", "1000"]).0, Some(0));
    assert_eq!(ctl(&["wait", "b:wp11"]).0, Some(0));
    let (code, out, err) = ctl(&["moveto", "b:wp11", "350u"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("wp11 target=3556"), "{out}");
    assert_eq!(
        ctl(&["move", "a:focus", "2000", "--vmax", "3000"]).0,
        Some(0)
    );
    assert_eq!(ctl(&["wait", "a:focus", "b:wp11"]).0, Some(0));
    let (code, out, _) = ctl(&["status", "--json"]);
    assert_eq!(code, Some(0));
    let all: Vec<serde_json::Value> = serde_json::from_str(&out).unwrap();
    assert_eq!(all.len(), 17);
    for s in &all {
        for key in ["axis", "position", "state", "homed", "trusted"] {
            assert!(s.get(key).is_some(), "{key} missing in {s}");
        }
    }
    let find = |n: &str| all.iter().find(|s| s["axis"] == n).unwrap().clone();
    assert_eq!(find("b:wp11")["position"], 3556);
    assert_eq!(find("a:focus")["position"], 2000);
    assert_eq!(find("a:focus")["state"], "idle");
    // A bare axis is ambiguous with two boards; an unknown axis is refused.
    let (code, _, err) = ctl(&["home", "wp1"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("BOARD:AXIS"), "{err}");
    let (code, _, err) = ctl(&["move", "a:nope", "5"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("error:4"), "{err}");
    // Homing a wave plate of the example (its sensor is noisy) and a synchronous group.
    assert_eq!(ctl(&["home", "a:wp3"]).0, Some(0));
    let (code, out, err) = ctl(&["group", "--sync", "a:wp1=1000", "a:wp2=-500", "a:slit=3200"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out, "wp1 target=1000\nwp2 target=3500\nslit target=3200\n");
    let (code, _, err) = ctl(&["group", "a:wp1=1", "b:wp11=1"]);
    assert_eq!(code, Some(2));
    // simulated boards share no SYNC line: refused before anything moves
    assert!(err.contains("has no SYNC line"), "{err}");
    assert_eq!(
        ctl(&["wait", "a:wp3", "a:wp1", "a:wp2", "a:slit"]).0,
        Some(0)
    );
    let (_, out, _) = ctl(&["status", "--json"]);
    let all: Vec<serde_json::Value> = serde_json::from_str(&out).unwrap();
    let find = |n: &str| all.iter().find(|s| s["axis"] == n).unwrap().clone();
    assert_eq!(
        (
            find("a:wp3")["homed"].clone(),
            find("a:wp3")["position"].clone()
        ),
        (true.into(), 0.into())
    );
    assert_eq!(find("a:wp1")["move_end"], find("a:slit")["move_end"]);
    assert_eq!(find("a:wp2")["position"], 3500);
    assert_eq!(ctl(&["estop"]).0, Some(0));
    let (code, _, err) = ctl(&["move", "a:slit", "5"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("error:11"), "{err}");
    assert_eq!(ctl(&["reset"]).0, Some(0));
}

#[test]
fn group_moves_share_a_start_tick_and_sync_a_finish_tick_over_the_protocol() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Server::start(dir.path(), None, 50.0, &[]);
    let mut c = srv.client();
    c.request("group move X=4000 Y=-300 Z=1500 sync").unwrap();
    let st = c.status().unwrap();
    let (x, y, z) = (&st[0], &st[1], &st[2]);
    assert_eq!(x.move_start, y.move_start);
    assert_eq!(x.move_start, z.move_start);
    assert_eq!(x.move_end, y.move_end);
    assert_eq!(x.move_end, z.move_end);
    for a in ["X", "Y", "Z"] {
        wait_idle(&mut c, a);
    }
    let pos: Vec<i64> = c.status().unwrap().iter().map(|s| s.position).collect();
    assert_eq!(pos, [4000, -300, 1500, 0]);
    // Named positions and presets persist and drive moves.
    c.request("save here X Y").unwrap();
    c.request("preset slow vmax=500 amax=2000").unwrap();
    c.request("group moveto X=0 Y=0 preset=slow").unwrap();
    wait_idle(&mut c, "X");
    wait_idle(&mut c, "Y");
    assert_eq!(status(&mut c, "X").position, 0);
    c.request("goto here").unwrap();
    wait_idle(&mut c, "X");
    wait_idle(&mut c, "Y");
    let pos: Vec<i64> = c.status().unwrap().iter().map(|s| s.position).collect();
    assert_eq!(pos, [4000, -300, 1500, 0]);
    assert_eq!(
        c.request("presets").unwrap(),
        vec!["slow vmax=500 amax=2000"]
    );
}

#[test]
fn the_protocol_runs_over_a_serial_pseudo_terminal() {
    use serialport::SerialPort;
    let (mut master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let dev = slave.name().expect("pty name");
    let dir = tempfile::tempdir().unwrap();
    let _srv = Server::start(dir.path(), None, 10.0, &["--serial", &dev]);
    master.set_timeout(Duration::from_millis(200)).unwrap();
    let read_until = |master: &mut serialport::TTYPort, want: &str| {
        let mut got = String::new();
        let t0 = Instant::now();
        while !(got.contains(want) && got.ends_with('\n')) {
            assert!(
                t0.elapsed() < Duration::from_secs(20),
                "no '{want}' on {dev}: {got:?}"
            );
            let mut buf = [0u8; 4096];
            if let Ok(n) = master.read(&mut buf) {
                got.push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        }
        got
    };
    // `serve` opens the device before it announces that it listens.
    master.write_all(b"version\n").unwrap();
    let got = read_until(&mut master, "ok\n");
    assert!(got.contains("multistep-controller"), "{got:?}");
    master.write_all(b"move X 100\nmove Q 1\n").unwrap();
    let reply = read_until(&mut master, "error:");
    assert!(reply.starts_with("X target=100\nok\nerror:4 "), "{reply:?}");
    drop(slave);
}

/// Copies bytes both ways between two pseudo-terminal masters until `stop`: a null-modem
/// cable between the board's serial line and the host's.
fn null_modem(
    a: serialport::TTYPort,
    b: serialport::TTYPort,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Vec<std::thread::JoinHandle<()>> {
    use serialport::SerialPort;
    let pipe = |mut from: serialport::TTYPort,
                mut to: serialport::TTYPort,
                stop: std::sync::Arc<std::sync::atomic::AtomicBool>| {
        std::thread::spawn(move || {
            from.set_timeout(Duration::from_millis(50)).unwrap();
            let mut buf = [0u8; 4096];
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                match from.read(&mut buf) {
                    Ok(n) if n > 0 => to.write_all(&buf[..n]).unwrap(),
                    _ => {}
                }
            }
        })
    };
    let (a2, b2) = (a.try_clone_native().unwrap(), b.try_clone_native().unwrap());
    vec![pipe(a, b2, stop.clone()), pipe(b, a2, stop)]
}

#[test]
fn ctl_talks_to_a_board_over_a_serial_line() {
    use serialport::SerialPort;
    let (board_m, board_s) = serialport::TTYPort::pair().unwrap();
    let (host_m, host_s) = serialport::TTYPort::pair().unwrap();
    let (board_dev, host_dev) = (board_s.name().unwrap(), host_s.name().unwrap());
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let cable = null_modem(board_m, host_m, stop.clone());
    let dir = tempfile::tempdir().unwrap();
    // the device is open once `serve` announces itself
    let _srv = Server::start(dir.path(), None, 20.0, &["--serial", &board_dev]);
    let boards = [format!("s=serial:{host_dev}")];
    let ctl = |args: &[&str]| run_ctl(&boards, args);
    let (code, out, err) = ctl(&["move", "Y", "-250"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out, "Y target=-250\n");
    assert_eq!(ctl(&["wait", "Y"]).0, Some(0));
    let (code, out, err) = ctl(&["status", "--json"]);
    assert_eq!(code, Some(0), "{err}");
    let all: Vec<serde_json::Value> = serde_json::from_str(&out).unwrap();
    assert_eq!(all[1]["axis"], "s:Y");
    assert_eq!(all[1]["position"], -250);
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    for t in cable {
        t.join().unwrap();
    }
    drop((board_s, host_s));
}

// ---- hardening: limits, partial lines, authentication, damaged data, crash recovery ----

/// Reads one connection to its end (the board closes it): everything it said.
fn read_all(s: &mut std::net::TcpStream) -> String {
    s.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
    let mut out = String::new();
    let _ = s.read_to_string(&mut out);
    out
}

/// `multistep serve ARGS` that is expected to exit: (code, stderr). Killed after 60 s.
fn serve_exits(args: &[&str], data: &Path) -> (Option<i32>, String) {
    let mut child = Command::new(BIN)
        .arg("serve")
        .arg("--data")
        .arg(data)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let code = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st.code();
        }
        if t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (code, err)
}

fn refused(r: Result<Vec<String>, ClientError>) -> (u16, String) {
    match r {
        Err(ClientError::Refused(r)) => (r.code, r.message),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn settings_out_of_range_are_refused_and_one_stored_by_an_older_build_is_clamped() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    {
        let mut srv = Server::start(&data, None, 10.0, &[]);
        let mut c = srv.client();
        for (key, value) in [
            ("sim.bounce_count", "4294967295"),
            ("sim.bounce_count", "101"),
            ("steps_per_unit", "1e-320"),
            ("vmax", "1e7"),
            ("home_search", "18446744073709551615"),
            ("debounce", "1e300"),
        ] {
            let (code, msg) = refused(c.request(&format!("set X {key} {value}")));
            assert_eq!(code, 9, "set X {key} {value}: {msg}");
            assert!(msg.contains(key), "{msg}");
        }
        assert_eq!(
            c.request("get X sim.bounce_count").unwrap(),
            ["sim.bounce_count=0"]
        );
        c.request("set X sim.bounce_count 100").unwrap();
        srv.kill9();
    }
    // An older build stored a value out of today's range: the board starts, says so once,
    // and uses the nearest allowed value.
    {
        let store = multistep_controller::store::Store::open(&data).unwrap();
        let mut s = store.settings("X").unwrap().unwrap();
        s.sim.bounce_count = u32::MAX;
        s.sim.bounce_time = 0.01;
        s.sim.sensor_at = -50;
        store.put_settings("X", &s).unwrap();
    }
    let log = dir.path().join("stderr.txt");
    let srv = Server::start_with(
        &data,
        None,
        10.0,
        &[],
        "127.0.0.1:0",
        Stdio::from(std::fs::File::create(&log).unwrap()),
    );
    let mut c = srv.client();
    assert_eq!(
        c.request("get X sim.bounce_count").unwrap(),
        ["sim.bounce_count=100"]
    );
    let err = std::fs::read_to_string(&log).unwrap();
    assert!(
        err.contains(
            "warning: axis X: stored sim.bounce_count 4294967295 is outside [0, 100]; using 100"
        ),
        "{err}"
    );
    assert!(c
        .request("info")
        .unwrap()
        .iter()
        .any(|l| l.contains("sim.bounce_count")));
    // Crossing the bouncing sensor works and the board stays responsive.
    c.request("move X -200").unwrap();
    let x = wait_idle(&mut c, "X");
    assert_eq!(x.position, -200);
}

#[test]
fn no_setting_in_range_makes_estop_or_any_command_slow() {
    let dir = tempfile::tempdir().unwrap();
    // The heaviest simulation the ranges allow, run 10 000 times faster than the wall clock:
    // far more work than the machine can do in real time.
    let srv = Server::start(dir.path(), None, 10_000.0, &[]);
    let mut c = srv.client();
    for a in ["X", "Y", "Z", "A"] {
        for (k, v) in [
            ("vmax", "1e6"),
            ("amax", "1e9"),
            ("sim.sensor_width", "1"),
            ("sim.bounce_count", "100"),
            ("sim.bounce_time", "1"),
            ("sim.glitch_rate", "1e4"),
            ("sim.glitch_max", "1"),
            ("sim.glitch_gap", "0"),
        ] {
            c.request(&format!("set {a} {k} {v}")).unwrap();
        }
        c.request(&format!("set {a} period 2")).unwrap();
    }
    c.request("group move X=1 Y=1 Z=1 A=1").unwrap();
    for a in ["X", "Y", "Z", "A"] {
        wait_idle(&mut c, a);
        c.request(&format!("set {a} period none")).unwrap();
        c.request(&format!("move {a} 20000000 vmax=200000"))
            .unwrap();
    }
    let mut slowest = Duration::ZERO;
    for _ in 0..20 {
        std::thread::sleep(Duration::from_millis(20));
        let t0 = Instant::now();
        c.request("status").unwrap();
        slowest = slowest.max(t0.elapsed());
    }
    let t0 = Instant::now();
    c.request("estop").unwrap();
    let estop = t0.elapsed();
    // Bounds only a hang reaches: without the work budget these take many minutes; the
    // latency itself is measured by the estop_load benchmark (BENCHMARKS.md).
    assert!(estop < Duration::from_secs(60), "estop took {estop:?}");
    assert!(slowest < Duration::from_secs(60), "status took {slowest:?}");
    let st = c.status().unwrap();
    assert!(st.iter().all(|s| s.state != AxisState::Moving), "{st:?}");
    // A move too long to time quickly is refused rather than holding the board up.
    c.request("reset").unwrap();
    let (code, msg) = refused(c.request("move X 900000000000"));
    assert_eq!(code, 15, "{msg}");
}

#[test]
fn a_line_cut_off_by_a_disconnect_is_never_run() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Server::start(dir.path(), None, 10.0, &[]);
    for partial in [&b"move Y 12"[..], b"set Y vmax 3", b"version\nmove Y 5"] {
        let mut s = std::net::TcpStream::connect(&srv.addr).unwrap();
        s.write_all(partial).unwrap();
        s.shutdown(std::net::Shutdown::Write).unwrap();
        let out = read_all(&mut s);
        let complete = partial.iter().filter(|&&b| b == b'\n').count();
        assert_eq!(out.matches("ok\n").count(), complete, "{out:?}");
    }
    let mut c = srv.client();
    assert_eq!(status(&mut c, "Y").position, 0);
    assert_eq!(c.request("get Y vmax").unwrap(), ["vmax=4000.0"]);
}

/// A pseudo-terminal master opened close-on-exec, so that no process spawned meanwhile
/// holds it: closing it hangs the line up.
struct Pty {
    master: std::fs::File,
    slave: String,
}

impl Pty {
    fn open() -> Pty {
        use std::os::fd::FromRawFd;
        // SAFETY: plain libc calls on a descriptor this function owns.
        unsafe {
            let fd = libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY | libc::O_CLOEXEC);
            assert!(fd >= 0, "posix_openpt");
            assert_eq!(libc::grantpt(fd), 0);
            assert_eq!(libc::unlockpt(fd), 0);
            let mut name = [0 as libc::c_char; 128];
            assert_eq!(libc::ptsname_r(fd, name.as_mut_ptr(), name.len()), 0);
            let slave = std::ffi::CStr::from_ptr(name.as_ptr())
                .to_str()
                .unwrap()
                .to_string();
            Pty {
                master: std::fs::File::from_raw_fd(fd),
                slave,
            }
        }
    }

    /// Reads until `want` and a newline have come (30 s at most).
    fn read_until(&mut self, want: &str) -> String {
        self.read_within(want, Duration::from_secs(30))
            .unwrap_or_else(|got| panic!("no '{want}': {got:?}"))
    }

    /// Waits until the service has the device open: `version` sent again until answered
    /// (a line sent before the service opens the device is dropped by the open).
    fn wait_served(&mut self) {
        let t0 = Instant::now();
        loop {
            self.master.write_all(b"version\n").unwrap();
            if self.read_within("ok\n", Duration::from_millis(300)).is_ok() {
                return;
            }
            assert!(t0.elapsed() < Duration::from_secs(30), "never served");
        }
    }

    /// What came until `want` and a newline, or what came within `limit` without them.
    fn read_within(&mut self, want: &str, limit: Duration) -> Result<String, String> {
        use std::os::fd::AsRawFd;
        let mut got = String::new();
        let t0 = Instant::now();
        while !(got.contains(want) && got.ends_with('\n')) {
            if t0.elapsed() > limit {
                return Err(got);
            }
            let mut p = libc::pollfd {
                fd: self.master.as_raw_fd(),
                events: libc::POLLIN,
                revents: 0,
            };
            // SAFETY: one valid pollfd.
            if unsafe { libc::poll(&mut p, 1, 100) } == 1 && p.revents & libc::POLLIN != 0 {
                let mut buf = [0u8; 1024];
                if let Ok(n) = self.master.read(&mut buf) {
                    got.push_str(&String::from_utf8_lossy(&buf[..n]));
                }
            }
        }
        Ok(got)
    }
}

#[test]
fn a_paused_partial_serial_line_is_dropped_and_a_hang_up_drops_it_too() {
    let dir = tempfile::tempdir().unwrap();
    // The board opens the device by a name that is pointed at a new pseudo-terminal when
    // the first one hangs up: a cable unplugged and plugged in again.
    let link = dir.path().join("tty");
    let mut pty = Pty::open();
    std::os::unix::fs::symlink(&pty.slave, &link).unwrap();
    let link_s = link.to_str().unwrap().to_string();
    let srv = Server::start(
        &dir.path().join("data"),
        None,
        10.0,
        &["--serial", &link_s, "--line-timeout", "1"],
    );
    // `serve` announced itself with the device open
    pty.master.write_all(b"version\n").unwrap();
    pty.read_until("ok\n");
    // A host that sent half a line, went away and came back: the pause drops the half.
    pty.master.write_all(b"move X 1").unwrap();
    std::thread::sleep(Duration::from_millis(1800));
    pty.master.write_all(b"0\n").unwrap();
    let got = pty.read_until("error:");
    assert!(got.starts_with("error:3 unknown command '0'"), "{got:?}");
    // Half a line, then the line hangs up and a new one comes on the same name.
    pty.master.write_all(b"move X 1").unwrap();
    std::thread::sleep(Duration::from_millis(200));
    drop(pty);
    std::fs::remove_file(&link).unwrap();
    let mut pty = Pty::open();
    std::os::unix::fs::symlink(&pty.slave, &link).unwrap();
    pty.wait_served();
    pty.master.write_all(b"0\n").unwrap();
    let got = pty.read_until("error:");
    assert!(got.starts_with("error:3 unknown command '0'"), "{got:?}");
    let mut c = srv.client();
    assert_eq!(status(&mut c, "X").position, 0, "no partial line was run");
}

const TOKEN: &str = "s3cret-token-0123456789";

#[test]
fn the_line_protocol_off_loopback_needs_the_flag_and_a_token() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let (code, err) = serve_exits(&["--listen", "0.0.0.0:0"], &data);
    assert_eq!(code, Some(2));
    assert!(
        err.starts_with("error:") && err.contains("--listen-allow-remote"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    let (code, err) = serve_exits(&["--listen", "0.0.0.0:0", "--listen-allow-remote"], &data);
    assert_eq!(code, Some(2));
    assert!(err.contains("--listen-token"), "{err}");
    let (code, err) = serve_exits(
        &[
            "--listen",
            "0.0.0.0:0",
            "--listen-allow-remote",
            "--listen-token",
            "short",
        ],
        &data,
    );
    assert_eq!(code, Some(2));
    assert!(err.contains("16 to 256"), "{err}");

    let srv = Server::start_with(
        &data,
        None,
        10.0,
        &["--listen-allow-remote", "--listen-token", TOKEN],
        "0.0.0.0:0",
        Stdio::piped(),
    );
    // Without `auth` first: one error line, closed, nothing run.
    let mut s = std::net::TcpStream::connect(&srv.addr).unwrap();
    s.write_all(b"move X 10\nmove X 10\n").unwrap();
    let out = read_all(&mut s);
    assert!(
        out.starts_with("error:16 authentication required"),
        "{out:?}"
    );
    assert_eq!(out.lines().count(), 1, "{out:?}");
    let mut s = std::net::TcpStream::connect(&srv.addr).unwrap();
    s.write_all(b"auth not-the-token-at-all\nmove X 10\n")
        .unwrap();
    let out = read_all(&mut s);
    assert!(out.starts_with("error:16 wrong token"), "{out:?}");
    assert_eq!(out.lines().count(), 1, "{out:?}");
    // With it, the connection is a normal one.
    let mut c = srv.client();
    c.authenticate(TOKEN).unwrap();
    assert_eq!(status(&mut c, "X").position, 0);
    // ctl passes the token; without it ctl fails with the board's refusal.
    let boards = [format!("b=tcp://{}", srv.addr)];
    let (code, out, err) = run_ctl(&boards, &["--token", TOKEN, "move", "X", "10"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out, "X target=10\n");
    let (code, _, err) = run_ctl(&boards, &["move", "X", "10"]);
    assert_eq!(code, Some(2));
    assert!(err.contains("error:16"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

#[test]
fn clients_are_capped_and_idle_or_dribbling_clients_are_closed() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Server::start(
        dir.path(),
        None,
        10.0,
        &[
            "--max-clients",
            "2",
            "--idle-timeout",
            "3",
            "--line-timeout",
            "1",
        ],
    );
    let mut a = srv.client();
    let mut b = srv.client();
    a.request("version").unwrap();
    b.request("version").unwrap();
    let mut third = std::net::TcpStream::connect(&srv.addr).unwrap();
    let out = read_all(&mut third);
    assert!(
        out.starts_with("error:17 too many clients (at most 2)"),
        "{out:?}"
    );
    assert_eq!(out.lines().count(), 1);
    drop(b);
    // The slot comes back once the board sees the client gone.
    let t0 = Instant::now();
    let mut slowloris = loop {
        let mut s = std::net::TcpStream::connect(&srv.addr).unwrap();
        s.write_all(b"version\n").unwrap();
        let mut r = BufReader::new(s.try_clone().unwrap());
        let mut l = String::new();
        r.read_line(&mut l).unwrap();
        if l.starts_with("multistep-controller") {
            r.read_line(&mut l).unwrap();
            break s;
        }
        assert!(t0.elapsed() < Duration::from_secs(20), "{l}");
        std::thread::sleep(Duration::from_millis(50));
    };
    // A line that never ends closes its connection, unrun, even while bytes trickle in.
    let t0 = Instant::now();
    for b in b"move X" {
        if slowloris.write_all(&[*b]).is_err() {
            break;
        }
        std::thread::sleep(Duration::from_millis(300));
    }
    let out = read_all(&mut slowloris);
    assert!(
        out.contains("error:17 line not completed within 1 s"),
        "{out:?}"
    );
    assert!(t0.elapsed() < Duration::from_secs(30));
    // An idle client is closed after the idle timeout with one line.
    let mut idle = std::net::TcpStream::connect(&srv.addr).unwrap();
    let t0 = Instant::now();
    let out = read_all(&mut idle);
    assert!(out.starts_with("error:17 idle for 3 s"), "{out:?}");
    assert!(t0.elapsed() >= Duration::from_secs(2), "{:?}", t0.elapsed());
    // The first client, also idle by now, went the same way; a new one is served.
    let _ = a.request("version");
    let mut c = srv.client();
    assert_eq!(status(&mut c, "X").position, 0);
    let (code, err) = serve_exits(
        &["--listen", "127.0.0.1:0", "--max-clients", "0"],
        dir.path(),
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("max clients must be in [1, 1024]"), "{err}");
}

#[test]
fn a_damaged_database_gives_one_error_line_and_a_fresh_start_needs_a_flag() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    {
        let mut srv = Server::start(&data, None, 10.0, &[]);
        let mut c = srv.client();
        c.request("set X vmax 1234").unwrap();
        c.request("save here").unwrap();
        srv.kill9();
    }
    let db = data.join("board.redb");
    let full = std::fs::read(&db).unwrap();
    let listen = ["--listen", "127.0.0.1:0"];
    for (what, bytes) in [
        ("truncated", &full[..full.len() / 2]),
        ("empty", &full[..0]),
        ("not a database", &b"hello world garbage"[..]),
    ] {
        std::fs::write(&db, bytes).unwrap();
        let (code, err) = serve_exits(&listen, &data);
        assert_eq!(code, Some(2), "{what}: {err}");
        assert_eq!(err.lines().count(), 1, "{what}: {err}");
        assert!(
            err.starts_with("error:") && err.contains("damaged"),
            "{what}: {err}"
        );
        assert!(
            err.contains("--reset-damaged-data") && !err.contains("panicked"),
            "{err}"
        );
        assert_eq!(
            std::fs::read(&db).unwrap(),
            bytes,
            "{what}: the file is left as it was"
        );
    }
    // With the flag: the damaged file is kept aside under the name printed.
    std::fs::write(&db, &full[..full.len() / 2]).unwrap();
    let log = dir.path().join("stderr.txt");
    let srv = Server::start_with(
        &data,
        None,
        10.0,
        &["--reset-damaged-data"],
        "127.0.0.1:0",
        Stdio::from(std::fs::File::create(&log).unwrap()),
    );
    let mut c = srv.client();
    assert_eq!(
        c.request("get X vmax").unwrap(),
        ["vmax=4000.0"],
        "a new board"
    );
    let err = std::fs::read_to_string(&log).unwrap();
    let aside = err
        .split("moved to ")
        .nth(1)
        .and_then(|r| r.split(';').next())
        .unwrap_or_else(|| panic!("{err}"));
    assert_eq!(std::fs::read(aside).unwrap(), &full[..full.len() / 2]);
}

#[test]
fn after_kill_9_during_homing_the_mechanics_are_where_they_were_and_homing_works() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write_config(
        dir.path(),
        "[[axis]]\nname = \"X\"\nhome_speed = 2000.0\n[axis.sim]\nsensor_at = -60000\n",
    );
    let data = dir.path().join("data");
    let mut srv = Server::start(&data, Some(&cfg), 20.0, &[]);
    let mut c = srv.client();
    c.request("home X").unwrap();
    // 2000 steps/s × 20: the sensor is 1.5 s away; kill half a second in.
    std::thread::sleep(Duration::from_millis(500));
    let before = status(&mut c, "X");
    assert_eq!(before.state, AxisState::Homing);
    std::thread::sleep(Duration::from_millis(100));
    srv.kill9();
    let srv = Server::start(&data, Some(&cfg), 20.0, &[]);
    let mut c = srv.client();
    let x = status(&mut c, "X");
    assert!(!x.homed && !x.trusted);
    assert!(
        x.sim_position <= before.sim_position && x.sim_position > -60000,
        "the mechanics came back at {} (seen at {} before the kill)",
        x.sim_position,
        before.sim_position
    );
    c.request("home X").unwrap();
    let x = wait_idle(&mut c, "X");
    assert!(x.homed && x.trusted && x.fault.is_none(), "{x:?}");
    assert_eq!(x.position, 0);
    assert!((x.sim_position + 60000).abs() <= 1, "{x:?}");
}

#[test]
fn small_protocol_edges_crlf_limit_and_the_most_negative_target() {
    let dir = tempfile::tempdir().unwrap();
    let srv = Server::start(dir.path(), None, 10.0, &[]);
    let mut s = std::net::TcpStream::connect(&srv.addr).unwrap();
    // A 4096-byte comment line: the same answer with LF and CRLF; 4097 bytes is too long.
    let mut input = Vec::new();
    for end in [&b"\n"[..], b"\r\n"] {
        input.push(b'#');
        input.extend(std::iter::repeat_n(b'x', 4095));
        input.extend_from_slice(end);
    }
    input.push(b'#');
    input.extend(std::iter::repeat_n(b'x', 4096));
    input.extend_from_slice(b"\r\n");
    input.extend_from_slice(b"moveto X -9223372036854775808\nmove X 9223372036854775807\n");
    s.write_all(&input).unwrap();
    s.shutdown(std::net::Shutdown::Write).unwrap();
    let out = read_all(&mut s);
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(
        lines[..3],
        ["ok", "ok", "error:1 line is longer than 4096 bytes"],
        "{out}"
    );
    assert!(
        lines[3].starts_with("error:5 target -9223372036854775808 is outside"),
        "{out}"
    );
    assert!(
        lines[4].starts_with("error:5 target 9223372036854775807 is outside"),
        "{out}"
    );
    assert_eq!(lines.len(), 5, "{out}");
}

#[test]
fn out_of_file_descriptors_the_accept_error_is_logged_rarely_and_service_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("stderr.txt");
    let mut child = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -n 24 && exec {BIN} serve --listen 127.0.0.1:0 --max-clients 200 --data {}",
            dir.path().join("data").display()
        ))
        .stdout(Stdio::piped())
        .stderr(Stdio::from(std::fs::File::create(&log).unwrap()))
        .spawn()
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let addr = first.trim().rsplit("tcp://").next().unwrap().to_string();
    let held: Vec<_> = (0..40)
        .map(|_| std::net::TcpStream::connect(&addr).unwrap())
        .collect();
    std::thread::sleep(Duration::from_millis(1500));
    let err = std::fs::read_to_string(&log).unwrap();
    let lines = err.lines().filter(|l| l.contains("accept")).count();
    assert!((1..=2).contains(&lines), "{lines} accept lines:\n{err}");
    drop(held);
    let t0 = Instant::now();
    loop {
        let c = Client::connect(&Endpoint::Tcp(addr.clone()));
        if let Ok(mut c) = c {
            if c.request("version").is_ok() {
                break;
            }
        }
        assert!(t0.elapsed() < Duration::from_secs(30), "never served again");
        std::thread::sleep(Duration::from_millis(100));
    }
    let _ = child.kill();
    let _ = child.wait();
}

#[test]
fn the_web_side_takes_the_bearer_scheme_in_any_case() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("stderr.txt");
    let _srv = Server::start_with(
        &dir.path().join("data"),
        None,
        10.0,
        &["--http", "127.0.0.1:0", "--http-token", TOKEN],
        "127.0.0.1:0",
        Stdio::from(std::fs::File::create(&log).unwrap()),
    );
    let t0 = Instant::now();
    let web = loop {
        let err = std::fs::read_to_string(&log).unwrap();
        if let Some(a) = err.split("web page on http://").nth(1) {
            break a.split('/').next().unwrap().to_string();
        }
        assert!(t0.elapsed() < Duration::from_secs(20), "{err}");
        std::thread::sleep(Duration::from_millis(50));
    };
    for scheme in ["Bearer", "bearer", "BEARER"] {
        let mut s = std::net::TcpStream::connect(&web).unwrap();
        write!(
            s,
            "GET /api/status HTTP/1.1\r\nHost: {web}\r\nAuthorization: {scheme} {TOKEN}\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        let out = read_all(&mut s);
        assert!(out.starts_with("HTTP/1.1 200"), "{scheme}: {out}");
    }
}

#[test]
fn ctl_tracks_axes_by_board_and_number_with_named_rates() {
    let dir = tempfile::tempdir().unwrap();
    let a = Server::start(&dir.path().join("a"), None, 1.0, &[]);
    let b = Server::start(&dir.path().join("b"), None, 1.0, &[]);
    let boards = [format!("a=tcp://{}", a.addr), format!("b=tcp://{}", b.addr)];
    let ctl = |args: &[&str]| run_ctl(&boards, args);
    let (code, _, err) = ctl(&["rate", "--to", "b", "constant", "15041/324"]);
    assert_eq!(code, Some(0), "{err}");
    // b:2 is board b's Z; by name and number alike
    let (code, out, err) = ctl(&["track", "b:2", "constant"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.contains("rate=46.42"), "{out}");
    let (code, out, err) = ctl(&["track", "a:1", "-300", "--lease", "30"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(out.trim(), "1 rate=-300");
    let (_, out, _) = ctl(&["status", "--json"]);
    let st: Vec<AxisStatus> = serde_json::from_str(&out).unwrap();
    let z = st.iter().find(|s| s.axis == "b:Z").unwrap();
    assert_eq!((z.state, z.number), (AxisState::Tracking, 2));
    assert_eq!(z.rate, Some(15041.0 / 324.0));
    let y = st.iter().find(|s| s.axis == "a:Y").unwrap();
    assert_eq!((y.state, y.rate), (AxisState::Tracking, Some(-300.0)));
    let (_, table, _) = ctl(&["status"]);
    let row = table.lines().find(|l| l.starts_with("b:Z ")).unwrap();
    let cols: Vec<&str> = row.split_whitespace().collect();
    assert_eq!(
        (cols[1], cols[3], cols[7]),
        ("2", "tracking", "46.423"),
        "{row}"
    );
    // bad input: one error each, the exit status says so
    for bad in [
        &["track", "b:2", "abc"][..],
        &["track", "b:9", "10"],
        &["track", "a:Y", "1e9"],
        &["release", "a:1"],
    ] {
        let (code, _, err) = ctl(bad);
        assert_ne!(code, Some(0), "{bad:?}");
        assert!(err.contains("error:"), "{bad:?}: {err}");
    }
    assert_eq!(ctl(&["stop", "a:1"]).0, Some(0));
    assert_eq!(ctl(&["wait", "a:Y", "--timeout", "10"]).0, Some(0));
    assert_eq!(ctl(&["release", "a:1"]).0, Some(0));
    let mut c = a.client();
    let y = status(&mut c, "Y");
    assert!(!y.enabled && !y.trusted && y.position < 0, "{y:?}");
    assert_eq!(ctl(&["energize", "a:Y"]).0, Some(0));
    assert!(status(&mut c, "Y").enabled);
}

// ---- start-up settings that would lose data or freeze the board are refused ----

#[test]
fn a_sync_line_in_the_data_directory_or_on_a_device_is_refused_and_nothing_is_lost() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    {
        let mut srv = Server::start(&data, None, 10.0, &[]);
        srv.client().request("set X vmax 1234").unwrap();
        srv.kill9();
    }
    let db = data.join("board.redb");
    let listen = ["--listen", "127.0.0.1:0", "--board-config"];
    for (line, why) in [
        (db.to_str().unwrap(), "inside the board's data directory"),
        ("/dev/zero", "not a regular file"),
        ("", "is empty"),
        ("/no/such/dir/line", "not a directory"),
    ] {
        let config = write_config(
            dir.path(),
            &TWO_AXES.replace("[board]\n", &format!("[board]\nsync_line = {line:?}\n")),
        );
        let args = [&listen[..], &[config.to_str().unwrap()]].concat();
        let (code, err) = serve_exits(&args, &data);
        assert_eq!(code, Some(2), "{line}: {err}");
        assert_eq!(err.lines().count(), 1, "{line}: {err}");
        assert!(
            err.starts_with("error:") && err.contains("board.sync_line") && err.contains(why),
            "{line}: {err}"
        );
    }
    // The database is still the board's: its setting survived every refusal.
    let srv = Server::start(&data, None, 10.0, &[]);
    assert_eq!(srv.client().request("get X vmax").unwrap(), ["vmax=1234.0"]);
}

#[test]
fn a_time_scale_outside_its_range_is_refused_and_the_slowest_still_ticks() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    for x in ["1e-300", "0.0009", "0", "-1", "10001", "NaN", "inf"] {
        let (code, err) = serve_exits(&["--listen", "127.0.0.1:0", "--time-scale", x], &data);
        assert_eq!(code, Some(2), "{x}: {err}");
        assert_eq!(err.lines().count(), 1, "{x}: {err}");
        assert!(
            err.contains("time scale must be in [0.001, 10000]"),
            "{x}: {err}"
        );
    }
    assert!(!data.exists(), "a refused start creates no board");
    let help = Command::new(BIN)
        .args(["serve", "--help"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&help.stdout).contains("0.001 to 10000"));
    // At the slowest scale the board's clock still moves.
    let srv = Server::start(&data, None, 0.001, &[]);
    let mut c = srv.client();
    let tick = |c: &mut Client| -> u64 {
        let info = c.request("info").unwrap();
        let t = info.iter().find_map(|l| l.strip_prefix("tick="));
        t.unwrap().parse().unwrap()
    };
    let (t0, started) = (tick(&mut c), Instant::now());
    while tick(&mut c) == t0 {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "the clock stands"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn a_data_directory_deleted_under_serve_refuses_every_write() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("board");
    let log = dir.path().join("stderr.txt");
    let stderr = Stdio::from(std::fs::File::create(&log).unwrap());
    let s = Server::start_with(&data, None, 10.0, &[], "127.0.0.1:0", stderr);
    let mut c = s.client();
    c.request("preset fast vmax=1000").unwrap();
    c.request("save p0").unwrap();
    std::fs::remove_dir_all(&data).unwrap();
    for line in [
        "save p1",
        "move X 100",
        "preset slow vmax=10",
        "rate sidereal 15",
        "set X vmax 2000",
    ] {
        let (code, msg) = refused(c.request(line));
        assert_eq!(code, 20, "{line}: {msg}");
    }
    let st = c.request("status X").unwrap();
    assert!(st[0].contains(" store=gone "), "{st:?}");
    let info = c.request("info").unwrap();
    assert!(
        info.iter().any(|l| l.starts_with("store=gone: ")),
        "{info:?}"
    );
    assert!(!data.exists(), "the data directory was recreated");
    let err = std::fs::read_to_string(&log).unwrap();
    assert!(err.contains("was deleted"), "{err}");
}
