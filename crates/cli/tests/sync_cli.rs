//! A group across boards through `serve` and `ctl`: two boards' RTL (`multistep board-sim
//! --boards 2`, one SYNC line), one `serve --board-link` per board, and `ctl group` with axes
//! on both. Needs `verilator` and `g++` (skipped with a message when missing, unless CI is
//! set: then it fails). On simulated boards, which have no SYNC line, the group is refused.

use multistep_controller::AxisStatus;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");

/// Two axes that move 200 steps in 0.02 s (a triangle at 1e6 steps/s²).
const CONFIG: &str = r#"[board]
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

/// `multistep serve` on `link` (None: the simulated board); its TCP address.
fn serve(dir: &Path, name: &str, link: Option<&str>) -> (Killed, String) {
    let config = dir.join(format!("{name}.toml"));
    std::fs::write(&config, CONFIG).unwrap();
    let mut cmd = Command::new(BIN);
    cmd.args(["serve", "--listen", "127.0.0.1:0", "--data"])
        .arg(dir.join(format!("{name}-data")))
        .arg("--board-config")
        .arg(&config)
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
    (Killed(child), addr)
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

fn model_cache() -> Option<PathBuf> {
    let have = ["verilator", "g++"]
        .iter()
        .all(|t| multistep_hdl::tools::find(t, t).is_ok());
    if !have {
        assert!(
            std::env::var("CI").map_or(true, |v| v != "true"),
            "verilator and g++ are needed under CI"
        );
        eprintln!("SKIPPED: verilator or g++ missing (apt-get install -y verilator g++)");
        return None;
    }
    Some(Path::new(env!("CARGO_TARGET_TMPDIR")).join("verilator"))
}

#[test]
fn a_group_across_two_boards_starts_on_one_sync_fall() {
    let Some(cache) = model_cache() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("edges");
    // Board 1's clock runs 50 ppm fast and starts 123.4 µs after board 0's.
    let mut sim = Command::new(BIN)
        .args([
            "board-sim",
            "--board",
            "ulx3s-25f",
            "--axes",
            "2",
            "--boards",
            "2",
        ])
        .args(["--ppm", "0,50", "--power-up-us", "0,123.4", "--edges"])
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
    let sim = Killed(sim);
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
    let (_sa, a) = serve(dir.path(), "a", Some(&format!("serial:{}", ptys[0])));
    let (_sb, b) = serve(dir.path(), "b", Some(&format!("serial:{}", ptys[1])));
    let addrs = [a, b];

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
    let mut sim = sim;
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
    let (_sa, a) = serve(dir.path(), "a", None);
    let (_sb, b) = serve(dir.path(), "b", None);
    let addrs = [a, b];
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
