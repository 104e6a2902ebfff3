//! `multistep simulate` and `multistep experiment two-axis` through the binary: flags, JSON
//! shape and errors.

use std::process::Command;

fn multistep(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_multistep"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

const MOVE: [&str; 8] = [
    "--steps",
    "3200",
    "--accel-time",
    "0.05",
    "--cruise-time",
    "0.05",
    "--decel-time",
    "0.05",
];

#[test]
fn simulate_json_has_the_contract_fields() {
    let mut args = vec!["simulate", "--motor", "42mm", "--format", "json"];
    args.extend(MOVE);
    let (code, out, err) = multistep(&args);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["steps"], 3200);
    assert_eq!(v["lost_steps"], 0);
    assert!(v["peak_following_error_deg"].as_f64().unwrap() > 0.0);
    assert!(v["final_error_deg"].as_f64().unwrap().abs() < 0.5);
    assert!(v["damping_ratio"].as_f64().unwrap() > 0.0);
}

#[test]
fn simulate_writes_trace_and_plots() {
    let dir = std::env::temp_dir().join(format!("multistep-sim-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (csv, svg, png) = (dir.join("t.csv"), dir.join("p.svg"), dir.join("p.png"));
    let mut args = vec![
        "simulate",
        "--motor",
        "20mm",
        "--profile",
        "parabolic",
        "--reverse",
        "--mode",
        "ideal",
        "--trace",
        csv.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ];
    args.extend(MOVE);
    let (code, out, err) = multistep(&args);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("lost steps"), "{out}");
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("t_s,commanded_deg,actual_deg"));
    assert!(text.lines().count() > 1000);
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.starts_with("<svg"));
    // the title names the driver as --mode and the table do
    assert!(plot.contains("20mm, 16 microsteps, ideal driver"), "{plot}");
    args[11] = png.to_str().unwrap();
    let (code, _, err) = multistep(&args);
    assert_eq!(code, 0, "{err}");
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn simulate_plot_title_names_the_rl_driver() {
    let svg = std::env::temp_dir().join(format!("multistep-sim-rl-{}.svg", std::process::id()));
    let mut args = vec![
        "simulate",
        "--motor",
        "42mm",
        "--plot",
        svg.to_str().unwrap(),
    ];
    args.extend(MOVE);
    let (code, out, err) = multistep(&args);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("(rl driver,"), "{out}");
    let plot = std::fs::read_to_string(&svg).unwrap();
    std::fs::remove_file(&svg).ok();
    assert!(plot.contains("on 42mm, 16 microsteps, rl driver"), "{plot}");
    assert!(!plot.contains("Rl driver"));
}

#[test]
fn simulate_errors_name_the_problem() {
    let mut args = vec!["simulate", "--motor", "nosuch"];
    args.extend(MOVE);
    let (code, _, err) = multistep(&args);
    assert_eq!(code, 2);
    assert!(err.starts_with("error:") && err.contains("57mm"), "{err}");
    let mut args = vec!["simulate", "--motor", "57mm", "--dt", "1e-3"];
    args.extend(MOVE);
    let (code, _, err) = multistep(&args);
    assert_eq!(code, 2);
    assert!(
        err.contains("unstable") && err.contains("current loop"),
        "{err}"
    );
    let dir = std::env::temp_dir().join(format!("multistep-badmotor-{}.toml", std::process::id()));
    std::fs::write(&dir, "name = \"x\"\nholding_torque = 1\nrated_current = 1\nresistance = 1\ninductance = 0\nrotor_inertia = 1e-5\n").unwrap();
    let mut args = vec!["simulate", "--motor", dir.to_str().unwrap()];
    args.extend(MOVE);
    let (code, _, err) = multistep(&args);
    std::fs::remove_file(&dir).ok();
    assert_eq!(code, 2);
    assert!(err.contains("`inductance`"), "{err}");
}

#[test]
fn two_axis_json_has_axes() {
    let (code, out, err) = multistep(&["experiment", "two-axis", "--format", "json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let axes = v["axes"].as_array().unwrap();
    assert_eq!(axes.len(), 2);
    for (ax, n) in axes.iter().zip([2400, 1800]) {
        assert_eq!(ax["steps"], n);
        assert_eq!(ax["lost_steps"], 0);
        assert!(ax["peak_following_error_steps"].as_f64().unwrap() <= 8.0);
    }
}

/// One `error:` line, exit 2, no report on stdout.
fn refused(args: &[&str]) -> String {
    let (code, out, err) = multistep(args);
    assert_eq!(code, 2, "{args:?}: {out}{err}");
    assert!(out.is_empty(), "{args:?}: {out}");
    assert!(
        err.starts_with("error: ") && err.trim_end().lines().count() == 1,
        "{err}"
    );
    err
}

#[test]
fn simulate_refuses_nonsense_physics_and_divergence() {
    let mv = ["--steps", "1000", "--vmax", "1000", "--amax", "10000"];
    let with = |extra: &[&'static str]| {
        let mut a = vec!["simulate", "--motor", "42mm"];
        a.extend(mv);
        a.extend(extra);
        a
    };
    for t in ["1e308", "1e200", "6"] {
        let err = refused(&with(&["--load-torque", t]));
        assert!(
            err.contains("`load_torque`") && err.contains("10 × holding_torque"),
            "{err}"
        );
        assert!(err.len() < 200, "{err}");
    }
    let err = refused(&with(&["--supply", "1e308"]));
    assert!(
        err.contains("`supply` = 1e308") && err.contains("1000 V"),
        "{err}"
    );
    // no damping against a load far above the holding torque: the rotor runs away
    let err = refused(&with(&["--load-torque", "5", "--damping-ratio", "0"]));
    assert!(err.contains("diverged at t = "), "{err}");
    // within the bounds a stall is a result: steps lost, finite error
    let (code, out, err) = multistep(&with(&["--load-torque", "1", "--format", "json"]));
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["lost"], true);
    assert!(v["final_error_deg"].as_f64().unwrap().is_finite());
}

#[test]
fn simulate_refuses_unbounded_work_at_once() {
    // the errors name the work bound, checked before anything runs
    let err = refused(&[
        "simulate", "--motor", "42mm", "--steps", "1000", "--vmax", "1000", "--amax", "10000",
        "--dt", "1e-300",
    ]);
    assert!(
        err.contains("`dt`") && err.contains("at least 1e-9 s"),
        "{err}"
    );
    for mv in [
        ["--steps", "1000", "--vmax", "1e-3", "--amax", "1e-3"],
        ["--steps", "100000000", "--vmax", "1000", "--amax", "10000"],
    ] {
        let mut a = vec!["simulate", "--motor", "42mm"];
        a.extend(mv);
        let err = refused(&a);
        assert!(
            err.contains("RK4 steps") && err.contains("5e8 allowed") && err.contains("larger dt"),
            "{err}"
        );
    }
}
