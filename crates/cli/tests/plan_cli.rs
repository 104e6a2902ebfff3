//! `multistep plan` as users script it: CSV rows, JSON summary, and errors (exit 2, one line).

use std::process::{Command, Output};

fn plan(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_multistep"))
        .arg("plan")
        .args(args)
        .output()
        .expect("run multistep")
}

const SEED: [&str; 10] = [
    "--profile",
    "trapezoid",
    "--steps",
    "2400",
    "--accel-time",
    "0.02",
    "--cruise-time",
    "0.01",
    "--decel-time",
    "0.02",
];

fn csv_rows(out: &Output) -> Vec<(u64, u64, u64)> {
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("step,edge_tick,period_ticks"));
    lines
        .map(|l| {
            let v: Vec<u64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[0], v[1], v[2])
        })
        .collect()
}

#[test]
fn csv_has_one_row_per_step_and_periods_sum_to_edges() {
    let mut args = SEED.to_vec();
    args.extend(["--format", "csv"]);
    let out = plan(&args);
    assert!(out.status.success());
    let rows = csv_rows(&out);
    assert_eq!(rows.len(), 2400);
    let mut sum = 0;
    for (k, &(step, edge, period)) in rows.iter().enumerate() {
        assert_eq!(step, k as u64 + 1);
        sum += period;
        assert_eq!(sum, edge);
    }
    // 50 ms at 50 MHz
    assert_eq!(rows.last().unwrap().1, 2_500_000);
}

#[test]
fn segments_reproduce_the_phase_trapezoid() {
    let mut args = SEED.to_vec();
    args.extend(["--format", "csv"]);
    let phase = csv_rows(&plan(&args));
    let seg = plan(&[
        "--segment",
        "0:0.02:800",
        "--segment",
        "80000:0.01:800",
        "--segment",
        "80000:0.02:800",
        "--format",
        "csv",
    ]);
    assert!(seg.status.success());
    assert_eq!(csv_rows(&seg), phase);
}

#[test]
fn json_summary_runs_the_whole_generator() {
    let out = plan(&[
        "--profile",
        "scurve4",
        "--steps",
        "5000000",
        "--vmax",
        "200000",
        "--amax",
        "1e6",
        "--jmax",
        "1e8",
        "--smax",
        "1e11",
        "--format",
        "json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["steps"], 5_000_000);
    let dur = v["duration_s"].as_f64().unwrap();
    let last = v["last_edge_tick"].as_u64().unwrap();
    assert_eq!(last, (dur * 50e6).round() as u64);
    assert!(v["peak_speed_steps_per_s"].as_f64().unwrap() <= 200000.0 * (1.0 + 1e-9));
    assert!(v["peak_accel_steps_per_s2"].as_f64().unwrap() <= 1e6 * (1.0 + 1e-9));
    // at 200 k steps/s and 50 MHz the shortest period is 250 ticks
    assert_eq!(v["min_period_ticks"], 250);
}

#[test]
fn every_family_plans_in_phase_mode() {
    for fam in [
        "trapezoid",
        "parabolic",
        "exponential",
        "sine",
        "scurve",
        "scurve4",
    ] {
        let mut args = SEED.to_vec();
        args[1] = fam;
        args.extend([
            "--format",
            "json",
            "--start-speed",
            "1000",
            "--end-speed",
            "500",
        ]);
        let out = plan(&args);
        assert!(out.status.success(), "{fam}");
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["last_edge_tick"], 2_500_000, "{fam}");
    }
}

#[test]
fn bad_input_gets_one_error_line_and_status_2() {
    let cases: Vec<Vec<&str>> = vec![
        vec!["--profile", "cubic", "--steps", "10", "--accel-time", "1"],
        vec!["--steps", "10", "--accel-time", "-1", "--decel-time", "1"],
        vec!["--steps", "10", "--accel-time", "NaN"],
        vec!["--steps", "10", "--cruise-time", "inf"],
        vec!["--steps", "10", "--accel-time", "0", "--cruise-time", "0"],
        vec!["--segment", "1000:0.1:10"],
        vec![
            "--profile",
            "scurve",
            "--steps",
            "10",
            "--vmax",
            "100",
            "--amax",
            "100",
        ],
        vec![
            "--profile",
            "scurve4",
            "--steps",
            "10",
            "--vmax",
            "100",
            "--amax",
            "100",
            "--jmax",
            "5",
        ],
        vec![
            "--profile",
            "sine",
            "--steps",
            "10",
            "--vmax",
            "100",
            "--amax",
            "100",
        ],
        vec![
            "--profile",
            "scurve",
            "--phi",
            "0.7",
            "--steps",
            "10",
            "--accel-time",
            "1",
        ],
        vec![
            "--profile",
            "scurve4",
            "--psi",
            "0",
            "--steps",
            "10",
            "--accel-time",
            "1",
        ],
        vec!["--steps", "10", "--accel-time", "1", "--clock", "0"],
        vec!["--steps", "10", "--accel-time", "1", "--start-speed", "1e6"],
        vec![
            "--steps",
            "10",
            "--accel-time",
            "1",
            "--vmax",
            "5",
            "--amax",
            "5",
        ],
        vec!["--steps", "0", "--accel-time", "1"],
        vec!["--accel-time", "1"],
        vec![
            "--profile",
            "trapezoid",
            "--steps",
            "10",
            "--vmax",
            "-5",
            "--amax",
            "5",
        ],
    ];
    // (errors clap finds keep its hints and usage: tests/cli_errors.rs)
    for args in cases {
        let out = plan(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        assert!(out.stdout.is_empty(), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(err.starts_with("error:"), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    }
}

#[test]
fn a_move_faster_than_the_clock_is_refused() {
    let limits = ["--steps", "1000", "--vmax", "1000", "--amax", "10000"];
    for clock in ["1", "0.001", "999"] {
        let mut args = limits.to_vec();
        args.extend(["--clock", clock]);
        let out = plan(&args);
        assert_eq!(out.status.code(), Some(2), "--clock {clock}");
        assert!(out.stdout.is_empty());
        let err = String::from_utf8(out.stderr).unwrap();
        assert!(
            err.starts_with("error: the move peaks at ")
                && err.contains(&format!(
                    "faster than one step per tick of the {clock} Hz clock"
                ))
                && err.lines().count() == 1,
            "{err}"
        );
    }
    // every edge at tick 0 before: an unbounded peak speed
    let out = plan(&[
        "--steps",
        "5",
        "--accel-time",
        "1e-300",
        "--cruise-time",
        "0",
        "--decel-time",
        "1e-300",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("faster than one step per tick"), "{err}");
    // at one step per tick the edges are still distinct, one tick apart at the peak
    let mut args = limits.to_vec();
    args.extend(["--clock", "1000", "--format", "csv"]);
    let out = plan(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = csv_rows(&out);
    assert_eq!(rows.len(), 1000);
    assert!(rows.iter().all(|&(_, _, period)| period >= 1));
}

/// A subcommand's arguments are built only when it runs; its help still opens with its own
/// line from the command list (not a flattened struct's doc comment), however asked for.
#[test]
fn subcommand_help_keeps_its_own_about() {
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_multistep"))
            .args(args)
            .output()
            .expect("run multistep");
        assert!(out.status.success(), "{args:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let list = run(&["--help"]);
    for (cmd, about) in [
        ("plan", "Plan one move: the exact tick of every step edge"),
        (
            "simulate",
            "Simulate one move on a motor and driver: lost steps",
        ),
        (
            "serve",
            "Run a controller board, simulated or the FPGA board",
        ),
    ] {
        assert!(list.contains(about), "{cmd} in the list");
        for args in [vec![cmd, "--help"], vec!["help", cmd]] {
            let help = run(&args);
            assert!(
                help.starts_with(about),
                "{args:?}: {}",
                help.lines().next().unwrap()
            );
        }
    }
}
