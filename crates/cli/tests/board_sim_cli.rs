//! `multistep board-sim`: the pty line first, the stdin commands, one `error:` line for bad
//! input. Needs `verilator` and `g++` (skipped with a message when missing, unless CI is
//! set: then it fails).

use std::io::{BufRead, BufReader, Write};
use std::process::{Command, Stdio};

fn exe() -> Command {
    Command::new(env!("CARGO_BIN_EXE_multistep"))
}

#[test]
fn unknown_board_is_one_error_line() {
    let out = exe()
        .args(["board-sim", "--board", "nope"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("error:") && err.contains("ulx3s-25f"),
        "{err}"
    );
    let out = exe()
        .args(["board-sim", "--board", "icebreaker", "--axes", "5"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("1..=4"));
}

/// The model cache of these tests, or None (skipped, with a message) when verilator or
/// g++ is missing (under CI that fails).
fn model_cache() -> Option<std::path::PathBuf> {
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
    Some(std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("verilator"))
}

/// Starts `multistep board-sim ARGS --cache-dir CACHE` with every stream piped.
fn board_sim(args: &[&str], cache: &std::path::Path) -> std::process::Child {
    exe()
        .arg("board-sim")
        .args(args)
        .arg("--cache-dir")
        .arg(cache)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

#[test]
fn prints_the_pty_first_and_takes_commands() {
    let Some(cache) = model_cache() else {
        return;
    };
    let mut child = board_sim(
        &["--board", "ulx3s-25f", "--axes", "2", "--sensor-at", "3"],
        &cache,
    );
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    let path = line
        .strip_prefix("pty ")
        .expect("the pty line first")
        .trim();
    assert!(std::path::Path::new(path).exists(), "{path}");
    let mut stdin = child.stdin.take().unwrap();
    writeln!(stdin, "bogus\nslip 1 5\nstate").unwrap();
    line.clear();
    out.read_line(&mut line).unwrap();
    let s: serde_json::Value = serde_json::from_str(&line).unwrap();
    assert_eq!(s["axes"].as_array().unwrap().len(), 2);
    assert_eq!(s["axes"][1]["position"], 5.0, "{line}");
    // the window is (3 - 400, 3]: axis 0 at 0 is in it, axis 1 slipped to 5 is not
    assert_eq!(s["axes"][0]["hall"], true, "{line}");
    assert_eq!(s["axes"][1]["hall"], false, "{line}");
    assert_eq!(s["clock_hz"], 50e6);
    writeln!(stdin, "quit").unwrap();
    let st = child.wait().unwrap();
    assert!(st.success());
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    // a cold model cache adds its one "building" line first
    let said: Vec<&str> = err
        .lines()
        .filter(|l| !l.starts_with("building the board's Verilator model"))
        .collect();
    assert_eq!(said.len(), 1, "{err}");
    assert!(
        said[0].starts_with("error: unknown command \"bogus\""),
        "{err}"
    );
}

#[test]
fn two_boards_print_two_ptys_and_take_board_prefixes() {
    let Some(cache) = model_cache() else {
        return;
    };
    let mut child = board_sim(
        &[
            "--board",
            "ulx3s-25f",
            "--axes",
            "2",
            "--boards",
            "2",
            "--ppm",
            "0,-20",
            "--power-up-us",
            "0,5",
        ],
        &cache,
    );
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut paths = Vec::new();
    for _ in 0..2 {
        let mut line = String::new();
        out.read_line(&mut line).unwrap();
        let p = line.strip_prefix("pty ").expect("pty lines first").trim();
        assert!(std::path::Path::new(p).exists(), "{p}");
        paths.push(p.to_string());
    }
    assert_ne!(paths[0], paths[1]);
    let mut stdin = child.stdin.take().unwrap();
    writeln!(stdin, "@2 state\n@1 slip 0 5\nstate").unwrap();
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    let s: serde_json::Value = serde_json::from_str(&line).unwrap();
    let boards = s.as_array().unwrap();
    assert_eq!(boards.len(), 2, "{line}");
    assert_eq!(boards[0]["axes"][0]["position"], 0.0, "{line}");
    assert_eq!(boards[1]["axes"][0]["position"], 5.0, "{line}");
    writeln!(stdin, "quit").unwrap();
    assert!(child.wait().unwrap().success());
    let mut err = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
    // one error line (and the model's build note, if this process built it)
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| !l.starts_with("building the board's Verilator model"))
        .collect();
    assert_eq!(lines.len(), 1, "{err}");
    assert!(err.contains("no board 2"), "{err}");
}
