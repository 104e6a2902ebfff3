//! Tracking kept to host time on two simulated boards whose crystals are 50 ppm fast and
//! 50 ppm slow, in virtual time: the host reads each board's tick counter every 10 s over
//! a jittery link (0.2 to 1.2 ms round trips, every ninth reading held up to 2 s), fits the
//! crystal and gives the trackers the corrected rate. For 24 hours at the sidereal, solar
//! and lunar rates every sampled position is within one step of the ideal computed from
//! host time, and the two boards' axes within one step of each other. The pointing drift
//! against host time is printed (docs/PROTOCOL.md) and asserted below 0.1″ an hour.

use multistep_controller::clock_rate::Reading;
use multistep_controller::config::{AxisConfig, BoardConfig, BoardSection};
use multistep_controller::protocol::{RateArg, SignedRate, TrackOpts};
use multistep_controller::store::Store;
use multistep_controller::{AxisSettings, Board, Controller};
use multistep_core::{Rate, TrackLimits, Tracker};
use std::time::{Duration, Instant};

const F: u64 = 50_000_000;
const AMAX: f64 = 200.0;
const S: u64 = 1_000_000_000;
/// Sidereal 15.041″/s, solar 15″/s and lunar 14.685″/s at 4,000,000 microsteps per
/// 1,296,000″.
const RATES: [(&str, &str); 3] = [
    ("sidereal", "15041/324"),
    ("solar", "1250/27"),
    ("lunar", "4895/108"),
];
/// Arcseconds per step.
const ARCSEC: f64 = 1.296e6 / 4e6;

/// The board's tick at host time `t_ns` on a crystal `ppm` off (exact, floored).
fn tick(t_ns: u64, ppm: i64) -> u64 {
    (t_ns as i128 * F as i128 * (1_000_000 + ppm as i128) / (S as i128 * 1_000_000)) as u64
}

struct Sim {
    board: Board,
    ppm: i64,
    seed: u64,
    readings: u64,
    _dir: tempfile::TempDir,
}

impl Sim {
    fn new(ppm: i64, seed: u64) -> Sim {
        let dir = tempfile::tempdir().unwrap();
        let axes = RATES
            .iter()
            .map(|(name, _)| AxisConfig {
                name: name.to_string(),
                settings: AxisSettings {
                    vmax: 40_000.0,
                    amax: AMAX,
                    steps_per_unit: 4e6 / 1.296e6,
                    ..AxisSettings::default()
                },
            })
            .collect();
        let c = BoardConfig {
            board: BoardSection {
                name: format!("b{ppm}"),
                clock_hz: F as f64,
                fifo_depth: 4,
                link: None,
                sync_line: None,
            },
            axes,
            alpaca: None,
        };
        let board = Board::open(&c, Store::open(dir.path()).unwrap()).unwrap();
        Sim {
            board,
            ppm,
            seed,
            readings: 0,
            _dir: dir,
        }
    }

    fn random(&mut self) -> u64 {
        self.seed = self
            .seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.seed >> 24
    }

    /// One reading of the counter asked for at host time `t`.
    fn read(&mut self, t: u64) {
        self.readings += 1;
        let mut rtt = 200_000 + self.random() % 1_000_000;
        let latched = t + self.random() % rtt;
        if self.readings % 9 == 4 {
            rtt += self.random() % (2 * S);
        }
        let r = Reading {
            sent_ns: t,
            recv_ns: t + rtt,
            tick: tick(latched, self.ppm),
        };
        self.board.clock_reading(r).unwrap();
    }

    fn position(&mut self, axis: &str, t: u64) -> i64 {
        let now = tick(t, self.ppm);
        self.board.status(&[axis.into()], now).unwrap()[0].position
    }
}

/// Readings of every board's counter every 10 s of host time from 0 until `end`.
fn read_until(boards: &mut [Sim], end: u64) {
    let mut t = 0;
    while t < end {
        for b in boards.iter_mut() {
            b.read(t);
        }
        t += 10 * S;
    }
}

/// The reference: the exact tracker on host time from `start_ns`; `count(t)` is its edges
/// up to host time `t`, `edge(n)` the host time of step `n` (ns, fractional).
struct Ideal {
    tracker: Tracker,
    start: u64,
    taken: u64,
    ahead: Option<u64>,
    edges: Vec<u64>,
}

impl Ideal {
    fn new(rate: &str, start_ns: u64) -> Ideal {
        let limits = TrackLimits {
            amax: AMAX,
            jmax: None,
        };
        let mut tracker = Tracker::new(F as f64, limits, 0.0, Rate::parse(rate).unwrap()).unwrap();
        let ahead = tracker.next();
        Ideal {
            tracker,
            start: start_ns / (S / F),
            taken: 0,
            ahead,
            edges: Vec::new(),
        }
    }

    fn count(&mut self, t_ns: u64) -> i64 {
        let h = t_ns / (S / F);
        while let Some(e) = self.ahead.filter(|&e| self.start + e <= h) {
            self.taken += 1;
            self.edges.push(e);
            if self.edges.len() > 64 {
                self.edges.remove(0);
            }
            self.ahead = self.tracker.next();
        }
        self.taken as i64
    }

    /// Host time (s) of step `n` (1-based), among the last edges counted.
    fn edge_s(&self, n: u64) -> f64 {
        let back = (self.taken - n) as usize;
        let e = self.edges[self.edges.len() - 1 - back];
        (self.start + e) as f64 / F as f64
    }
}

/// The host time (s) at which `sim`'s `axis` reaches step `n`, to within 20 µs, stepping
/// the board forward from host time `t`.
fn reaches(sim: &mut Sim, axis: &str, n: i64, mut t: u64) -> f64 {
    while sim.position(axis, t) < n {
        t += 20_000;
    }
    t as f64 / S as f64
}

#[test]
fn a_day_on_two_boards_50_ppm_apart_follows_host_time() {
    let mut boards = [Sim::new(50, 1), Sim::new(-50, 2)];
    let start = 600 * S;
    let day = 24 * 3600 * S;
    // ten minutes of readings before tracking starts
    read_until(&mut boards, start);
    for b in &mut boards {
        let fit = b.board.clock_state();
        let ppm = fit.ppm.unwrap();
        assert!((ppm - b.ppm as f64).abs() < 0.5, "{ppm} vs {}", b.ppm);
        assert!(fit.correcting);
        let now = tick(start, b.ppm);
        for (axis, rate) in RATES {
            let r = RateArg::Value(SignedRate::parse(rate).unwrap().unwrap());
            b.board
                .track(axis, &r, &TrackOpts::default(), None, now)
                .unwrap();
        }
    }
    let mut ideal: Vec<Ideal> = RATES.iter().map(|(_, r)| Ideal::new(r, start)).collect();
    let (mut samples, mut worst) = (0u64, 0i64);
    let mut lag = Vec::new();
    let mut next_read = start;
    let mut k = 0u64;
    loop {
        k += 1;
        // every minute, at an odd offset so samples fall anywhere between edges
        let at = (start + k * 60 * S + k * 12_347_891 % S).min(start + day);
        while next_read <= at {
            for b in &mut boards {
                b.read(next_read);
            }
            next_read += 10 * S;
        }
        for (j, (axis, _)) in RATES.iter().enumerate() {
            let want = ideal[j].count(at);
            let a = boards[0].position(axis, at);
            let b = boards[1].position(axis, at);
            let off = (a - want).abs().max((b - want).abs());
            worst = worst.max(off);
            assert!(off <= 1, "{axis} at {at} ns: {a} and {b}, ideal {want}");
            assert!((a - b).abs() <= 1, "{axis} at {at} ns: {a} vs {b}");
        }
        samples += 1;
        // after the first hour and at the end: when each board's sidereal axis makes
        // its next step, against the ideal's
        if k == 60 || at == start + day {
            let n = ideal[0].count(at) + 1;
            let want_t = {
                let mut probe = at;
                while ideal[0].count(probe) < n {
                    probe += 20_000;
                }
                ideal[0].edge_s(n as u64)
            };
            let got: Vec<f64> = boards
                .iter_mut()
                .map(|b| reaches(b, "sidereal", n, at) - want_t)
                .collect();
            lag.push((at, got));
        }
        if at == start + day {
            break;
        }
    }
    assert!(samples >= 1440, "{samples}");
    let hours = (lag[1].0 - lag[0].0) as f64 / 3600e9;
    for (i, b) in boards.iter().enumerate() {
        let drift = (lag[1].1[i] - lag[0].1[i]) / hours * 15.041;
        let c = b.board.clock_state();
        println!(
            "board at {:+} ppm: fitted {:+.4} ppm, trackers on {:+.3} ppm; sidereal step \
             {:+.0} µs from host time after 1 h, {:+.0} µs after 24 h: drift {:+.4}″/h; \
             worst sample {worst} step ({ARCSEC}″/step)",
            b.ppm,
            c.ppm.unwrap(),
            c.applied_ppm,
            lag[0].1[i] * 1e6,
            lag[1].1[i] * 1e6,
            drift,
        );
        assert!(drift.abs() <= 0.1, "{drift}″/h");
    }
}

/// Without the correction the same board runs on its crystal: 50 ppm of 46.4 steps/s is
/// 8.4 steps (2.7″) an hour ahead of host time.
#[test]
fn without_the_correction_a_board_follows_its_crystal() {
    let mut b = Sim::new(50, 3);
    b.board.set_clock_correction(false);
    let start = 600 * S;
    let mut t = 0;
    while t < start {
        b.read(t);
        t += 10 * S;
    }
    let c = b.board.clock_state();
    assert!(
        !c.correcting && c.applied_ppm == 0.0 && c.ppm.is_some(),
        "{c:?}"
    );
    let r = RateArg::Value(SignedRate::parse(RATES[0].1).unwrap().unwrap());
    b.board
        .track("sidereal", &r, &TrackOpts::default(), None, tick(start, 50))
        .unwrap();
    let mut ideal = Ideal::new(RATES[0].1, start);
    let at = start + 3600 * S;
    let ahead = b.position("sidereal", at) - ideal.count(at);
    assert!((8..=9).contains(&ahead), "{ahead} steps ahead");
    // turned on, the rate follows host time from then on (the steps ahead stay ahead)
    b.board.set_clock_correction(true);
    assert!(b.board.clock_state().correcting);
    let later = at + 3600 * S;
    let more = b.position("sidereal", later) - ideal.count(later);
    assert!((ahead - 1..=ahead + 1).contains(&more), "{more} vs {ahead}");
}

/// `status` says what the host fitted and whether tracking follows it, on every axis of
/// the board, once there is a fit; a board without one shows neither.
#[test]
fn status_shows_the_fitted_crystal() {
    let mut b = Sim::new(-50, 4);
    let before = b.board.status(&[], 0).unwrap();
    assert!(before.iter().all(|s| s.clock_ppm.is_none()));
    assert!(!before[0].line().contains("clock"), "{}", before[0].line());
    for k in 0..60 {
        b.read(k * 10 * S);
    }
    let all = b.board.status(&[], tick(600 * S, -50)).unwrap();
    for s in &all {
        let ppm = s.clock_ppm.unwrap();
        assert!((ppm + 50.0).abs() < 0.5, "{ppm}");
        assert_eq!(s.clock_fix, Some(true));
        let line = s.line();
        let shown = format!(" clock_ppm={ppm:.4} clock_fix=1 en=");
        assert!(line.contains(&shown), "{line}");
        let json = serde_json::to_string(s).unwrap();
        assert!(json.contains(r#""clock_fix":true"#), "{json}");
    }
    b.board.set_clock_correction(false);
    let s = b.board.status(&[], tick(600 * S, -50)).unwrap().remove(0);
    assert_eq!(s.clock_fix, Some(false));
    assert!(s.line().contains(" clock_fix=0 en="), "{}", s.line());
}

/// `serve --ppm`: the simulated board's ticks run off host time (the scaled wall clock)
/// and the host's fit of its counter finds the error.
#[test]
fn a_simulated_board_with_a_crystal_error_is_fitted() {
    let dir = tempfile::tempdir().unwrap();
    let store = || Store::open(dir.path()).unwrap();
    let c = BoardConfig::default();
    for bad in [1000.5, -2000.0, f64::NAN] {
        let e = Controller::open_sim(&c, store(), 1000.0, bad)
            .err()
            .unwrap();
        assert!(
            e.to_string().contains("ppm must be in [-1000, 1000]"),
            "{e}"
        );
    }
    let ctl = Controller::open_sim(&c, store(), 1000.0, 200.0).unwrap();
    let end = Instant::now() + Duration::from_secs(60);
    let s = loop {
        let s = ctl.status(&["X".into()]).unwrap().remove(0);
        if s.clock_ppm.is_some() {
            break s;
        }
        assert!(Instant::now() < end, "no fit: {s:?}");
        std::thread::sleep(Duration::from_millis(5));
    };
    let ppm = s.clock_ppm.unwrap();
    assert!((ppm - 200.0).abs() < 0.01, "{ppm}");
    assert_eq!(s.clock_fix, Some(true));
}

/// Host nanoseconds of `ticks` board ticks on a crystal `ppm` off.
fn host_ns(ticks: u64, ppm: i64) -> f64 {
    ticks as f64 * S as f64 * 1e6 / (F as f64 * (1e6 + ppm as f64))
}

/// Moves with phase times follow host time too: on the two boards 50 ppm fast and slow, a
/// 2/6/2 s move and a sync group of two axes given those times last them but for the fit's
/// error (a few tenths of a ppm: microseconds in 10 s, where the crystals alone put them
/// a millisecond apart), and pass the same positions at the same host times. A
/// limits-mode move is played on the board's ticks per host second: it keeps its limits
/// in host seconds and lasts its host time too (uncorrected, the crystal's error).
#[test]
fn phase_time_moves_on_two_boards_50_ppm_apart_last_their_host_time() {
    use multistep_controller::protocol::{Amount, MoveOpts};
    use multistep_core::{MoveParams, MoveSpec};
    let phases = MoveParams {
        accel_time: Some(2.0),
        cruise_time: Some(6.0),
        decel_time: Some(2.0),
        ..MoveParams::default()
    };
    let nominal = |steps: u64, params: MoveParams| {
        let spec = MoveSpec {
            profile: Some("trapezoid"),
            steps: Some(steps),
            params,
            ..MoveSpec::default()
        };
        spec.plan_on_clock(F as f64).unwrap().duration() * 1e9
    };
    let limits = MoveParams {
        vmax: Some(40_000.0),
        amax: Some(AMAX),
        ..MoveParams::default()
    };
    for correct in [true, false] {
        let mut boards = [Sim::new(50, 5), Sim::new(-50, 6)];
        for b in &mut boards {
            b.board.set_clock_correction(correct);
        }
        let start = 600 * S;
        read_until(&mut boards, start);
        // host durations of: solar's phase-time move, the sync group (sidereal, lunar) of
        // the same phase times, and a limits move of sidereal after it
        let mut took: Vec<[f64; 4]> = Vec::new();
        for b in &mut boards {
            let now = tick(start, b.ppm);
            let steps = |a: &str, n| (a.to_string(), Amount::Steps(n));
            let timed = MoveOpts {
                params: phases,
                ..MoveOpts::default()
            };
            let brd = &mut b.board;
            brd.group_move(&[steps("solar", 2_000)], false, false, &timed, now)
                .unwrap();
            let group = [steps("sidereal", 3_000), steps("lunar", 1_000)];
            brd.group_move(&group, false, true, &timed, now).unwrap();
            let s = brd.status(&[], now).unwrap();
            let span = |name: &str| {
                let a = s.iter().find(|a| a.axis == name).unwrap();
                host_ns(a.move_end.unwrap() - a.move_start.unwrap(), b.ppm)
            };
            took.push([span("solar"), span("sidereal"), span("lunar"), 0.0]);
        }
        // mid-move, the same host times give the same positions (sync group, phase move)
        for k in 1..20 {
            let at = start + k * S / 2 + 123_457;
            for axis in ["solar", "sidereal", "lunar"] {
                let a = boards[0].position(axis, at);
                let b = boards[1].position(axis, at);
                if correct {
                    assert!((a - b).abs() <= 1, "{axis} at {k}/2 s: {a} vs {b}");
                }
            }
        }
        // then a limits move of 20,000 steps on each, once the group is done
        let later = start + 60 * S;
        for (b, t) in boards.iter_mut().zip(&mut took) {
            let now = tick(later, b.ppm);
            let target = [("sidereal".to_string(), Amount::Steps(20_000))];
            b.board
                .group_move(&target, false, false, &MoveOpts::default(), now)
                .unwrap();
            let s = &b.board.status(&["sidereal".into()], now).unwrap()[0];
            t[3] = host_ns(s.move_end.unwrap() - s.move_start.unwrap(), b.ppm);
            // a sync group scaled to its axes' limits: its phases, rounded to whole ticks
            // on the corrected clock, still keep every peak within them
            let group = [
                ("solar".to_string(), Amount::Steps(-2_000)),
                ("lunar".to_string(), Amount::Steps(-1_000)),
            ];
            let opts = MoveOpts::default();
            b.board.group_move(&group, false, true, &opts, now).unwrap();
        }
        // the limits moves, mid-move: the same host times give the same positions
        for k in 1..20 {
            let at = later + k * S / 2 + 123_457;
            let a = boards[0].position("sidereal", at);
            let b = boards[1].position("sidereal", at);
            if correct {
                assert!((a - b).abs() <= 1, "limits move at {k}/2 s: {a} vs {b}");
            }
        }
        let want_solar = nominal(2_000, phases);
        let want_limits = nominal(20_000, limits);
        for (j, b) in boards.iter().enumerate() {
            let [solar, sidereal, lunar, lim] = took[j];
            let fit = b.board.clock_state().applied_ppm - b.ppm as f64;
            let crystal = -(b.ppm as f64) * 1e-6;
            println!(
                "board at {:+} ppm, correction {correct}: 2/6/2 s move {:+.3} µs, sync group \
                 {:.6} s (axes {:+.3} µs apart), limits move {:+.3} µs from a true clock's",
                b.ppm,
                (solar - want_solar) / 1e3,
                sidereal / 1e9,
                (sidereal - lunar) / 1e3,
                (lim - want_limits) / 1e3,
            );
            // a sync group's axes finish on the same tick
            assert!((sidereal - lunar).abs() < 1.0, "{sidereal} vs {lunar}");
            // the limits move: on host time but for the fit's error and the clock's
            // rounding to the whole Hz; uncorrected, at its limits on the crystal
            let off = lim - want_limits;
            if correct {
                assert!(
                    (off - want_limits * fit * 1e-6).abs() <= 500.0,
                    "limits: {off} ns, fit {fit}"
                );
                assert!(off.abs() <= want_limits * 0.5e-6, "limits: {off} ns");
            } else {
                assert!(
                    (off - want_limits * crystal).abs() <= 1_000.0,
                    "limits: {off} ns"
                );
            }
            let off = solar - want_solar;
            if correct {
                // what is left is the fit's error and the rounding to whole ticks
                assert!(
                    (off - want_solar * fit * 1e-6).abs() <= 100.0,
                    "{off} ns, fit {fit}"
                );
                assert!(off.abs() <= want_solar * 0.5e-6, "{off} ns");
            } else {
                assert!((off - want_solar * crystal).abs() <= 100.0, "{off} ns");
            }
        }
        // the sync groups on the two boards: the same host time with the correction,
        // the crystals' 100 ppm apart without
        let apart = took[1][1] - took[0][1];
        if correct {
            assert!(apart.abs() <= took[0][1] * 1e-6, "{apart} ns");
        } else {
            assert!(
                (apart - took[0][1] * 100e-6).abs() <= took[0][1] * 1e-6,
                "{apart} ns"
            );
        }
    }
}
