//! `multistep demo`: seed 000's two-axis run through the TDM engine into simulated motors.

use std::process::Command;

#[test]
fn demo_runs_seed000_without_faults_and_writes_plots() {
    let dir = std::env::temp_dir().join(format!("multistep-demo-{}", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_multistep"))
        .args(["demo", "--format", "json", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["start_skew_ticks"], 0);
    let axes = v["axes"].as_array().unwrap();
    assert_eq!(axes.len(), 2);
    for (a, steps) in axes.iter().zip([2400, 1800]) {
        assert_eq!(a["steps"], steps);
        assert_eq!(a["underruns"], 0);
        assert_eq!(a["lost_steps"], 0);
        // 50 ms move at 50 MHz, both axes ending on the same tick
        assert!((a["duration_s"].as_f64().unwrap() - 0.05).abs() < 1e-9);
        // seed 000 measured a following error within ±8 microsteps
        let e = a["peak_following_error_steps"].as_f64().unwrap();
        assert!(e > 0.5 && e <= 8.0, "{e}");
        let plot = std::fs::read_to_string(a["plot"].as_str().unwrap()).unwrap();
        assert!(plot.starts_with("<svg"));
    }
    std::fs::remove_dir_all(&dir).ok();
}
