//! `multistep tdm` end to end on the example configs.

use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;

fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name)
}

fn multistep(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_multistep"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

fn tdm_json(config: &str, extra: &[&str]) -> Value {
    let path = example(config);
    let mut args = vec![
        "tdm",
        "--config",
        path.to_str().unwrap(),
        "--format",
        "json",
    ];
    args.extend_from_slice(extra);
    let (ok, out, err) = multistep(&args);
    assert!(ok, "{err}");
    serde_json::from_str(&out).unwrap()
}

#[test]
fn seed000_example_runs_clean_and_its_edges_are_the_plans() {
    let dir = std::env::temp_dir().join(format!("multistep-tdm-test-{}", std::process::id()));
    let v = tdm_json(
        "seed000-two-axis.toml",
        &["--edges-dir", dir.to_str().unwrap()],
    );
    assert_eq!(v["underruns"], 0);
    assert_eq!(v["start_skew_ticks"], 0);
    assert!(v["min_slack_ticks"].as_i64().unwrap() > 0);
    let u = v["calculator_utilization"].as_f64().unwrap();
    assert!(u > 0.0 && u < 1.0);
    let axes = v["axes"].as_array().unwrap();
    assert_eq!(axes.len(), 2);
    for (m, steps) in [(0, "2400"), (1, "1800")] {
        assert_eq!(axes[m]["steps"].as_u64().unwrap().to_string(), steps);
        assert_eq!(axes[m]["underruns"], 0);
        let cmd = format!("plan --steps {steps} --accel-time 0.02 --cruise-time 0.01 --decel-time 0.02 --format csv");
        let args: Vec<&str> = cmd.split_whitespace().collect();
        let (ok, plan, _) = multistep(&args);
        assert!(ok);
        let got = std::fs::read_to_string(dir.join(format!("axis{m}.csv"))).unwrap();
        assert!(
            got == plan,
            "axis {m}: TDM edges differ from multistep plan"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn telescope_example_serves_17_axes() {
    let v = tdm_json("telescope-17-axis.toml", &[]);
    assert_eq!(v["axes"].as_array().unwrap().len(), 17);
    assert_eq!(v["underruns"], 0);
    assert_eq!(v["start_skew_ticks"], 0);
    assert!(v["start_tick"].as_u64().unwrap() >= 500, "DIR setup time");
}

#[test]
fn stress_example_underruns_with_round_robin_and_not_with_earliest_deadline() {
    let rr = tdm_json("stress.toml", &["--policy", "round-robin"]);
    assert!(rr["underruns"].as_u64().unwrap() > 0);
    assert!(rr["min_slack_ticks"].as_i64().unwrap() < 0);
    let per_axis: u64 = rr["axes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["underruns"].as_u64().unwrap())
        .sum();
    assert_eq!(per_axis, rr["underruns"].as_u64().unwrap());
    let edf = tdm_json("stress.toml", &["--policy", "earliest-deadline"]);
    assert_eq!(edf["underruns"], 0);
    assert!(
        edf["k_eq12"].as_u64().unwrap() < 19,
        "more axes than eq. (12) promises"
    );
}

#[test]
fn sweep_prints_k_max_and_writes_an_svg() {
    let svg = std::env::temp_dir().join(format!("multistep-sweep-{}.svg", std::process::id()));
    let (ok, out, err) = multistep(&[
        "tdm",
        "--sweep",
        "--rates",
        "120000:140000:2",
        "--max-axes",
        "16",
        "--fifo-depths",
        "1,4",
        "--format",
        "json",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(ok, "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[1]["k_eq12"], 357 / 51);
    // identical cruising moves started together: eq. (12) is exact with 4 slots. With one,
    // the scheduler sees the slot a rise frees a tick later: k·51 ≤ Δt_min − 1, one axis
    // short where Δt_min is a multiple of 51 (357 at 140 k), not at 416 (120 k)
    for (r, short) in rows.iter().zip([0, 1]) {
        for s in r["series"].as_array().unwrap() {
            let eq12 = r["k_eq12"].as_u64().unwrap();
            let want = if s["fifo_depth"] == 1 {
                eq12 - short
            } else {
                eq12
            };
            assert_eq!(s["k_max"], want, "{r}");
        }
    }
    let text = std::fs::read_to_string(&svg).unwrap();
    std::fs::remove_file(&svg).ok();
    assert!(text.starts_with("<svg") && text.contains("seed 000 eq. (12)"));
    // both policies draw the same line as eq. (12) with 4 slots: the legend says so
    for name in ["round-robin D=4", "earliest-deadline D=4"] {
        assert!(
            text.contains(&format!("{name} (same as eq. (12))")),
            "{name}: {text}"
        );
    }
    assert!(
        text.contains("earliest-deadline D=1 (same as round-robin D=1)"),
        "{text}"
    );
    assert!(
        !text.contains(".0\n</text>"),
        "a tick label with \".0\": {text}"
    );
}

#[test]
fn bad_input_is_one_clear_error() {
    let (ok, _, err) = multistep(&["tdm"]);
    assert!(!ok && err.contains("--config"), "{err}");
    let bad = std::env::temp_dir().join(format!("multistep-bad-{}.toml", std::process::id()));
    std::fs::write(
        &bad,
        "fifo_depth = 0\n[[axis]]\nsteps = 10\naccel_time = 0.1\n",
    )
    .unwrap();
    let (ok, _, err) = multistep(&["tdm", "--config", bad.to_str().unwrap()]);
    assert!(!ok && err.contains("fifo_depth"), "{err}");
    std::fs::remove_file(&bad).ok();
}

#[test]
fn k_max_of_a_config_against_eq12() {
    // seed 000's two moves alternating over k axes: eq. (12) from the 625-tick cruise
    let v = tdm_json("seed000-two-axis.toml", &["--k-max", "--max-axes", "16"]);
    assert_eq!(v["k_eq12"], 625 / 50);
    assert_eq!(v["k_max"], v["k_eq12"]);
    assert!(v["first_failure_underruns"].as_u64().unwrap() > 0);
    // mixed rates: round-robin at depth 1 holds at least eq. (12) (its guarantee for any
    // phases), below the load bound
    let rr = tdm_json("stress.toml", &["--k-max", "--policy", "round-robin"]);
    assert!(rr["k_max"].as_u64().unwrap() >= rr["k_eq12"].as_u64().unwrap());
    assert!(rr["k_load"].as_u64().unwrap() > rr["k_max"].as_u64().unwrap());
}

/// Writes `text` as a config, runs `tdm` on it with `extra`, and returns the error.
fn config_error(name: &str, text: &str, extra: &[&str]) -> String {
    let path = std::env::temp_dir().join(format!("multistep-{name}-{}.toml", std::process::id()));
    std::fs::write(&path, text).unwrap();
    let mut args = vec!["tdm", "--config", path.to_str().unwrap()];
    args.extend_from_slice(extra);
    let (ok, out, err) = multistep(&args);
    std::fs::remove_file(&path).ok();
    // a failure, no report, one `error:` line
    assert_eq!(
        (ok, out.as_str(), err.lines().count()),
        (false, "", 1),
        "{err}"
    );
    assert!(err.starts_with("error: "), "{err}");
    err
}

#[test]
fn board_keys_out_of_range_are_named() {
    let axis = "[[axis]]\nsteps = 100\nvmax = 10\namax = 10\n";
    let err = config_error("clock", &format!("clock = 0.5\n{axis}"), &[]);
    assert!(
        err.contains("axis 0") && err.contains("faster than one step per tick of the 0.5 Hz clock"),
        "{err}"
    );
    let err = config_error("negclock", &format!("clock = -1\n{axis}"), &[]);
    assert!(err.contains("clock = -1 must be"), "{err}");
    for key in ["pulse_width_ticks", "dir_setup_ticks"] {
        let err = config_error(key, &format!("{key} = 9223372036854775807\n{axis}"), &[]);
        assert!(
            err.contains(key) && err.contains("at most 50000000 ticks"),
            "{err}"
        );
    }
    let err = config_error(
        "zerocycles",
        &format!("mul_cycles = 0\ndiv_cycles = 0\nsqrt_cycles = 0\noverhead_cycles = 0\n{axis}"),
        &[],
    );
    assert!(err.contains("at least one cycle"), "{err}");
}

#[test]
fn runs_past_the_edge_limit_are_refused_at_once() {
    let big = "[[axis]]\nsteps = 100000000000\nvmax = 1000000\namax = 1000000\n";
    let err = config_error("big", big, &[]);
    assert!(
        err.contains("100000000000 step edges") && err.contains("5000000000 allowed"),
        "{err}"
    );
    // k-max runs 1…64 axes: 64·65/2 = 2080 runs of the move's 3 000 000 steps
    let mid = "[[axis]]\nsteps = 3000000\nvmax = 1000000\namax = 1000000\n";
    let err = config_error("kmax", mid, &["--k-max"]);
    assert!(
        err.contains("6240000000 step edges") && err.contains("--max-axes"),
        "{err}"
    );
    let (ok, _, err) = multistep(&["tdm", "--sweep", "--move-times", "100:100:100"]);
    assert!(
        !ok && err.contains("allowed") && err.contains("--move-times"),
        "{err}"
    );
}
