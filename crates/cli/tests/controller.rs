//! The controller as a real process: `multistep serve` spawned, driven over TCP, a serial
//! pseudo-terminal and `multistep ctl`, killed with SIGKILL and restarted.

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
}

impl Server {
    fn start(data: &Path, config: Option<&Path>, time_scale: f64, extra: &[&str]) -> Server {
        let mut cmd = Command::new(BIN);
        cmd.args([
            "serve",
            "--listen",
            "127.0.0.1:0",
            "--time-scale",
            &time_scale.to_string(),
        ])
        .arg("--data")
        .arg(data)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
        if let Some(c) = config {
            cmd.arg("--board-config").arg(c);
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
    let t0 = Instant::now();
    loop {
        let s = status(c, axis);
        if s.state != AxisState::Moving && s.state != AxisState::Homing {
            return s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "{axis} never stopped: {s:?}"
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
    std::thread::sleep(Duration::from_millis(300));
    let x = status(&mut c, "X");
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
    assert!(err.contains("one board"), "{err}");
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
    // The service opens the device just after it starts listening.
    std::thread::sleep(Duration::from_millis(300));
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
    let _srv = Server::start(dir.path(), None, 20.0, &["--serial", &board_dev]);
    std::thread::sleep(Duration::from_millis(300));
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
