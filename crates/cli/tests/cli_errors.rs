//! What a user sees when something is wrong: clap's whole message with its hints, and errors
//! that name the file, the device or the directory. Status 2 every time.

use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

fn multistep(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_multistep"))
        .args(args)
        .output()
        .expect("run multistep")
}

/// Status 2, nothing on stdout; returns stderr.
fn failure(args: &[&str]) -> String {
    let out = multistep(args);
    let err = String::from_utf8(out.stderr).unwrap();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(out.stdout.is_empty(), "{args:?}");
    assert!(err.starts_with("error: "), "{args:?}: {err}");
    err
}

/// One line, as the library's errors are.
fn one_line_failure(args: &[&str]) -> String {
    let err = failure(args);
    assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    err
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("multistep-errors-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn missing_arguments_are_named_with_the_usage() {
    let cases: [(&[&str], &str, &str); 3] = [
        (
            &["ctl", "--board", "a=tcp://127.0.0.1:1", "move", "X"],
            "<STEPS>",
            "Usage: multistep ctl --board <NAME=ENDPOINT> move <AXIS> <STEPS>",
        ),
        (
            &["simulate"],
            "--motor <NAME|FILE>",
            "Usage: multistep simulate",
        ),
        (&["serve"], "--data <DIR>", "Usage: multistep serve"),
    ];
    for (args, missing, usage) in cases {
        let err = failure(args);
        assert!(
            err.starts_with("error: the following required arguments were not provided:"),
            "{err}"
        );
        assert!(err.contains(missing), "{args:?}: {err}");
        assert!(err.contains(usage), "{args:?}: {err}");
    }
}

#[test]
fn typos_get_clap_did_you_mean_hints() {
    let err = failure(&["plna"]);
    assert!(
        err.contains("tip: a similar subcommand exists: 'plan'"),
        "{err}"
    );
    let err = failure(&["plan", "--profil", "sine"]);
    assert!(
        err.contains("tip: a similar argument exists: '--profile'"),
        "{err}"
    );
    let err = failure(&["plan", "--steps", "ten", "--accel-time", "1"]);
    assert!(
        err.starts_with("error: invalid value 'ten' for '--steps <N>'"),
        "{err}"
    );
}

#[test]
fn help_and_version_still_succeed() {
    for args in [&["--help"][..], &["--version"], &["plan", "--help"]] {
        let out = multistep(args);
        assert_eq!(out.status.code(), Some(0), "{args:?}");
        assert!(!out.stdout.is_empty(), "{args:?}");
    }
}

#[test]
fn negative_numbers_reach_the_planner() {
    let err = one_line_failure(&[
        "plan",
        "--profile",
        "trapezoid",
        "--steps",
        "100",
        "--vmax",
        "-5",
        "--amax",
        "10",
    ]);
    assert_eq!(
        err.trim_end(),
        "error: vmax must be greater than zero (got -5)"
    );
    let err = one_line_failure(&["plan", "--segment", "-1:1:10"]);
    assert!(err.contains("start speed") && err.contains("-1"), "{err}");
    let err = failure(&["plan", "--steps", "-5", "--accel-time", "1"]);
    assert!(
        err.starts_with("error: invalid value '-5' for '--steps <N>'"),
        "{err}"
    );
}

#[test]
fn a_bad_board_config_is_named() {
    let dir = temp_dir("config");
    let data = dir.join("data");
    let cases = [
        ("syntax.toml", "axes = [", "TOML parse error at line 1"),
        (
            "field.toml",
            "[board]\nname = \"b\"\n[[axes]]\n",
            "unknown field `axes`",
        ),
    ];
    for (name, text, what) in cases {
        let file = dir.join(name);
        std::fs::write(&file, text).unwrap();
        let err = one_line_failure(&[
            "serve",
            "--data",
            data.to_str().unwrap(),
            "--listen",
            "127.0.0.1:0",
            "--board-config",
            file.to_str().unwrap(),
        ]);
        let head = format!("error: board config {}: ", file.display());
        assert!(err.starts_with(&head), "{err}");
        assert!(err.contains(what), "{err}");
    }
    let missing = dir.join("missing.toml");
    let err = one_line_failure(&[
        "serve",
        "--data",
        data.to_str().unwrap(),
        "--board-config",
        missing.to_str().unwrap(),
    ]);
    assert!(
        err.contains(&format!("board config {}", missing.display())),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_missing_serial_device_stops_serve() {
    let dir = temp_dir("serial");
    let dev = dir.join("ttyUSB0");
    let err = one_line_failure(&[
        "serve",
        "--data",
        dir.join("data").to_str().unwrap(),
        "--listen",
        "127.0.0.1:0",
        "--serial",
        dev.to_str().unwrap(),
    ]);
    assert!(
        err.starts_with(&format!("error: serial device {}: ", dev.display())),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn data_directory_problems_name_the_directory() {
    let dir = temp_dir("data");
    let file = dir.join("a-file");
    std::fs::write(&file, "x").unwrap();
    let err = one_line_failure(&["serve", "--data", file.to_str().unwrap()]);
    assert_eq!(
        err.trim_end(),
        format!("error: --data {}: not a directory", file.display())
    );
    let below = file.join("sub");
    let err = one_line_failure(&["serve", "--data", below.to_str().unwrap()]);
    assert!(err.starts_with(&format!("error: --data {}: cannot create", below.display())));

    // A second board on a database that one is using.
    let data = dir.join("board");
    let mut first = Command::new(env!("CARGO_BIN_EXE_multistep"))
        .args(["serve", "--listen", "127.0.0.1:0", "--data"])
        .arg(&data)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(first.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert!(line.contains("listening"), "{line}");
    let err = one_line_failure(&[
        "serve",
        "--listen",
        "127.0.0.1:0",
        "--data",
        data.to_str().unwrap(),
    ]);
    first.kill().ok();
    first.wait().ok();
    assert!(
        err.starts_with(&format!("error: --data {}: ", data.display())),
        "{err}"
    );
    assert!(err.contains("another `multistep serve`"), "{err}");

    // A file that is not a database.
    let junk = dir.join("junk");
    std::fs::create_dir_all(&junk).unwrap();
    std::fs::write(junk.join("board.redb"), "not a database").unwrap();
    let err = one_line_failure(&[
        "serve",
        "--listen",
        "127.0.0.1:0",
        "--data",
        junk.to_str().unwrap(),
    ]);
    assert!(err.starts_with(&format!(
        "error: --data {}: board database: ",
        junk.display()
    )));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn ctl_names_a_board_that_never_answers() {
    // Port 1 on loopback: nothing listens there, so every attempt is refused.
    let err = one_line_failure(&["ctl", "--board", "a=tcp://127.0.0.1:1", "status"]);
    assert!(
        err.starts_with("error: board a (tcp://127.0.0.1:1): "),
        "{err}"
    );
    assert!(err.contains("retried for 5 s"), "{err}");
}

#[test]
fn a_bad_multistep_font_is_named() {
    let dir = temp_dir("font");
    let not_a_font = dir.join("notes.txt");
    std::fs::write(&not_a_font, "not a font").unwrap();
    let missing = dir.join("missing.ttf");
    let plot = dir.join("p.svg");
    for (font, why) in [
        (&missing, "cannot read it"),
        (&not_a_font, "is not a usable TrueType font"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_multistep"))
            .args([
                "simulate", "--motor", "20mm", "--mode", "ideal", "--steps", "100",
            ])
            .args([
                "--accel-time",
                "0.01",
                "--cruise-time",
                "0",
                "--decel-time",
                "0.01",
            ])
            .arg("--plot")
            .arg(&plot)
            .env("MULTISTEP_FONT", font)
            .output()
            .unwrap();
        let err = String::from_utf8(out.stderr).unwrap();
        assert_eq!(out.status.code(), Some(2), "{err}");
        let named = format!("MULTISTEP_FONT={}", font.display());
        assert!(
            err.starts_with("error: ") && err.contains(&named) && err.contains(why),
            "{err}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
