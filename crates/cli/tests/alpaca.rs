//! `multistep serve --alpaca` as a process, driven by alpyca (the ASCOM Initiative's
//! Python Alpaca client, PyPI `alpyca`) through crates/cli/tests/alpaca_alpyca.py, with
//! the line protocol open beside it; and the flag's refusals.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");
const TOKEN: &str = "alpyca-token-0123456789";

const CONFIG: &str = r#"
[board]
name = "optics"
[[axis]]
name = "F"
soft_min = 0
soft_max = 20000
steps_per_unit = 100.0
vmax = 4000.0
amax = 40000.0
home_speed = 100.0
home_search = 10000000
sim.sensor_at = -1000000
[[axis]]
name = "R"
period = 36000
steps_per_unit = 100.0
vmax = 8000.0
amax = 80000.0
[[axis]]
name = "W"
period = 4000
vmax = 1000.0
amax = 4000.0

[[alpaca.focuser]]
axis = "F"
name = "Focus"
[[alpaca.rotator]]
axis = "R"
name = "Wave plate"
[[alpaca.filterwheel]]
axis = "W"
name = "Filters"
slots = [
  { name = "Ha", position = 0, focus_offset = 12 },
  { name = "CaK", position = 2000, focus_offset = -7 },
  { name = "Hb", position = 3000 },
]
"#;

fn write_config(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("board.toml");
    std::fs::write(&p, text).unwrap();
    p
}

struct Serve(Child);

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// alpyca importable? In CI (CI=true) its absence fails the test; locally it skips.
fn alpyca_present() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import alpaca.focuser, alpaca.discovery, ifaddr"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        let why = "python3 with alpyca is missing (pip install alpyca==3.1.3)";
        assert!(std::env::var("CI").as_deref() != Ok("true"), "{why}");
        eprintln!("skipped: {why}");
    }
    ok
}

#[test]
fn alpyca_drives_the_focuser_rotator_and_filter_wheel() {
    if !alpyca_present() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let cfg = write_config(tmp.path(), CONFIG);
    let mut child = Command::new(BIN)
        .args(["serve", "--listen", "127.0.0.1:0", "--data"])
        .arg(tmp.path().join("d"))
        .arg("--board-config")
        .arg(&cfg)
        .args(["--alpaca", "127.0.0.1:0", "--alpaca-discovery-port", "0"])
        .args(["--alpaca-token", TOKEN])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut said = String::new();
    BufReader::new(child.stderr.take().unwrap())
        .read_line(&mut said)
        .unwrap();
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let _serve = Serve(child);
    // "alpaca devices on http://127.0.0.1:P/ (discovery on udp port D)"
    let rest = said
        .trim()
        .strip_prefix("alpaca devices on http://")
        .expect(&said);
    let (http, rest) = rest.split_once("/ (discovery on udp port ").expect(&said);
    let discovery = rest.trim_end_matches(')');
    let tcp = first.trim().rsplit("tcp://").next().unwrap();

    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/alpaca_alpyca.py");
    let out = Command::new("python3")
        .args([script, http, discovery, tcp, TOKEN])
        .output()
        .unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    println!("{so}");
    assert!(out.status.success(), "alpyca run failed:\n{so}\n{se}");
    assert!(so.contains("alpyca: all checks passed"), "{so}");
}

#[test]
fn the_flag_refuses_remote_addresses_and_a_config_without_devices() {
    let tmp = tempfile::tempdir().unwrap();
    let with_devices = write_config(tmp.path(), CONFIG);
    let bad = tmp.path().join("bad.toml");
    std::fs::write(
        &bad,
        "[[axis]]\nname = \"X\"\n[[alpaca.rotator]]\naxis = \"X\"\n",
    )
    .unwrap();
    let none = tmp.path().join("none.toml");
    std::fs::write(&none, "[[axis]]\nname = \"X\"\n").unwrap();
    for (cfg, args, says) in [
        (
            &with_devices,
            vec!["--alpaca", "0.0.0.0:0"],
            "--alpaca-allow-remote",
        ),
        (
            &with_devices,
            vec!["--alpaca", "0.0.0.0:0", "--alpaca-allow-remote"],
            "needs an access token",
        ),
        (&none, vec!["--alpaca", "0"], "[alpaca] section"),
        // Checked with or without --alpaca: a bad section is an error, not ignored.
        (&bad, vec![], "360"),
    ] {
        let out = Command::new(BIN)
            .args(["serve", "--listen", "127.0.0.1:0", "--data"])
            .arg(tmp.path().join("d"))
            .arg("--board-config")
            .arg(cfg)
            .args(&args)
            .env_remove("MULTISTEP_ALPACA_TOKEN")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.starts_with("error:") && err.contains(says),
            "{args:?}: {err}"
        );
    }
}
