//! `multistep bench`: every implementation on every move, in its documented JSON shape.

use std::process::{Command, Output};

fn bench(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_multistep"))
        .arg("bench")
        .args(args)
        .output()
        .expect("run multistep")
}

#[test]
fn quick_json_has_every_impl_and_multistep_is_exact() {
    let out = bench(&["--quick", "--format", "json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let cases = v["cases"].as_array().unwrap();
    let names = [
        "multistep-float",
        "multistep-int",
        "seed000",
        "austin",
        "eiderman",
        "ramp-maker",
    ];
    assert_eq!(cases.len() % names.len(), 0);
    for c in cases {
        let imp = c["impl"].as_str().unwrap();
        assert!(names.contains(&imp), "{imp}");
        assert!(c["move"].is_string());
        assert!(c["edges_per_s"].as_f64().unwrap() > 0.0);
        assert!(c["max_period_error_pct"].as_f64().unwrap() >= 0.0);
        if imp.starts_with("multistep") {
            assert_eq!(c["max_edge_error_ticks"], 0, "{c}");
            assert_eq!(c["drift_ticks"], 0, "{c}");
        } else {
            // the baselines approximate: none of them lands every edge on the nearest tick
            assert!(c["max_edge_error_ticks"].as_u64().unwrap() > 0, "{c}");
        }
    }
}

/// The help lists only the formats bench prints, so csv is a mistyped command line:
/// clap's message, naming the two it takes.
#[test]
fn csv_is_refused_by_the_parser() {
    let out = bench(&["--quick", "--format", "csv"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(err.contains("invalid value 'csv'"), "{err}");
    assert!(err.contains("[possible values: table, json]"), "{err}");
}

/// `--planning --quick`: multistep's native row for every case, with a time; the Python
/// rows (multistep and Ruckig) only where the interpreter named by MULTISTEP_PYTHON
/// (python3 by default) imports both packages, else a note says they were left out.
#[test]
fn planning_quick_has_the_native_rows() {
    let python = std::env::var("MULTISTEP_PYTHON").unwrap_or_else(|_| "python3".into());
    let out = bench(&[
        "--planning",
        "--quick",
        "--format",
        "json",
        "--python",
        &python,
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v["planning"].as_array().unwrap();
    let of = |case: &str, imp: &str| {
        rows.iter()
            .find(|r| r["case"] == case && r["impl"] == imp)
            .cloned()
    };
    let left_out = err.contains("Python rows are left out");
    for case in ["trapezoid-100k", "scurve-100k"] {
        let native = of(case, "multistep (Rust)").expect(case);
        assert!(native["us_per_call"].as_f64().unwrap() > 0.0, "{native}");
        // no --instructions: nothing counted
        assert!(native["instructions"].is_null(), "{native}");
        for imp in ["multistep (Python)", "ruckig (Python)"] {
            let row = of(case, imp);
            if left_out {
                assert!(row.is_none(), "{row:?}");
            } else {
                let row = row.unwrap_or_else(|| panic!("{case} {imp}: {err}"));
                assert!(row["us_per_call"].as_f64().unwrap() > 0.0, "{row}");
            }
        }
    }
    assert_eq!(rows.len(), if left_out { 2 } else { 6 }, "{v}");
}
