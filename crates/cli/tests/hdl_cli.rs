//! `multistep hdl`: emit writes both tops; bad parameters fail before anything is written.

use std::process::Command;

fn multistep(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_multistep"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn emit_writes_the_library_and_both_tops() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rtl");
    let o = multistep(&["hdl", "emit", "--axes", "3", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "ms_core.v",
        "ms_calc.v",
        "ms_fifo.v",
        "ms_pulse.v",
        "ms_tdm_top.v",
        "ms_indep_top.v",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let top = std::fs::read_to_string(out.join("ms_tdm_top.v")).unwrap();
    assert!(top.contains(".K(3)") && top.contains("K = 3 axes"), "{top}");
    let ind = std::fs::read_to_string(out.join("ms_indep_top.v")).unwrap();
    assert_eq!(ind.matches("ms_core #(").count(), 3);
}

#[test]
fn bad_parameters_fail_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let o = out.to_str().unwrap();
    for (args, msg) in [
        (vec!["hdl", "emit", "--axes", "0", "--out", o], "axes"),
        (
            vec![
                "hdl",
                "emit",
                "--axes",
                "2",
                "--fifo-depth",
                "0",
                "--out",
                o,
            ],
            "fifo depth",
        ),
        (
            vec![
                "hdl",
                "emit",
                "--axes",
                "2",
                "--tick-bits",
                "20",
                "--out",
                o,
            ],
            "tick bits 20 too narrow",
        ),
        (
            vec!["hdl", "emit", "--axes", "2", "--clock", "1e5", "--out", o],
            "clock",
        ),
        (vec!["hdl", "report", "--axes", "1,0", "--work", o], "axes"),
    ] {
        let r = multistep(&args);
        assert_eq!(r.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(
            err.starts_with("error:") && err.contains(msg),
            "{args:?}: {err}"
        );
        assert!(!out.exists(), "{args:?} wrote files");
    }
}

#[test]
fn boards_lists_every_board() {
    let o = multistep(&["hdl", "boards"]);
    assert!(o.status.success());
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("ulx3s-25f") && text.contains("LFE5U-25F-6BG381C"),
        "{text}"
    );
    assert!(
        text.contains("icebreaker") && text.contains("iCE40UP5K-SG48"),
        "{text}"
    );
}

#[test]
fn build_refuses_bad_boards_and_axes_before_writing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let o = out.to_str().unwrap();
    for (args, msg) in [
        (
            vec!["hdl", "build", "--board", "nope", "--out", o],
            "unknown board \"nope\"",
        ),
        (
            vec![
                "hdl",
                "build",
                "--board",
                "icebreaker",
                "--axes",
                "5",
                "--out",
                o,
            ],
            "1..=4 axes, got 5",
        ),
        (
            vec![
                "hdl",
                "build",
                "--board",
                "ulx3s-25f",
                "--axes",
                "0",
                "--out",
                o,
            ],
            "got 0",
        ),
        (
            vec!["hdl", "report", "--axes", "2", "--pnr", "--work", o],
            "iCE40 or ECP5",
        ),
        (
            vec!["hdl", "modules", "--board", "nope", "--out", o],
            "unknown board \"nope\"",
        ),
        (
            vec![
                "hdl",
                "modules",
                "--board",
                "icebreaker",
                "--axes",
                "5",
                "--out",
                o,
            ],
            "1..=4 axes, got 5",
        ),
    ] {
        let r = multistep(&args);
        assert_eq!(r.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(
            err.starts_with("error:") && err.contains(msg) && err.lines().count() == 1,
            "{args:?}: {err}"
        );
        assert!(!out.exists(), "{args:?} wrote files");
    }
}

#[test]
fn build_with_a_missing_native_nextpnr_fails_before_synthesis() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("build");
    let exe = dir.path().join("nextpnr-ecp5");
    let o = multistep(&[
        "hdl",
        "build",
        "--board",
        "ulx3s-85f",
        "--out",
        out.to_str().unwrap(),
        "--nextpnr",
        exe.to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains(&format!("{}: no such executable", exe.display())),
        "{err}"
    );
    assert!(!out.join("yosys.log").exists());
}

/// `hdl modules` of one iCEBreaker axis: every module of the board with its instances,
/// the per-axis modules once each, and the sums.
#[test]
fn modules_lists_where_the_logic_goes() {
    let o = multistep(&[
        "hdl",
        "modules",
        "--board",
        "icebreaker",
        "--axes",
        "1",
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let t: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let rows = t["rows"].as_array().unwrap();
    assert_eq!(rows[0]["module"], "ms_icebreaker_top");
    let row = |m: &str| {
        rows.iter()
            .find(|r| r["module"] == m)
            .unwrap_or_else(|| panic!("no {m}"))
    };
    for (m, n) in [
        ("ms_pulse", 1),
        ("ms_fifo", 1),
        ("ms_axis_io", 1),
        // the Hall filter only: the iCEBreaker has no limit inputs
        ("ms_debounce", 1),
        ("ms_calc", 1),
    ] {
        assert_eq!(row(m)["instances"], n, "{m}");
        assert!(row(m)["each"]["lut"].as_u64().unwrap() > 0, "{m}");
    }
    let table = multistep(&["hdl", "modules", "--board", "icebreaker", "--axes", "1"]);
    let text = String::from_utf8_lossy(&table.stdout);
    assert!(
        text.contains("whole board") && text.contains("ms_pulse"),
        "{text}"
    );
}
