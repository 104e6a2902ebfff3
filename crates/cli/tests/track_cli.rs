//! `multistep plan --track`: the printed edges are the core tracker's, a cruise's edges are
//! the exact nearest ticks, and bad input is one `error:` line with exit status 2.

use multistep_core::{Rate, TrackLimits, Tracker};
use std::process::{Command, Output};

fn plan(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_multistep"))
        .arg("plan")
        .args(args)
        .output()
        .expect("run multistep")
}

fn csv_rows(out: &Output) -> Vec<(u64, u64, u64)> {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
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
fn cruise_edges_are_the_exact_nearest_ticks() {
    // already at the rate: step k at k·f/R = k·5e7·10/319999 ticks, ties to the earlier tick
    let out = plan(&[
        "--track",
        "31999.9",
        "--start-speed",
        "31999.9",
        "--duration",
        "2",
        "--format",
        "csv",
    ]);
    let rows = csv_rows(&out);
    assert_eq!(rows.len(), 63_999);
    let mut last = 0;
    for (k, &(step, edge, period)) in rows.iter().enumerate() {
        let k = k as u128 + 1;
        // ⌈(2k·f·10 − 319999)/(2·319999)⌉
        let want = (2 * k * 500_000_000 - 319_999).div_ceil(2 * 319_999) as u64;
        assert_eq!((step, edge, period), (k as u64, want, want - last));
        last = want;
    }
    assert!(last <= 100_000_000);
}

#[test]
fn ramp_then_cruise_is_the_core_tracker() {
    let out = plan(&[
        "--track",
        "15041/324",
        "--amax",
        "20",
        "--start-speed",
        "3",
        "--duration",
        "120",
        "--clock",
        "1000000",
        "--format",
        "csv",
    ]);
    let rows = csv_rows(&out);
    let limits = TrackLimits {
        amax: 20.0,
        jmax: None,
    };
    let tr = Tracker::new(1e6, limits, 3.0, Rate::new(15041, 324).unwrap()).unwrap();
    let want: Vec<u64> = tr.take_while(|&e| e <= 120_000_000).collect();
    assert_eq!(rows.iter().map(|r| r.1).collect::<Vec<_>>(), want);
    assert!(want.len() > 5_000);
}

#[test]
fn json_summary() {
    let out = plan(&[
        "--track",
        "100",
        "--amax",
        "1000",
        "--duration",
        "10",
        "--format",
        "json",
    ]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["rate_exact"], "100/1");
    // 0 → 100 steps/s at 1000 steps/s² loses 0.05 s: 995 steps by 10 s
    assert_eq!(v["steps"], 995);
    assert_eq!(v["min_cruise_period_ticks"], 500_000);
    assert_eq!(v["max_cruise_period_ticks"], 500_000);
}

#[test]
fn bad_input_is_one_error_line() {
    for args in [
        &["--track", "abc", "--duration", "1"][..],
        &["--track", "46", "--duration", "1"],
        &["--track", "46", "--duration", "-1", "--amax", "5"],
        &[
            "--track",
            "46",
            "--duration",
            "1",
            "--amax",
            "5",
            "--steps",
            "3",
        ],
        &["--track", "46", "--amax", "5"],
        &["--track", "4e7", "--duration", "1", "--amax", "5"],
        &[
            "--duration",
            "1",
            "--steps",
            "5",
            "--vmax",
            "5",
            "--amax",
            "5",
        ],
    ] {
        let out = plan(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8(out.stderr).unwrap();
        // one line from the planner; clap's own refusals add its usage and hint
        assert!(
            err.starts_with("error:") && (err.lines().count() == 1 || err.contains("\nUsage: ")),
            "{args:?}: {err}"
        );
    }
}

/// The simulated board's edges while tracking are exactly `plan --track`'s: its count
/// steps up on every printed edge tick and at no other tick.
#[test]
fn the_boards_tracking_edges_are_plan_tracks_edges() {
    use multistep_controller::config::{AxisConfig, BoardConfig, BoardSection};
    use multistep_controller::protocol::{RateArg, SignedRate, TrackOpts};
    use multistep_controller::store::Store;
    use multistep_controller::{AxisSettings, Board};
    for (rate, amax, seconds) in [("15041/324", "200", "30"), ("31999.9", "64000", "2")] {
        let out = plan(&[
            "--track",
            rate,
            "--amax",
            amax,
            "--duration",
            seconds,
            "--clock",
            "1e6",
            "--format",
            "csv",
        ]);
        let edges: Vec<u64> = csv_rows(&out).iter().map(|r| r.1).collect();
        assert!(edges.len() > 1000, "{rate}: {} edges", edges.len());
        let dir = tempfile::tempdir().unwrap();
        let config = BoardConfig {
            board: BoardSection {
                name: "b".into(),
                clock_hz: 1e6,
                fifo_depth: 4,
                link: None,
                sync_line: None,
            },
            axes: vec![AxisConfig {
                name: "X".into(),
                settings: AxisSettings {
                    vmax: 40_000.0,
                    amax: amax.parse().unwrap(),
                    ..AxisSettings::default()
                },
            }],
            alpaca: None,
        };
        let mut b = Board::open(&config, Store::open(dir.path()).unwrap()).unwrap();
        let r = RateArg::Value(SignedRate::parse(rate).unwrap().unwrap());
        b.track("X", &r, &TrackOpts::default(), None, 0).unwrap();
        let pos = |b: &mut Board, t: u64| b.status(&[], t).unwrap()[0].position;
        for (k, &e) in edges.iter().enumerate() {
            if e > 0 {
                assert_eq!(pos(&mut b, e - 1), k as i64, "{rate}: before edge {k}");
            }
            assert_eq!(
                pos(&mut b, e),
                k as i64 + 1,
                "{rate}: on edge {k} at tick {e}"
            );
        }
    }
}
