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
        plot_speaks_microsteps(&plot, e);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The text elements of an SVG, trimmed, each with whether it is a y-axis tick label (the
/// only right-aligned text).
fn svg_texts(svg: &str) -> Vec<(bool, String)> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let open = t.find('>')?;
            let y_tick = t[..open].contains("text-anchor=\"end\"");
            Some((y_tick, t[open + 1..t.find("</text>")?].trim().to_string()))
        })
        .collect()
}

/// The plot gives the following error in microsteps, as the table does: its axis says so and
/// its ticks reach the table's peak; tick labels are "9000", not "9000.0", and never "-0".
fn plot_speaks_microsteps(svg: &str, peak_steps: f64) {
    let texts = svg_texts(svg);
    let label = texts
        .iter()
        .position(|(_, t)| t == "following error θ* − θ (microsteps)")
        .unwrap_or_else(|| panic!("{texts:?}"));
    assert!(!texts
        .iter()
        .any(|(_, t)| t.contains("(°)") && t.contains("error")));
    for (_, t) in &texts {
        assert!(!t.ends_with(".0"), "tick {t:?} in {texts:?}");
        if t.parse::<f64>() == Ok(0.0) {
            assert_eq!(t, "0", "{texts:?}");
        }
    }
    // the error panel's ticks reach the table's peak (in degrees they would stay below 1)
    let error_ticks: Vec<f64> = texts[label..]
        .iter()
        .filter(|(y_tick, _)| *y_tick)
        .map(|(_, t)| t.parse().unwrap())
        .collect();
    let top = error_ticks.iter().cloned().fold(f64::MIN, f64::max);
    assert!(
        error_ticks.len() >= 3 && top >= 0.8 * peak_steps && top <= 1.5 * peak_steps + 1.0,
        "{error_ticks:?}, peak {peak_steps}"
    );
}
