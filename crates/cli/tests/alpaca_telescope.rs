//! The Alpaca Telescope of `multistep serve --alpaca`, driven by alpyca through
//! crates/cli/tests/alpaca_telescope.py: every ITelescopeV4 member against the checks
//! docs/ALPACA.md lists, then parking and sync offsets across a restart of the service on
//! the same data.

mod common;

use common::EchoedStderr;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");
const TOKEN: &str = "alpyca-token-0123456789";

/// A German equatorial mount: one step is 3.6″, sidereal is 4.178 steps/s; the Hall
/// sensors sit 100° below the start, past where the checks drive the axes.
const CONFIG: &str = r#"
[board]
name = "mount"
[[axis]]
name = "ha"
vmax = 40000.0
amax = 80000.0
home_speed = 20000.0
home_search = 1000000
sim.sensor_at = -100000
[[axis]]
name = "dec"
vmax = 40000.0
amax = 80000.0
home_speed = 20000.0
home_search = 1000000
sim.sensor_at = -100000

[[alpaca.telescope]]
name = "Mount"
mount = "german"
ra_axis = "ha"
dec_axis = "dec"
ra_steps_per_rev = 360000
dec_steps_per_rev = 360000
latitude = 52.0
longitude = 4.5
elevation = 12.0
ha_limit = 80.0
horizon = 0.0
"#;

/// The service, stopped when dropped; its stderr past the first line is echoed (the
/// mount's warnings), so the pipe stays open while it runs.
struct Serve {
    child: Child,
    stderr: EchoedStderr,
}

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        self.stderr.flush_if_failing();
    }
}

/// alpyca importable? In CI (CI=true) its absence fails the test; locally it skips.
fn alpyca_present() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import alpaca.telescope"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        let why = "python3 with alpyca is missing (pip install alpyca==3.1.3)";
        assert!(std::env::var("CI").as_deref() != Ok("true"), "{why}");
        eprintln!("skipped: {why}");
    }
    ok
}

/// Starts serve on `dir`; returns it with its Alpaca and line-protocol addresses.
fn serve(dir: &Path, cfg: &Path) -> (Serve, String, String) {
    let mut child = Command::new(BIN)
        .args(["serve", "--listen", "127.0.0.1:0", "--data"])
        .arg(dir.join("d"))
        .arg("--board-config")
        .arg(cfg)
        .args(["--alpaca", "127.0.0.1:0", "--alpaca-token", TOKEN])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut said = String::new();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    err.read_line(&mut said).unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let http = said
        .trim()
        .strip_prefix("alpaca devices on http://")
        .and_then(|r| r.split('/').next())
        .expect(&said)
        .to_string();
    let tcp = first.trim().rsplit("tcp://").next().unwrap().to_string();
    let stderr = EchoedStderr::start(err);
    (Serve { child, stderr }, http, tcp)
}

fn run(mode: &str, http: &str, tcp: &str, extra: &[&str]) -> String {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/alpaca_telescope.py");
    let out = Command::new("python3")
        .args([script, mode, http, tcp, TOKEN])
        .args(extra)
        .output()
        .unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    println!("{so}");
    assert!(
        out.status.success(),
        "alpyca {mode} run failed:\n{so}\n{se}"
    );
    assert!(so.contains(" 0 failures"), "{so}");
    so.to_string()
}

#[test]
fn alpyca_checks_every_telescope_member_and_parking_survives_a_restart() {
    if !alpyca_present() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let cfg = tmp.path().join("board.toml");
    std::fs::write(&cfg, CONFIG).unwrap();
    let (parked, pointing) = {
        let (_serve, http, tcp) = serve(tmp.path(), &cfg);
        let so = run("first", &http, &tcp, &[]);
        let line = |p: &str| so.lines().find(|l| l.starts_with(p)).unwrap().to_string();
        (line("park position"), line("pointing "))
    };
    // The service stopped; a new one on the same data finds the mount parked, pointing
    // where it did (the sync offsets kept).
    let (_serve, http, tcp) = serve(tmp.path(), &cfg);
    let at: Vec<&str> = pointing.split(' ').skip(1).collect();
    assert_eq!(at.len(), 2, "{pointing}");
    let so = run("restart", &http, &tcp, &at);
    assert!(so.contains("telescope: "), "{so}");
    assert!(parked.starts_with("park position "), "{parked}");
}

#[test]
fn a_telescope_beyond_its_ranges_is_refused_at_start() {
    let tmp = tempfile::tempdir().unwrap();
    for (from, to, says) in [
        (
            "latitude = 52.0",
            "latitude = 95.0",
            "latitude = 95 is outside -90 to 90",
        ),
        (
            "ha_limit = 80.0",
            "ha_limit = 200.0",
            "ha_limit = 200 is outside 0 to 180",
        ),
        (
            "dec_axis = \"dec\"",
            "dec_axis = \"ha\"",
            "given to two devices",
        ),
        ("mount = \"german\"", "mount = \"altaz\"", "unknown variant"),
    ] {
        let bad = CONFIG.replace(from, to);
        assert_ne!(bad, CONFIG, "{from}");
        let cfg = tmp.path().join("bad.toml");
        std::fs::write(&cfg, &bad).unwrap();
        let out = Command::new(BIN)
            .args(["serve", "--listen", "127.0.0.1:0", "--data"])
            .arg(tmp.path().join("d"))
            .arg("--board-config")
            .arg(&cfg)
            .args(["--alpaca", "127.0.0.1:0"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{to}: {err}");
        let key = says.split(' ').next().unwrap();
        assert!(
            err.starts_with("error:") && err.contains(key),
            "{says}: {err}"
        );
    }
}
