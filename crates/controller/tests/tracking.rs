//! Tracking on the simulated board in virtual time: the board's position at sampled ticks
//! is the count of the core tracker's edges up to that tick (the tracker `multistep plan
//! --track` prints), through rate changes, reversals and stops; soft limits, periodic
//! wrap, jog leases; driver enable and release.

use multistep_controller::config::{AxisConfig, BoardConfig, BoardSection};
use multistep_controller::protocol::{Amount, MoveOpts, RateArg, SignedRate, TrackOpts};
use multistep_controller::store::Store;
use multistep_controller::{AxisSettings, AxisState, AxisStatus, Board, CtlError};
use multistep_core::{Rate, TrackLimits, Tracker};

fn config(clock_hz: f64, axes: Vec<(&str, AxisSettings)>) -> BoardConfig {
    BoardConfig {
        board: BoardSection {
            name: "t".into(),
            clock_hz,
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

fn st(b: &mut Board, axis: &str) -> AxisStatus {
    let now = b.now();
    b.status(&[axis.to_string()], now).unwrap().remove(0)
}

fn rate(text: &str) -> RateArg {
    RateArg::Value(SignedRate::parse(text).unwrap().unwrap())
}

fn track(b: &mut Board, axis: &str, r: &str, now: u64) -> Result<f64, CtlError> {
    b.track(axis, &rate(r), &TrackOpts::default(), None, now)
}

/// The reference: the core tracker (what `plan --track` prints), started at tick `start`,
/// with the count of its edges up to a tick.
struct Reference {
    tr: Tracker,
    start: u64,
    /// Edges at or before the ticks asked about so far.
    taken: u64,
    /// The next edge, produced but not yet counted.
    ahead: Option<u64>,
}

impl Reference {
    fn new(clock: f64, amax: f64, r: &str, start: u64) -> Reference {
        let limits = TrackLimits { amax, jmax: None };
        let tr = Tracker::new(clock, limits, 0.0, Rate::parse(r).unwrap()).unwrap();
        Reference {
            tr,
            start,
            taken: 0,
            ahead: None,
        }
    }

    fn fill(&mut self) {
        if self.ahead.is_none() {
            self.ahead = self.tr.next().map(|e| self.start + e);
        }
    }

    /// Edges with tick ≤ t (t non-decreasing between calls).
    fn count_to(&mut self, t: u64) -> u64 {
        loop {
            self.fill();
            match self.ahead {
                Some(e) if e <= t => {
                    self.taken += 1;
                    self.ahead = None;
                }
                _ => return self.taken,
            }
        }
    }

    /// As the board does on a command at tick `now`: every edge ≤ now taken, the next
    /// one produced (the board looks one edge ahead), then the new rate.
    fn set_rate_at(&mut self, now: u64, r: Rate) {
        self.count_to(now);
        self.fill();
        self.tr.set_rate(r).unwrap();
    }
}

fn tracking_axis(vmax: f64, amax: f64) -> AxisSettings {
    AxisSettings {
        vmax,
        amax,
        ..AxisSettings::default()
    }
}

/// Samples the board every `every` ticks up to `until`, checking the position against
/// the reference at each; returns the samples taken.
fn follow(b: &mut Board, r: &mut Reference, until: u64, every: u64) -> u64 {
    let mut n = 0;
    let mut t = b.now();
    while t < until {
        t = (t + every).min(until);
        b.advance(t);
        let s = st(b, "X");
        assert_eq!(s.position as u64, r.count_to(t), "position at tick {t}");
        n += 1;
    }
    n
}

#[test]
fn board_edges_are_the_trackers_through_rate_changes_and_a_stop() {
    let clock = 1e6;
    let dir = tempfile::tempdir().unwrap();
    let mut b = open(
        dir.path(),
        &config(clock, vec![("X", tracking_axis(5000.0, 2000.0))]),
    );
    assert_eq!(track(&mut b, "X", "15041/324", 0).unwrap(), 15041.0 / 324.0);
    let mut r = Reference::new(clock, 2000.0, "15041/324", 0);
    let s = st(&mut b, "X");
    assert_eq!(s.state, AxisState::Tracking);
    assert_eq!(s.rate, Some(15041.0 / 324.0));
    assert_eq!(s.target, None);
    follow(&mut b, &mut r, 20_000_000, 9_973);
    // faster, without stopping
    track(&mut b, "X", "3000.5", 20_000_000).unwrap();
    r.set_rate_at(20_000_000, Rate::parse("3000.5").unwrap());
    follow(&mut b, &mut r, 25_000_000, 1_237);
    assert!((st(&mut b, "X").speed - 3000.5).abs() < 1e-6);
    // slower again
    track(&mut b, "X", "100", 25_000_000).unwrap();
    r.set_rate_at(25_000_000, Rate::new(100, 1).unwrap());
    follow(&mut b, &mut r, 30_000_000, 3_001);
    // a controlled stop is the tracker's own stop
    b.stop(Some("X"), 30_000_000).unwrap();
    r.set_rate_at(30_000_000, Rate::ZERO);
    assert_eq!(st(&mut b, "X").state, AxisState::Moving);
    follow(&mut b, &mut r, 32_000_000, 1_000);
    let s = st(&mut b, "X");
    assert_eq!(s.state, AxisState::Idle);
    assert_eq!(s.rate, None);
    assert_eq!(s.position as u64, r.count_to(u64::MAX));
}

#[test]
fn a_negative_rate_reverses_through_a_controlled_stop() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = open(
        dir.path(),
        &config(1e6, vec![("X", tracking_axis(5000.0, 4000.0))]),
    );
    track(&mut b, "X", "2000", 0).unwrap();
    b.advance(2_000_000);
    let at = st(&mut b, "X").position;
    assert!(at > 2000, "{at}");
    track(&mut b, "X", "-1500", 2_000_000).unwrap();
    let s = st(&mut b, "X");
    assert_eq!((s.state, s.rate), (AxisState::Tracking, Some(-1500.0)));
    // the stop from 2000 steps/s at 4000 steps/s² takes 500 steps and 0.5 s
    let mut peak = at;
    let mut t = 2_000_000;
    let mut last_speed = f64::MAX;
    while t < 6_000_000 {
        t += 10_000;
        b.advance(t);
        let s = st(&mut b, "X");
        peak = peak.max(s.position);
        assert!(
            s.speed <= last_speed + 1e-9 || s.speed < 0.0,
            "the speed only falls"
        );
        last_speed = s.speed.max(-1e9);
    }
    assert!(
        peak - at <= 502 && peak - at >= 498,
        "went on {} steps",
        peak - at
    );
    let s = st(&mut b, "X");
    assert!((s.speed + 1500.0).abs() < 1e-9, "{}", s.speed);
    assert_eq!(s.state, AxisState::Tracking);
    assert!(s.position < peak - 4000);
    assert!(!s.dir_level, "DIR shows the negative direction");
}

#[test]
fn soft_limits_stop_a_tracking_axis_before_it_crosses_them() {
    let (mut cases, mut refused) = (0, 0);
    for (k, (r, amax, jmax)) in [
        ("4000", 20000.0, None),
        ("-3999.5", 5000.0, None),
        ("250", 100.0, None),
        ("31999.9", 64000.0, None),
        ("2500", 8000.0, Some(40000.0)),
        ("-777.7", 300.0, Some(1000.0)),
    ]
    .into_iter()
    .enumerate()
    {
        for limit in [3i64, 150, 5_000, 40_001] {
            let dir = tempfile::tempdir().unwrap();
            let s = AxisSettings {
                vmax: 40_000.0,
                amax: 1e5,
                jmax,
                soft_min: Some(-limit - k as i64),
                soft_max: Some(limit + k as i64),
                ..AxisSettings::default()
            };
            let mut b = open(dir.path(), &config(1e6, vec![("X", s)]));
            let opts = TrackOpts {
                amax: Some(amax),
                lease: None,
            };
            match b.track("X", &rate(r), &opts, None, 0) {
                Err(CtlError::OutOfLimits { .. }) => {
                    // an S-curve ramp runs to its end before a stop: no room for it
                    assert!(jmax.is_some() && limit < 5_000, "{r} {limit} refused");
                    assert_eq!(st(&mut b, "X").state, AxisState::Idle);
                    refused += 1;
                    continue;
                }
                other => {
                    other.unwrap();
                }
            }
            let mut t = 0;
            let mut far = 0i64;
            while b.busy() {
                t += 20_000;
                b.advance(t);
                far = far.max(st(&mut b, "X").position.abs());
                assert!(t < 2_000_000_000, "{r} never stopped");
            }
            let at = st(&mut b, "X");
            let lim = limit + k as i64;
            assert!(
                far <= lim,
                "{r} amax {amax}: reached {far} past the limit {lim}"
            );
            // it stopped near the limit: within the stop distance and a margin
            let v = r.trim_start_matches('-').parse::<f64>().unwrap();
            let stop = v * v / (2.0 * amax) + jmax.map_or(0.0, |j| v * amax / (2.0 * j));
            assert!(
                at.position.abs() as f64 >= lim as f64 - 2.0 * stop - 8.0,
                "{r}: stopped at {} far from {lim}",
                at.position
            );
            assert_eq!(at.state, AxisState::Idle);
            // at the limit, tracking further that way is refused; back is fine
            let sign = if r.starts_with('-') { "-" } else { "" };
            if at.position.abs() == lim {
                assert!(matches!(
                    track(&mut b, "X", &format!("{sign}10"), t),
                    Err(CtlError::OutOfLimits { .. })
                ));
            }
            cases += 1;
        }
    }
    assert_eq!((cases, refused), (20, 4));
}

#[test]
fn a_periodic_axis_wraps_while_tracking() {
    let clock = 1e6;
    let dir = tempfile::tempdir().unwrap();
    let s = AxisSettings {
        period: Some(4000),
        ..tracking_axis(5000.0, 20000.0)
    };
    let mut b = open(dir.path(), &config(clock, vec![("X", s)]));
    track(&mut b, "X", "-3333.3", 0).unwrap();
    let mut r = Reference::new(clock, 20000.0, "3333.3", 0);
    let mut t = 0;
    while t < 10_000_000 {
        t += 7_919;
        b.advance(t);
        let s = st(&mut b, "X");
        assert!((0..4000).contains(&s.position), "{}", s.position);
        let n = r.count_to(t) as i64;
        assert_eq!(s.position, (-n).rem_euclid(4000), "at tick {t}");
    }
    assert!(r.taken > 30_000);
}

/// A jog at 1000 steps/s under a 0.3 s lease, renewed every 0.2 s from 0 to 1.8 s.
fn jog_renewed_to_1_8_s(b: &mut Board) {
    let opts = TrackOpts {
        amax: None,
        lease: Some(0.3),
    };
    for k in 0..10u64 {
        b.track("X", &rate("1000"), &opts, Some(300_000), k * 200_000)
            .unwrap();
    }
}

#[test]
fn a_jog_lease_stops_the_axis_unless_renewed() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = open(
        dir.path(),
        &config(1e6, vec![("X", tracking_axis(5000.0, 20000.0))]),
    );
    // renewed every 0.2 s for 2 s: runs all along
    jog_renewed_to_1_8_s(&mut b);
    b.advance(2_000_000);
    assert_eq!(st(&mut b, "X").state, AxisState::Tracking);
    // renewals do not touch the stream: one cruise from the start
    let mut r = Reference::new(1e6, 20000.0, "1000", 0);
    assert_eq!(st(&mut b, "X").position as u64, r.count_to(2_000_000));
    // no renewal: stops at the lease (1.8 s + 0.3 s), decelerating 25 steps
    b.advance(2_100_000);
    let s = st(&mut b, "X");
    assert_eq!(s.state, AxisState::Moving, "stopping");
    assert_eq!(s.rate, Some(0.0));
    b.advance(2_200_000);
    let s = st(&mut b, "X");
    assert_eq!(s.state, AxisState::Idle);
    let n = r.count_to(2_100_000) as i64;
    assert!((s.position - n - 25).abs() <= 2, "{} vs {n}", s.position);
}

/// A lease counts from the command's arrival, not from the board's clock: a backend that
/// falls behind under load (the service's work budget) and then catches up does not lapse
/// a jog renewed in time, and an unrenewed one still stops a lease after its last renewal.
#[test]
fn a_jog_lease_counts_from_the_command_not_from_a_lagging_board_clock() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = open(
        dir.path(),
        &config(1e6, vec![("X", tracking_axis(5000.0, 20000.0))]),
    );
    b.set_work_budget(Some(64));
    jog_renewed_to_1_8_s(&mut b);
    let lag = 1_800_000 - b.now();
    assert!(lag > 300_000, "the board's clock lags by {lag} ticks only");
    b.set_work_budget(None);
    b.advance(2_000_000);
    assert_eq!(st(&mut b, "X").state, AxisState::Tracking);
    // the last renewal came at 1.8 s: stopping from 2.1 s
    b.advance(2_090_000);
    assert_eq!(st(&mut b, "X").rate, Some(1000.0));
    b.advance(2_200_000);
    assert_ne!(st(&mut b, "X").state, AxisState::Tracking);
}

#[test]
fn bad_track_requests_are_refused_one_by_one() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = open(
        dir.path(),
        &config(1e6, vec![("X", tracking_axis(5000.0, 20000.0))]),
    );
    let err = |b: &mut Board, r: RateArg| {
        b.track("X", &r, &TrackOpts::default(), None, 0)
            .unwrap_err()
            .code()
    };
    assert_eq!(err(&mut b, rate("5000.1")), 14, "above vmax");
    assert_eq!(
        err(&mut b, RateArg::Preset("fast".into())),
        8,
        "unknown preset"
    );
    let opts = TrackOpts {
        amax: Some(1e6),
        lease: None,
    };
    assert_eq!(
        b.track("X", &rate("10"), &opts, None, 0)
            .unwrap_err()
            .code(),
        14,
        "accel above amax"
    );
    // a rate whose step period is under two ticks (the clock is 1 MHz)
    let dir2 = tempfile::tempdir().unwrap();
    let mut fast = open(
        dir2.path(),
        &config(1e6, vec![("X", tracking_axis(1e6, 1e9))]),
    );
    assert_eq!(track(&mut fast, "X", "600000", 0).unwrap_err().code(), 14);
    // busy: homing, moving
    b.home("X", 0).unwrap();
    assert_eq!(err(&mut b, rate("10")), 6);
    b.stop(None, 0).unwrap();
    b.advance(100_000_000);
    b.move_axis(
        "X",
        Amount::Steps(5000),
        false,
        &MoveOpts::default(),
        100_000_000,
    )
    .unwrap();
    assert_eq!(
        b.track("X", &rate("10"), &TrackOpts::default(), None, 100_000_000)
            .unwrap_err()
            .code(),
        6
    );
    // stored rates: by name, in user units
    b.set_rate_preset("slow", &SignedRate::parse("-2.5u").unwrap().unwrap())
        .unwrap();
    b.advance(300_000_000);
    b.set("X", "steps_per_unit", "4", 300_000_000).unwrap();
    let v = b
        .track(
            "X",
            &RateArg::Preset("slow".into()),
            &TrackOpts::default(),
            None,
            300_000_000,
        )
        .unwrap();
    assert_eq!(v, -10.0);
    assert_eq!(b.rate_presets().unwrap()["slow"], "-5/2u");
    b.estop(300_500_000);
    assert_eq!(err(&mut b, rate("10")), 11);
    // named rates are kept with the board
    drop(b);
    let b = open(
        dir.path(),
        &config(1e6, vec![("X", tracking_axis(5000.0, 20000.0))]),
    );
    assert_eq!(b.rate_presets().unwrap()["slow"], "-5/2u");
}

#[test]
fn drivers_are_energized_before_motion_and_released_at_rest() {
    let dir = tempfile::tempdir().unwrap();
    let x = AxisSettings {
        enable_settle: 0.25,
        idle_release: Some(2.0),
        ..AxisSettings::default()
    };
    let y = AxisSettings {
        release_keeps_position: true,
        enable_active_high: true,
        ..AxisSettings::default()
    };
    let mut b = open(dir.path(), &config(1e6, vec![("X", x), ("Y", y)]));
    // energized from start-up; X is released 2 s after it came to rest
    let s = st(&mut b, "X");
    assert!(
        s.enabled && !s.enable_level,
        "active low: the line is low when enabled"
    );
    assert!(b.needs_polling());
    b.advance(1_999_999);
    assert!(st(&mut b, "X").enabled);
    b.advance(2_000_000);
    let s = st(&mut b, "X");
    assert!(!s.enabled && s.enable_level && !s.trusted, "{s:?}");
    // the next move energizes it and waits 0.25 s before the first step
    b.move_axis(
        "X",
        Amount::Steps(100),
        false,
        &MoveOpts::default(),
        3_000_000,
    )
    .unwrap();
    let s = st(&mut b, "X");
    assert!(s.enabled);
    assert!(s.move_start.unwrap() >= 3_250_000, "{:?}", s.move_start);
    // a moving axis cannot be released
    assert_eq!(b.release("X", 3_000_001).unwrap_err().code(), 6);
    // Y keeps its position when released; energize brings it back
    b.release("Y", 3_000_002).unwrap();
    let s = st(&mut b, "Y");
    assert!(!s.enabled && !s.enable_level && s.trusted == st(&mut b, "Y").trusted);
    let before = st(&mut b, "Y").trusted;
    b.energize("Y", 3_000_003).unwrap();
    let s = st(&mut b, "Y");
    assert!(s.enabled && s.enable_level && s.trusted == before);
    // settings persist, with their ranges
    b.advance(10_000_000);
    b.set("X", "idle_release", "never", 10_000_000).unwrap();
    assert_eq!(b.settings("X").unwrap().idle_release, None);
    for bad in [
        ("enable_settle", "11"),
        ("enable_settle", "-1"),
        ("idle_release", "1e6"),
    ] {
        assert_eq!(b.set("X", bad.0, bad.1, 10_000_000).unwrap_err().code(), 9);
    }
    b.set("X", "enable_settle", "0.5", 10_000_000).unwrap();
    b.set("Y", "release_keeps_position", "true", 10_000_000)
        .unwrap();
    drop(b);
    let b = open(
        dir.path(),
        &config(
            1e6,
            vec![
                ("X", AxisSettings::default()),
                ("Y", AxisSettings::default()),
            ],
        ),
    );
    assert_eq!(b.settings("X").unwrap().enable_settle, 0.5);
    assert!(b.settings("Y").unwrap().release_keeps_position);
}

mod random_rate_changes {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Random rates (decimals with up to 3 places), changed at random ticks, then a
        /// stop: the board's position equals the reference tracker's count at every sample,
        /// the commanded speed never exceeds the fastest rate asked for, and the axis
        /// comes to rest on the reference's last edge.
        #[test]
        fn board_follows_the_tracker_through_random_rate_changes(
            amax in 200.0f64..50_000.0,
            rates in proptest::collection::vec(1u64..4_000_000, 2..5),
            gaps in proptest::collection::vec(50_000u64..2_000_000, 4),
        ) {
            let clock = 1e6;
            let dir = tempfile::tempdir().unwrap();
            let mut b = open(dir.path(), &config(clock, vec![("X", tracking_axis(4000.0, amax))]));
            let text = |milli: u64| format!("{}.{:03}", milli / 1000, milli % 1000);
            let fastest = rates.iter().max().copied().unwrap() as f64 / 1000.0;
            track(&mut b, "X", &text(rates[0]), 0).unwrap();
            let mut r = Reference::new(clock, amax, &text(rates[0]), 0);
            let mut t = 0;
            for (k, &next) in rates[1..].iter().chain([&0]).enumerate() {
                let until = t + gaps[k];
                while t < until {
                    t = (t + 7_013).min(until);
                    b.advance(t);
                    let s = st(&mut b, "X");
                    prop_assert_eq!(s.position as u64, r.count_to(t), "tick {}", t);
                    prop_assert!(s.speed <= fastest * (1.0 + 1e-9), "{} > {}", s.speed, fastest);
                }
                if next == 0 {
                    b.stop(Some("X"), t).unwrap();
                    r.set_rate_at(t, Rate::ZERO);
                } else {
                    track(&mut b, "X", &text(next), t).unwrap();
                    r.set_rate_at(t, Rate::parse(&text(next)).unwrap());
                }
            }
            while b.busy() {
                t += 50_000;
                b.advance(t);
            }
            prop_assert_eq!(st(&mut b, "X").position as u64, r.count_to(u64::MAX));
        }
    }
}
