//! The board in virtual time: homing, periodic axes, group moves, stops, recovery, drift.

use multistep_controller::config::{AxisConfig, BoardConfig, BoardSection};
use multistep_controller::protocol::{Amount, MoveOpts};
use multistep_controller::store::Store;
use multistep_controller::{AxisSettings, AxisState, AxisStatus, Board, CtlError, SimSettings};
use multistep_core::MoveParams;

const CLOCK: f64 = 1e6;

fn config(axes: Vec<(&str, AxisSettings)>) -> BoardConfig {
    BoardConfig {
        board: BoardSection {
            name: "t".into(),
            clock_hz: CLOCK,
            fifo_depth: 4,
            link: None,
            sync_line: None,
        },
        axes: axes
            .into_iter()
            .map(|(n, s)| AxisConfig {
                name: n.into(),
                settings: s,
            })
            .collect(),
        alpaca: None,
    }
}

fn open(dir: &std::path::Path, c: &BoardConfig) -> Board {
    Board::open(c, Store::open(dir).unwrap()).unwrap()
}

/// Advances in 1 ms steps until no axis moves; returns the tick reached.
fn run_idle(b: &mut Board) -> u64 {
    let mut t = b.now();
    for _ in 0..10_000_000 {
        if !b.busy() {
            return t;
        }
        t += 1000;
        b.advance(t);
    }
    panic!("board never came to rest");
}

fn st(b: &mut Board, axis: &str) -> AxisStatus {
    let now = b.now();
    b.status(&[axis.to_string()], now).unwrap().remove(0)
}

fn glitchy(seed: u64, sensor_at: i64, home_dir: i8) -> AxisSettings {
    AxisSettings {
        home_dir,
        debounce: 0.002,
        home_speed: 3000.0,
        home_slow_speed: 2000.0, // clamped to 1 step per 2 debounce = 250 steps/s
        home_backoff: 300,
        home_offset: 1000,
        sim: SimSettings {
            sensor_at,
            sensor_width: 600,
            bounce_count: 4,
            bounce_time: 0.0008,
            glitch_rate: 300.0,
            glitch_max: 0.0012,
            glitch_gap: 0.002,
            seed,
        },
        ..AxisSettings::default()
    }
}

#[test]
fn homing_finds_the_edge_within_one_microstep_under_glitches_over_many_seeds() {
    let mut worst = 0;
    for seed in 0..120u64 {
        let dir = tempfile::tempdir().unwrap();
        let home_dir = if seed % 2 == 0 { -1 } else { 1 };
        let sensor_at = (seed as i64 * 7919) % 20_000 - 10_000;
        let c = config(vec![("X", glitchy(seed, sensor_at, home_dir))]);
        let mut b = open(dir.path(), &c);
        // Start on the approach side of the sensor or on it (d ≥ 0 is inside the window).
        let d = ((seed as i64 * 104_729) % 15_600) - 15_000;
        let start = sensor_at + home_dir as i64 * d;
        b.sim_slip("X", start, 0).unwrap();
        b.home("X", 0).unwrap();
        run_idle(&mut b);
        let s = st(&mut b, "X");
        assert_eq!(s.state, AxisState::Idle, "seed {seed}: {:?}", s.fault);
        assert!(s.homed && s.trusted, "seed {seed}");
        assert_eq!(s.position, 1000, "seed {seed}: parks on home_offset");
        // The count now maps the sensor edge to home_offset: the mechanics sit on the edge.
        let err = s.sim_position - sensor_at;
        assert!(
            err.abs() <= 1,
            "seed {seed}: edge found {err} microsteps off"
        );
        worst = worst.max(err.abs());
    }
    eprintln!("worst homing error over 120 seeds: {worst} microsteps");
}

#[test]
fn homing_without_a_sensor_in_reach_faults_and_stays_unhomed() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = glitchy(3, 0, -1);
    s.home_search = 2000;
    let mut b = open(dir.path(), &config(vec![("X", s)]));
    b.sim_slip("X", 50_000, 0).unwrap();
    b.home("X", 0).unwrap();
    run_idle(&mut b);
    let s = st(&mut b, "X");
    assert_eq!(s.state, AxisState::Fault);
    assert!(s.fault.unwrap().contains("not found"));
    assert!(!s.homed);
}

#[test]
fn periodic_axes_take_the_shortest_way() {
    let dir = tempfile::tempdir().unwrap();
    let wp = AxisSettings {
        period: Some(1000),
        ..AxisSettings::default()
    };
    let mut b = open(dir.path(), &config(vec![("W", wp)]));
    let o = MoveOpts::default();
    assert_eq!(
        b.move_axis("W", Amount::Steps(900), true, &o, 0).unwrap(),
        900
    );
    let t = run_idle(&mut b);
    assert_eq!(st(&mut b, "W").position, 900);
    // 900 → 100 is +200 the short way round, not −800.
    let before = st(&mut b, "W").sim_position;
    assert_eq!(
        b.move_axis("W", Amount::Steps(2100), true, &o, t).unwrap(),
        100
    );
    assert_eq!(st(&mut b, "W").target, Some(1100));
    run_idle(&mut b);
    let s = st(&mut b, "W");
    assert_eq!(s.position, 100);
    assert_eq!((s.sim_position - before).rem_euclid(1000), 200);
    // A relative move of 2.4 periods is 0.4 of a period; 0.6 goes back 0.4.
    let t = b.now();
    b.move_axis("W", Amount::Steps(2400), false, &o, t).unwrap();
    assert_eq!(st(&mut b, "W").target, Some(500));
    run_idle(&mut b);
    let t = b.now();
    b.move_axis("W", Amount::Steps(600), false, &o, t).unwrap();
    assert_eq!(st(&mut b, "W").target, Some(100));
    run_idle(&mut b);
    assert_eq!(st(&mut b, "W").position, 100);
}

/// A period set on an idle axis applies at once: its position is read in `[0, period)`,
/// the mechanics stay where they are, and the wrapped position is what a restart finds.
#[test]
fn a_period_set_on_an_idle_axis_wraps_its_position_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(vec![("W", AxisSettings::default())]);
    let mut b = open(dir.path(), &c);
    b.move_axis("W", Amount::Steps(5300), false, &MoveOpts::default(), 0)
        .unwrap();
    let t = run_idle(&mut b);
    let before = st(&mut b, "W");
    assert_eq!(before.position, 5300);
    b.set("W", "period", "1000", t).unwrap();
    let s = st(&mut b, "W");
    assert_eq!(s.position, 300);
    assert_eq!(
        s.sim_position,
        before.sim_position - 5000,
        "the same place, renamed"
    );
    // a bad family is a bad setting value (error:9), not an unplannable move
    let e = b.set("W", "profile", "bogus", t).unwrap_err();
    assert_eq!(e.code(), 9, "{e}");
    drop(b);
    assert_eq!(st(&mut open(dir.path(), &c), "W").position, 300);
}

#[test]
fn group_moves_start_on_one_tick_and_sync_finishes_on_one_tick() {
    let dir = tempfile::tempdir().unwrap();
    let slow = AxisSettings {
        vmax: 1000.0,
        amax: 3000.0,
        ..AxisSettings::default()
    };
    let c = config(vec![
        ("A", AxisSettings::default()),
        ("B", slow),
        ("C", AxisSettings::default()),
    ]);
    let mut b = open(dir.path(), &c);
    let t = vec![
        ("A".to_string(), Amount::Steps(5000)),
        ("B".into(), Amount::Steps(-3000)),
        ("C".into(), Amount::Steps(7)),
    ];
    b.advance(12_345);
    b.group_move(&t, false, true, &MoveOpts::default(), 12_345)
        .unwrap();
    let all = b.status(&[], 12_345).unwrap();
    let starts: Vec<_> = all.iter().map(|s| s.move_start).collect();
    let ends: Vec<_> = all.iter().map(|s| s.move_end).collect();
    // The TDM engine primes every FIFO first; then all three start on one tick.
    assert!(
        starts.iter().all(|&s| s == starts[0] && s > Some(12_345)),
        "{starts:?}"
    );
    assert!(
        ends.iter().all(|&e| e == ends[0] && e > Some(12_345)),
        "{ends:?}"
    );
    run_idle(&mut b);
    let all = b.status(&[], b.now()).unwrap();
    assert_eq!(
        all.iter().map(|s| s.position).collect::<Vec<_>>(),
        vec![5000, -3000, 7]
    );
    // Without sync: same start, each at its own pace.
    let t2 = vec![
        ("A".to_string(), Amount::Steps(0)),
        ("B".into(), Amount::Steps(3000)),
        ("C".into(), Amount::Steps(100)),
    ];
    let now = b.now();
    b.group_move(&t2, true, false, &MoveOpts::default(), now)
        .unwrap();
    let all = b.status(&[], now).unwrap();
    assert!(all
        .iter()
        .all(|s| s.move_start == all[1].move_start && s.move_start >= Some(now)));
    assert_ne!(all[1].move_end, all[2].move_end);
}

#[test]
fn a_controlled_stop_decelerates_at_amax() {
    let dir = tempfile::tempdir().unwrap();
    let s = AxisSettings {
        vmax: 4000.0,
        amax: 10_000.0,
        ..AxisSettings::default()
    };
    let mut b = open(dir.path(), &config(vec![("X", s)]));
    b.move_axis("X", Amount::Steps(100_000), false, &MoveOpts::default(), 0)
        .unwrap();
    // Cruising at 4000 steps/s after 0.4 s of acceleration; stop at 1 s.
    b.advance(1_000_000);
    let at = st(&mut b, "X");
    assert!((at.speed - 4000.0).abs() < 1e-6);
    b.stop(Some("X"), 1_000_000).unwrap();
    run_idle(&mut b);
    let end = st(&mut b, "X");
    // v²/2a = 800 steps of braking, never more.
    assert_eq!(end.position - at.position, 800);
    assert_eq!(end.state, AxisState::Idle);
    assert!(
        end.move_end.unwrap() - 1_000_000 <= 400_001,
        "0.4 s to stop"
    );
}

#[test]
fn estop_halts_marks_moving_axes_untrusted_and_latches_until_reset() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = open(
        dir.path(),
        &config(vec![
            ("X", AxisSettings::default()),
            ("Y", AxisSettings::default()),
        ]),
    );
    b.home("X", 0).unwrap();
    b.home("Y", 0).unwrap();
    let t = run_idle(&mut b);
    b.move_axis("X", Amount::Steps(50_000), false, &MoveOpts::default(), t)
        .unwrap();
    b.estop(t + 500_000);
    let x = st(&mut b, "X");
    let y = st(&mut b, "Y");
    assert_eq!(x.state, AxisState::Fault);
    assert!(!x.trusted && y.trusted);
    assert!(matches!(
        b.move_axis(
            "Y",
            Amount::Steps(1),
            false,
            &MoveOpts::default(),
            t + 600_000
        ),
        Err(CtlError::EStopped)
    ));
    b.reset(t + 700_000);
    assert_eq!(st(&mut b, "X").state, AxisState::Idle);
    b.move_axis(
        "Y",
        Amount::Steps(1),
        false,
        &MoveOpts::default(),
        t + 800_000,
    )
    .unwrap();
}

#[test]
fn bad_targets_and_busy_axes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let s = AxisSettings {
        soft_min: Some(-100),
        soft_max: Some(100),
        ..AxisSettings::default()
    };
    let mut b = open(dir.path(), &config(vec![("X", s)]));
    let o = MoveOpts::default();
    assert!(matches!(
        b.move_axis("X", Amount::Steps(101), true, &o, 0),
        Err(CtlError::OutOfLimits { .. })
    ));
    assert!(matches!(
        b.move_axis("Q", Amount::Steps(1), true, &o, 0),
        Err(CtlError::UnknownAxis(_))
    ));
    assert!(matches!(
        b.move_axis(
            "X",
            Amount::Steps(100),
            false,
            &MoveOpts {
                params: MoveParams {
                    vmax: Some(1e9),
                    amax: Some(1e9),
                    ..o.params
                },
                ..o.clone()
            },
            0
        ),
        Err(CtlError::TooFast(_))
    ));
    b.move_axis("X", Amount::Steps(100), true, &o, 0).unwrap();
    assert!(matches!(
        b.move_axis("X", Amount::Steps(1), false, &o, 10),
        Err(CtlError::Busy { .. })
    ));
    b.stop(None, 20).unwrap();
    run_idle(&mut b);
    b.set("X", "soft_max", "5", b.now()).unwrap();
    assert!(st(&mut b, "X").dir_level, "last move was positive");
    b.set("X", "invert_dir", "true", b.now()).unwrap();
    assert!(
        !st(&mut b, "X").dir_level,
        "inverted wiring flips the DIR level"
    );
    assert_eq!(b.settings("X").unwrap().soft_max, Some(5));
    b.home("X", b.now()).unwrap();
    assert!(matches!(
        b.move_axis("X", Amount::Steps(1), false, &o, b.now()),
        Err(CtlError::Busy {
            state: "homing",
            ..
        })
    ));
}

#[test]
fn a_board_that_dies_mid_move_restores_idle_axes_exactly_and_distrusts_the_moving_one() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(vec![
        ("X", AxisSettings::default()),
        ("Y", AxisSettings::default()),
    ]);
    {
        let mut b = open(dir.path(), &c);
        b.home("X", 0).unwrap();
        b.home("Y", 0).unwrap();
        let t = run_idle(&mut b);
        b.move_axis("Y", Amount::Steps(-1234), false, &MoveOpts::default(), t)
            .unwrap();
        let t = run_idle(&mut b);
        b.move_axis("X", Amount::Steps(40_000), false, &MoveOpts::default(), t)
            .unwrap();
        b.advance(t + 1_000_000);
        assert_eq!(st(&mut b, "X").state, AxisState::Moving);
        // Dropped without finishing: what a kill leaves in the store.
    }
    let mut b = open(dir.path(), &c);
    let y = st(&mut b, "Y");
    assert_eq!((y.position, y.homed, y.trusted), (-1234, true, true));
    let x = st(&mut b, "X");
    assert!(!x.trusted && !x.homed);
    b.home("X", 0).unwrap();
    run_idle(&mut b);
    let x = st(&mut b, "X");
    assert!(x.trusted && x.homed);
    assert_eq!(x.position, x.sim_position);
}

#[test]
fn passing_the_sensor_checks_the_count_and_catches_lost_steps() {
    let dir = tempfile::tempdir().unwrap();
    let s = AxisSettings {
        home_offset: 0,
        sim: SimSettings {
            sensor_at: 0,
            sensor_width: 100,
            ..SimSettings::default()
        },
        ..AxisSettings::default()
    };
    let mut b = open(dir.path(), &config(vec![("X", s)]));
    b.home("X", 0).unwrap();
    let t = run_idle(&mut b);
    let o = MoveOpts {
        params: MoveParams {
            vmax: Some(500.0),
            ..MoveParams::default()
        },
        ..MoveOpts::default()
    };
    // Out and back over the sensor in the homing (negative) direction: no drift.
    b.move_axis("X", Amount::Steps(2000), true, &o, t).unwrap();
    let t = run_idle(&mut b);
    b.move_axis("X", Amount::Steps(-2000), true, &o, t).unwrap();
    run_idle(&mut b);
    let x = st(&mut b, "X");
    assert_eq!((x.drift, x.drift_checks, x.trusted), (Some(0), 1, true));
    // The mechanics lose 50 steps: the next pass sees the edge 50 steps early in counts.
    b.sim_slip("X", -50, b.now()).unwrap();
    let t = b.now();
    b.move_axis("X", Amount::Steps(2000), true, &o, t).unwrap();
    let t = run_idle(&mut b);
    b.move_axis("X", Amount::Steps(-2000), true, &o, t).unwrap();
    run_idle(&mut b);
    let x = st(&mut b, "X");
    assert_eq!((x.drift, x.drift_checks), (Some(50), 2));
    assert!(!x.trusted, "a drifted count is not trusted");
}

/// The control experiment: the same glitches with a debounce time shorter than they last
/// are taken for the sensor, and homing lands far from the edge.
#[test]
fn with_a_debounce_shorter_than_the_glitches_homing_goes_wrong() {
    let mut wrong = 0;
    for seed in 0..20u64 {
        let dir = tempfile::tempdir().unwrap();
        let mut s = glitchy(seed, 0, -1);
        s.debounce = 0.0003; // glitches last up to 1.2 ms
        let mut b = open(dir.path(), &config(vec![("X", s)]));
        b.sim_slip("X", 8000, 0).unwrap();
        b.home("X", 0).unwrap();
        run_idle(&mut b);
        let s = st(&mut b, "X");
        if s.state != AxisState::Idle || s.sim_position.abs() > 1 {
            wrong += 1;
        }
    }
    assert!(wrong >= 10, "only {wrong} of 20 homings went wrong");
}

#[test]
fn sim_commands_belong_to_the_simulated_board_only() {
    let dir = tempfile::tempdir().unwrap();
    let c = config(vec![("X", AxisSettings::default())]);
    let mut sim = open(dir.path(), &c);
    assert!(sim.is_simulated());
    sim.sim_slip("X", 5, 0).unwrap();
    assert_eq!(st(&mut sim, "X").sim_position, 5);
    drop(sim);
    let mut hw = open(dir.path(), &c).without_simulation();
    let e = hw.sim_slip("X", 5, 0).unwrap_err();
    assert!(matches!(e, CtlError::NotSimulated), "{e}");
    assert_eq!(e.code(), 18);
    assert_eq!(st(&mut hw, "X").sim_position, 5, "nothing changed");
}

#[test]
fn a_work_budget_bounds_each_advance_and_the_clock_catches_up_later() {
    let dir = tempfile::tempdir().unwrap();
    let s = AxisSettings {
        vmax: 1e6,
        amax: 1e9,
        sim: SimSettings {
            sensor_width: 1,
            bounce_count: 100,
            bounce_time: 1.0,
            glitch_rate: 1e4,
            glitch_max: 1.0,
            glitch_gap: 0.0,
            ..SimSettings::default()
        },
        period: Some(2),
        ..AxisSettings::default()
    };
    let c = config(vec![("X", s.clone()), ("Y", s)]);
    let mut b = open(dir.path(), &c);
    b.set_work_budget(Some(10_000));
    b.group_move(
        &[
            ("X".into(), Amount::Steps(1)),
            ("Y".into(), Amount::Steps(1)),
        ],
        false,
        false,
        &MoveOpts::default(),
        0,
    )
    .unwrap();
    // Every step crosses the sensor edge (period 2, width 1) with bounce and glitches.
    b.set("X", "period", "none", 1).unwrap_err(); // busy
    let far = 1_000_000_000u64;
    b.advance(far);
    let (_, most) = b.work();
    assert!(most <= 2 * 10_000, "one advance did {most} units of work");
    let mut calls = 0;
    while b.now() < far || b.busy() {
        b.advance(far);
        calls += 1;
        assert!(calls < 1_000_000, "the clock never caught up");
    }
    assert!(b.work().1 <= 2 * 10_000);
}
