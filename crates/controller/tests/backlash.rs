//! Backlash compensation per axis: a move that reverses turns the motor |d| + backlash
//! steps in one profile, the load (the reported position) ends exactly at the target, and
//! the slack's side survives a restart. Virtual time on the simulated backend: the
//! simulated mechanics are the motor, so `sim_position − position` is the slack.

use multistep_controller::protocol::{Amount, MoveOpts};
use multistep_controller::store::Store;
use multistep_controller::{AxisStatus, Board, BoardConfig, CtlError};
use multistep_core::EdgeGenerator;
use proptest::prelude::*;

const BACKLASH: i64 = 700;

/// A focuser (soft limits), a rotator (periodic) and a mount axis (fast, big numbers).
const CONFIG: &str = r#"
[board]
name = "b"
clock_hz = 1e6

[[axis]]
name = "F"
vmax = 4000.0
amax = 20000.0
soft_min = 0
soft_max = 1000000
backlash = 700

[[axis]]
name = "R"
vmax = 3000.0
amax = 15000.0
period = 57600
backlash = 700

[[axis]]
name = "M"
vmax = 19000.0
amax = 50000.0
jmax = 400000.0
backlash = 700
"#;

fn open(dir: &std::path::Path) -> Board {
    let config = BoardConfig::parse(CONFIG).unwrap();
    Board::open(&config, Store::open(dir).unwrap()).unwrap()
}

/// A board on a store of its own (kept as long as the directory).
fn fresh() -> (tempfile::TempDir, Board) {
    let dir = tempfile::tempdir().unwrap();
    let b = open(dir.path());
    (dir, b)
}

fn status(b: &mut Board, axis: &str, now: u64) -> AxisStatus {
    b.status(&[axis.to_string()], now).unwrap().remove(0)
}

/// Advances until the axis rests; returns its status and the tick.
fn settle(b: &mut Board, axis: &str, mut now: u64) -> (AxisStatus, u64) {
    loop {
        let s = status(b, axis, now);
        if s.target.is_none() {
            return (s, now);
        }
        now = s.move_end.unwrap_or(now).max(now + 1);
    }
}

fn motor(s: &AxisStatus) -> i64 {
    s.sim_position
}

/// One move of `d` load steps, checked: the motor makes |d| plus what slack is left to
/// take up that way, as one profile whose every edge is within the axis's limits, and
/// the load ends on the target.
fn check_move(b: &mut Board, axis: &str, d: i64, now: u64) -> u64 {
    let before = status(b, axis, now);
    let take_up = match d.signum() {
        1 => BACKLASH - before.slack,
        -1 => before.slack,
        _ => 0,
    };
    let steps = d.unsigned_abs() as i64 + take_up;
    let plan = b
        .preview(
            &[(axis.to_string(), Amount::Steps(d))],
            false,
            false,
            &MoveOpts::default(),
        )
        .unwrap()
        .remove(0);
    if d == 0 {
        assert!(plan.profile.is_none());
    } else {
        let p = plan.profile.clone().unwrap();
        assert_eq!(
            p.steps() as i64,
            steps,
            "{axis} {d}: one profile of |d| + take-up"
        );
        let s = b.settings(axis).unwrap().clone();
        let clock = b.clock_hz();
        let tol = 1.0 + 1e-9;
        let mut edges = 0;
        for tick in EdgeGenerator::new(p.clone(), clock).unwrap() {
            let t = tick as f64 / clock;
            let (v, a) = (p.velocity(t), p.acceleration(t));
            assert!(v >= 0.0 && v <= s.vmax * tol, "{axis} {d}: v {v} at {t}");
            assert!(a.abs() <= s.amax * tol, "{axis} {d}: a {a} at {t}");
            edges += 1;
        }
        assert_eq!(edges, steps);
        assert!(p.velocity(0.0).abs() < 1e-9 && p.velocity(p.duration()).abs() < 1e-6);
    }
    let target = b
        .move_axis(axis, Amount::Steps(d), false, &MoveOpts::default(), now)
        .unwrap();
    let (after, end) = settle(b, axis, now);
    let period = b.settings(axis).unwrap().period.map(|p| p as i64);
    let want = match period {
        Some(p) => (before.position + d).rem_euclid(p),
        None => before.position + d,
    };
    assert_eq!((after.position, target), (want, want), "{axis} {d}");
    let moved = motor(&after) - motor(&before);
    // a periodic axis's numbers wrap; the mechanics count on
    let load_moved = match period {
        Some(p) => d - (d - (after.position - before.position)).rem_euclid(p),
        None => after.position - before.position,
    };
    assert_eq!(load_moved, d);
    assert_eq!(moved, d.signum() * steps, "{axis} {d}: motor steps");
    let slack = match d.signum() {
        1 => BACKLASH,
        -1 => 0,
        _ => before.slack,
    };
    assert_eq!(after.slack, slack);
    assert_eq!(
        motor(&after) - after.position,
        before_offset(&before) + slack
    );
    end
}

/// Motor minus load, less the slack: a constant of the axis (its numbers' origin).
fn before_offset(s: &AxisStatus) -> i64 {
    motor(s) - s.position - s.slack
}

#[test]
fn reversals_end_exactly_on_the_target_on_every_kind_of_axis() {
    let (_dir, mut b) = fresh();
    for axis in ["F", "R", "M"] {
        let mut now = b.now();
        // from a fresh axis (slack 0: taken up backward) forward, on, back, back, forward
        // (less than half the rotator's turn: the short way is the way asked)
        for d in [5000, 3000, -2000, -10, 1, 20_000, -19_999] {
            now = check_move(&mut b, axis, d, now);
        }
    }
    // a rotator's shortest way that crosses the wrap, reversing
    let mut now = b.now();
    now = check_move(&mut b, "R", 57600 / 2 - 1, now);
    check_move(&mut b, "R", -(57600 / 2 - 3), now);
}

#[test]
fn a_group_and_an_absolute_move_take_up_the_slack_too() {
    let (_dir, mut b) = fresh();
    let now = check_move(&mut b, "F", 10_000, 0);
    let s0 = status(&mut b, "M", now);
    let targets = vec![
        ("F".to_string(), Amount::Steps(4000)),
        ("M".to_string(), Amount::Steps(-4000)),
    ];
    assert_eq!(
        b.group_move(&targets, true, true, &MoveOpts::default(), now)
            .unwrap(),
        vec![4000, -4000]
    );
    let (f, now) = settle(&mut b, "F", now);
    let (m, _) = settle(&mut b, "M", now);
    assert_eq!((f.position, f.slack), (4000, 0));
    assert_eq!(motor(&f), 4000);
    assert_eq!((m.position, m.slack), (-4000, 0));
    // M was taken up backward already: exactly 4000 motor steps
    assert_eq!(motor(&m) - motor(&s0), -4000);
}

#[test]
fn the_slack_side_survives_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    {
        let mut b = open(dir.path());
        let now = check_move(&mut b, "F", 2500, 0);
        let s = status(&mut b, "F", now);
        assert_eq!(
            (s.position, s.slack, motor(&s)),
            (2500, BACKLASH, 2500 + BACKLASH)
        );
    }
    let mut b = open(dir.path());
    let s = status(&mut b, "F", 0);
    assert_eq!(
        (s.position, s.slack, motor(&s)),
        (2500, BACKLASH, 2500 + BACKLASH)
    );
    // the next reversal knows it: |d| + backlash motor steps
    let now = check_move(&mut b, "F", -500, 0);
    let s = status(&mut b, "F", now);
    assert_eq!((s.position, s.slack, motor(&s)), (2000, 0, 2000));
}

#[test]
fn a_stop_during_the_take_up_leaves_the_load_where_it_was() {
    let (_dir, mut b) = fresh();
    b.set("F", "backlash", "200000", 0).unwrap();
    // forward: slack goes to 200 000 (the band from a fresh axis is crossed first)
    b.move_axis("F", Amount::Steps(1000), false, &MoveOpts::default(), 0)
        .unwrap();
    let (s, now) = settle(&mut b, "F", 0);
    assert_eq!((s.position, s.slack, motor(&s)), (1000, 200_000, 201_000));
    // back: 200 000 steps of take-up first; stop a second in
    b.move_axis("F", Amount::Steps(-500), false, &MoveOpts::default(), now)
        .unwrap();
    let mid = now + 1_000_000;
    let s = status(&mut b, "F", mid);
    assert!(
        motor(&s) < 201_000 && s.slack > 0 && s.slack < 200_000,
        "{s:?}"
    );
    assert_eq!(s.position, 1000, "no load moves during the take-up");
    b.stop(Some("F"), mid).unwrap();
    let (s, now) = settle(&mut b, "F", mid);
    assert_eq!(s.position, 1000);
    assert_eq!(motor(&s) - s.position, s.slack);
    assert!(s.slack > 0 && s.slack < 200_000);
    // the rest of the band is taken up by the next move that way, and only the rest
    let left = s.slack;
    b.move_axis("F", Amount::Steps(-500), false, &MoveOpts::default(), now)
        .unwrap();
    let (e, _) = settle(&mut b, "F", now);
    assert_eq!((e.position, e.slack), (500, 0));
    assert_eq!(motor(&s) - motor(&e), left + 500);
}

#[test]
fn an_estop_during_a_reversal_keeps_the_load_exact() {
    let (_dir, mut b) = fresh();
    let now = check_move(&mut b, "M", 3000, 0);
    b.move_axis("M", Amount::Steps(-2000), false, &MoveOpts::default(), now)
        .unwrap();
    // early in the move: within the take-up
    let s = status(&mut b, "M", now + 100_000);
    assert!(s.slack < BACKLASH && s.slack > 0, "{s:?}");
    b.estop(now + 100_000);
    let s = status(&mut b, "M", now + 100_000);
    assert_eq!(s.position, 3000);
    assert_eq!(motor(&s) - s.position, s.slack);
}

#[test]
fn backlash_is_a_setting_with_a_range_and_shown_by_get() {
    let (_dir, mut b) = fresh();
    for bad in ["-1", "1000001", "1.5", "x"] {
        let e = b.set("F", "backlash", bad, 0).unwrap_err();
        assert!(matches!(e, CtlError::Setting(_)), "{bad}: {e}");
    }
    let e = b.set("F", "backlash", "1000001", 0).unwrap_err();
    assert!(
        e.to_string().contains("backlash must be in [0, 1000000]"),
        "{e}"
    );
    b.set("F", "backlash", "1000000", 0).unwrap();
    assert_eq!(b.settings("F").unwrap().get("backlash").unwrap(), "1000000");
    assert!(b
        .settings("F")
        .unwrap()
        .list()
        .contains(&"backlash=1000000".to_string()));
    // a board config outside the range is refused
    let bad = CONFIG.replace(
        "backlash = 700\n\n[[axis]]\nname = \"R\"",
        "backlash = 2000000\n\n[[axis]]\nname = \"R\"",
    );
    let e = BoardConfig::parse(&bad).and_then(|c| c.validate().map(|_| c));
    assert!(e.is_err());
}

#[test]
fn changing_the_backlash_keeps_the_load_and_the_side() {
    let (_dir, mut b) = fresh();
    let now = check_move(&mut b, "F", 4000, 0);
    b.set("F", "backlash", "900", now).unwrap();
    let s = status(&mut b, "F", now);
    // the same side: all of the new band; the load keeps its number, the motor's count
    // (and so the simulation's) is renamed
    assert_eq!((s.position, s.slack, motor(&s)), (4000, 900, 4900));
    b.set("F", "backlash", "0", now).unwrap();
    let s = status(&mut b, "F", now);
    assert_eq!((s.position, s.slack), (4000, 0));
}

#[test]
fn homing_takes_its_edge_with_the_slack_taken_up_and_the_drift_check_agrees() {
    let (_dir, mut b) = fresh();
    b.set("M", "sim.sensor_at", "-5000", 0).unwrap();
    b.home("M", 0).unwrap();
    let (s, now) = settle(&mut b, "M", 0);
    assert!(s.homed && s.trusted, "{s:?}");
    assert_eq!(s.position, 0);
    // home_dir -1: the slack is on the homing direction's side
    assert_eq!(s.slack, 0);
    // out and back over the sensor in the homing direction, reversing each time
    let mut now = check_move(&mut b, "M", 30_000, now);
    now = check_move(&mut b, "M", -40_000, now);
    let s = status(&mut b, "M", now);
    assert_eq!(s.drift, Some(0), "{s:?}");
    assert!(s.trusted);
}

/// A sequence of load moves on a focuser with random backlash: the load is the sum of the
/// moves, the motor the load plus the slack, the slack the side of the last move.
fn run_sequence(backlash: u64, moves: &[i64]) {
    let (_dir, mut b) = fresh();
    b.set("M", "backlash", &backlash.to_string(), 0).unwrap();
    let mut now = 0;
    let (mut load, mut slack) = (0i64, 0i64);
    for &d in moves {
        let before = status(&mut b, "M", now);
        b.move_axis("M", Amount::Steps(d), false, &MoveOpts::default(), now)
            .unwrap();
        let (s, end) = settle(&mut b, "M", now);
        now = end;
        let take_up = match d.signum() {
            1 => backlash as i64 - slack,
            -1 => slack,
            _ => 0,
        };
        load += d;
        slack = match d.signum() {
            1 => backlash as i64,
            -1 => 0,
            _ => slack,
        };
        assert_eq!(s.position, load);
        assert_eq!(s.slack, slack);
        assert_eq!(motor(&s), load + slack);
        assert_eq!((motor(&s) - motor(&before)).abs(), d.abs() + take_up);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn load_is_the_sum_of_the_moves_and_motor_is_load_plus_slack(
        backlash in 0u64..2000,
        moves in proptest::collection::vec(-3000i64..3000, 1..8),
    ) {
        run_sequence(backlash, &moves);
    }
}

#[test]
fn a_tracking_reversal_takes_the_slack_up_in_its_ramp_and_the_load_never_jumps() {
    use multistep_controller::protocol::{RateArg, SignedRate, TrackOpts};
    let (_dir, mut b) = fresh();
    let rate = |r: &str| RateArg::Value(SignedRate::parse(r).unwrap().unwrap());
    let opts = TrackOpts::default();
    // forward at 2000 steps/s: the slack goes to the + side
    b.track("M", &rate("2000"), &opts, None, 0).unwrap();
    let s = status(&mut b, "M", 1_000_000);
    assert_eq!((s.slack, motor(&s) - s.position), (BACKLASH, BACKLASH));
    // the other way: through a stop, then a ramp whose first steps cross the band
    b.track("M", &rate("-2000"), &opts, None, 1_000_000)
        .unwrap();
    let mut now = 1_000_000;
    let mut last = s.position;
    let mut seen_inside = false;
    loop {
        now += 2_000;
        let s = status(&mut b, "M", now);
        // the load moves one way, then the other, and never by more than the motor did
        assert_eq!(motor(&s) - s.position, s.slack, "{s:?}");
        assert!(s.slack >= 0 && s.slack <= BACKLASH);
        if s.slack > 0 && s.slack < BACKLASH {
            // inside the band the load stands still
            assert_eq!(s.position, last, "{s:?}");
            seen_inside = true;
        }
        last = s.position;
        if s.slack == 0 && s.speed < -1999.0 {
            break;
        }
        assert!(now < 10_000_000, "no reversal: {s:?}");
    }
    assert!(seen_inside);
    b.stop(Some("M"), now).unwrap();
    let (s, _) = settle(&mut b, "M", now);
    assert_eq!((s.slack, motor(&s)), (0, s.position));
}
