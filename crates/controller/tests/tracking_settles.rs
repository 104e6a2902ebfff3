//! Rate changes, reversals and stops a few milliseconds apart on the simulated board (in
//! virtual time): the axis always comes to rest within the ramps its limits allow, and
//! takes the next motion.

use multistep_controller::config::{AxisConfig, BoardConfig, BoardSection};
use multistep_controller::protocol::{Amount, MoveOpts, RateArg, SignedRate, TrackOpts};
use multistep_controller::store::Store;
use multistep_controller::{AxisSettings, AxisState, Board};

const CLOCK: u64 = 50_000_000;

fn board(dir: &std::path::Path) -> Board {
    let c = BoardConfig {
        board: BoardSection {
            name: "t".into(),
            clock_hz: CLOCK as f64,
            fifo_depth: 4,
            link: None,
            sync_line: None,
        },
        axes: vec![AxisConfig {
            name: "Z".into(),
            settings: AxisSettings::default(),
        }],
        alpaca: None,
    };
    Board::open(&c, Store::open(dir).unwrap()).unwrap()
}

fn state(b: &mut Board) -> AxisState {
    let now = b.now();
    b.status(&["Z".to_string()], now).unwrap().remove(0).state
}

/// `track Z 2763; track Z -2667; track Z 0; track Z -1832; track Z 1188; stop Z`, the
/// commands 0.5 to 10 ms apart in many patterns: after the stop, Z is idle within the
/// stop from its fastest rate at amax (2763 steps/s at 20000 steps/s²: 0.14 s) and a
/// reversal's restart, not hours later, and a move is taken at once.
#[test]
fn rate_changes_a_few_ms_apart_come_to_rest_promptly() {
    let rates = ["2763", "-2667", "0", "-1832", "1188"];
    // a fixed pseudo-random sequence of gaps, so each run checks the same timings
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut gap = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        CLOCK / 2000 * (1 + seed % 20)
    };
    let mut slowest = 0.0f64;
    for trial in 0..120 {
        let dir = tempfile::tempdir().unwrap();
        let mut b = board(dir.path());
        let mut t = 1_000;
        for r in rates {
            let rate = RateArg::Value(SignedRate::parse(r).unwrap().unwrap());
            b.track("Z", &rate, &TrackOpts::default(), None, t)
                .unwrap_or_else(|e| panic!("trial {trial}: track Z {r}: {e}"));
            t += gap();
        }
        b.stop(Some("Z"), t).unwrap();
        let stopped = t;
        // 2 ms steps until idle, at most 1 s
        while state(&mut b) != AxisState::Idle && t < stopped + CLOCK {
            t += CLOCK / 500;
            b.advance(t);
        }
        let took = (t - stopped) as f64 / CLOCK as f64;
        assert_eq!(
            state(&mut b),
            AxisState::Idle,
            "trial {trial}: still moving {took} s after the stop"
        );
        slowest = slowest.max(took);
        b.move_axis("Z", Amount::Steps(10), false, &MoveOpts::default(), t)
            .unwrap_or_else(|e| panic!("trial {trial}: a move after the stop: {e}"));
    }
    // the stop from 2763 steps/s takes 0.14 s; a reversal's restart and stop as much again
    assert!(slowest <= 0.35, "slowest rest {slowest} s after the stop");
}

/// A rate asked for once the stream has come to rest (nothing left to give: a board's
/// stream may be closed by then) starts a new stream the same way when this one ends.
#[test]
fn a_rate_asked_for_at_rest_starts_a_new_stream_the_same_way() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = board(dir.path());
    let track = |b: &mut Board, r: &str, t: u64| {
        let rate = RateArg::Value(SignedRate::parse(r).unwrap().unwrap());
        b.track("Z", &rate, &TrackOpts::default(), None, t).unwrap()
    };
    // stopped before its first step: the tracker is at rest at once
    track(&mut b, "-500", 1_000);
    track(&mut b, "0", 1_000);
    track(&mut b, "-700", 1_000);
    b.advance(CLOCK);
    let now = b.now();
    let s = b.status(&["Z".to_string()], now).unwrap().remove(0);
    assert_eq!((s.state, s.rate), (AxisState::Tracking, Some(-700.0)));
    assert!((s.speed + 700.0).abs() < 1e-9, "{}", s.speed);
    assert!(s.position < -600, "{}", s.position);
}
