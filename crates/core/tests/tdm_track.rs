//! Tracking axes in the TDM engine: open-ended axes (float and integer trackers) beside
//! axes running moves, rate changes and stops delivered while they run. Every tracking
//! axis's rises are its tracker's edges (a reference tracker given the same changes after
//! the same steps) shifted by the start tick, and every move's rises are its plan's.

use multistep_core::int::IntTracker;
use multistep_core::tdm::{Axis, Board, StepPulse, TdmConfig, TdmError, TrackCommand};
use multistep_core::{EdgeGenerator, LimitsMove, Move, Order, Profile, Rate, TrackLimits, Tracker};
use proptest::prelude::*;

const F: u64 = 50_000_000;

#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Kind {
    Move(Profile),
    Track {
        rate: Rate,
        amax: f64,
        start: f64,
        int: bool,
        /// S-curve ramps with this jmax.
        jmax: Option<f64>,
    },
}

fn limits(amax: f64, jmax: Option<f64>) -> TrackLimits {
    TrackLimits { amax, jmax }
}

fn axis(k: &Kind) -> Axis {
    match k {
        Kind::Move(p) => Axis::new(p.clone(), F as f64).unwrap(),
        Kind::Track {
            rate,
            amax,
            start,
            int: false,
            jmax,
        } => Axis::tracking(Tracker::new(F as f64, limits(*amax, *jmax), *start, *rate).unwrap())
            .unwrap(),
        Kind::Track {
            rate,
            amax,
            start,
            int: true,
            jmax,
        } => Axis::tracking_int(
            IntTracker::new(F as f64, limits(*amax, *jmax), *start, *rate).unwrap(),
        )
        .unwrap(),
    }
}

/// The reference edges of axis `m`: the plan's, or a fresh tracker's with each applied
/// command given after the steps the engine reports; as many as the engine emitted.
fn reference(k: &Kind, m: usize, commands: &[TrackCommand], n: usize) -> Vec<u64> {
    match k {
        Kind::Move(p) => EdgeGenerator::new(p.clone(), F as f64)
            .unwrap()
            .take(n)
            .collect(),
        Kind::Track {
            rate,
            amax,
            start,
            jmax,
            ..
        } => {
            let mut t = Tracker::new(F as f64, limits(*amax, *jmax), *start, *rate).unwrap();
            let mut out = Vec::new();
            let mut cs = commands
                .iter()
                .filter(|c| c.axis == m)
                .filter_map(|c| c.applied_after.map(|s| (s, c.rate)))
                .peekable();
            loop {
                while let Some((_, r)) = cs.next_if(|(s, _)| *s == out.len() as u64) {
                    t.set_rate(r).unwrap();
                }
                if out.len() == n {
                    break;
                }
                match t.next() {
                    Some(e) => out.push(e),
                    None => break,
                }
            }
            out
        }
    }
}

fn run_case(
    kinds: &[Kind],
    mut commands: Vec<TrackCommand>,
    until: u64,
    depth: usize,
) -> Result<(Vec<Vec<StepPulse>>, Vec<TrackCommand>), TestCaseError> {
    let mut axes: Vec<Axis> = kinds.iter().map(axis).collect();
    let cfg = TdmConfig {
        clock_hz: F as f64,
        fifo_depth: depth,
        ..TdmConfig::default()
    };
    let mut pulses = vec![Vec::new(); axes.len()];
    let r = Board::new(cfg, &mut axes)
        .unwrap()
        .run_tracking(until, &mut commands, |p| pulses[p.axis].push(p))
        .unwrap();
    prop_assert_eq!(r.underruns, 0, "the calculator keeps up in these cases");
    for (m, k) in kinds.iter().enumerate() {
        let got = &pulses[m];
        let want = reference(k, m, &commands, got.len());
        prop_assert_eq!(got.len(), want.len(), "axis {}", m);
        for (j, (p, e)) in got.iter().zip(&want).enumerate() {
            prop_assert_eq!(p.step, j as u64 + 1);
            prop_assert_eq!(p.rise - r.start_tick, *e, "axis {} step {}", m, j + 1);
        }
        if let Kind::Move(p) = k {
            // a move ends within the horizon here: every step
            prop_assert_eq!(got.len() as u64, p.steps());
        }
    }
    Ok((pulses, commands))
}

fn a_move(steps: u64, vmax: f64) -> Profile {
    Profile::plan(&Move::Limits(LimitsMove {
        steps,
        order: Order::Trapezoid,
        vmax,
        amax: vmax * 4.0,
        jmax: None,
        smax: None,
        start_speed: 0.0,
        end_speed: 0.0,
    }))
    .unwrap()
}

/// A random exact rate between 1 and 2·10⁴ steps/s with a denominator up to 2^20.
fn any_rate() -> impl Strategy<Value = Rate> {
    (1.0f64..2e4, 1u128..(1 << 20))
        .prop_map(|(r, den)| Rate::new(((r * den as f64) as u128).max(1), den).unwrap())
}

fn any_kind() -> impl Strategy<Value = Kind> {
    prop_oneof![
        (1u64..3000, 100.0f64..2e4).prop_map(|(n, v)| Kind::Move(a_move(n, v))),
        (
            any_rate(),
            1.0f64..50.0,
            0.0f64..1.5,
            any::<bool>(),
            prop::option::of(2.0f64..100.0)
        )
            .prop_map(|(rate, ax, s, int, jx)| {
                let amax = rate.to_f64() * ax;
                Kind::Track {
                    amax,
                    start: s * rate.to_f64(),
                    rate,
                    int,
                    jmax: jx.map(|j| j * amax),
                }
            }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// Random mixes of moves and tracking axes, random changes and stops: every axis's
    /// edges are its source's.
    #[test]
    fn tracking_and_moving_axes_emit_their_sources_edges(
        kinds in prop::collection::vec(any_kind(), 1..6),
        cmds in prop::collection::vec((0u64..3 * F, 0usize..6, prop::option::of(any_rate())), 0..6),
        depth in 1usize..5,
    ) {
        let tracking: Vec<usize> = (0..kinds.len())
            .filter(|&m| matches!(kinds[m], Kind::Track { .. }))
            .collect();
        let mut commands: Vec<TrackCommand> = cmds
            .iter()
            .filter(|_| !tracking.is_empty())
            .map(|&(t, m, r)| TrackCommand::new(t, tracking[m % tracking.len()], r.unwrap_or(Rate::ZERO)))
            .collect();
        commands.sort_by_key(|c| c.tick);
        // past every move's end and every command
        let longest = kinds.iter().map(|k| match k {
            Kind::Move(p) => p.duration(),
            _ => 0.0,
        }).fold(0.0, f64::max);
        let given = commands.len();
        let (_, commands) = run_case(&kinds, commands, ((longest + 3.5) * F as f64) as u64, depth)?;
        // every command reaches its axis unless that axis had stopped already
        let stops = commands.iter().filter(|c| c.rate.is_zero()).count();
        prop_assert!(stops > 0 || commands.iter().all(|c| c.applied_after.is_some()));
        prop_assert_eq!(commands.len(), given);
    }
}

/// 15041/324 steps/s from rest (the sidereal rate on 4·10⁶ microsteps a turn), integer.
fn sidereal_from_rest() -> Kind {
    Kind::Track {
        rate: Rate::new(15041, 324).unwrap(),
        amax: 200.0,
        start: 0.0,
        int: true,
        jmax: None,
    }
}

#[test]
fn a_stop_ends_a_tracking_axis_and_commands_are_checked() {
    let rate = Rate::new(15041, 324).unwrap();
    let kinds = [
        sidereal_from_rest(),
        Kind::Move(a_move(500, 1000.0)),
        Kind::Track {
            rate: Rate::new(1000, 1).unwrap(),
            amax: 5000.0,
            start: 0.0,
            int: false,
            jmax: None,
        },
    ];
    let commands = vec![
        TrackCommand::new(F, 2, Rate::new(3000, 1).unwrap()),
        TrackCommand::new(2 * F, 0, Rate::ZERO),
        TrackCommand::new(3 * F, 2, Rate::ZERO),
    ];
    let (pulses, commands) = run_case(&kinds, commands, 10 * F, 2).unwrap();
    assert!(commands
        .iter()
        .all(|c| c.applied_after.is_some() && c.refused.is_none()));
    // both trackers stopped well before the horizon: their last pulses are the stops'
    assert!(pulses[0].last().unwrap().rise < 3 * F);
    assert!(pulses[2].last().unwrap().rise < 4 * F);
    assert!(pulses[2].len() > 1000 + 3000);

    // a command for a move, or out of order, is refused before the run
    let mut axes: Vec<Axis> = kinds.iter().map(axis).collect();
    let board = Board::new(TdmConfig::default(), &mut axes).unwrap();
    let mut bad = [TrackCommand::new(0, 1, rate)];
    assert_eq!(
        board.run_tracking(F, &mut bad, |_| {}).err(),
        Some(TdmError::NotTracking { axis: 1 })
    );
    let board = Board::new(TdmConfig::default(), &mut axes).unwrap();
    let mut unordered = [TrackCommand::new(5, 0, rate), TrackCommand::new(4, 0, rate)];
    assert_eq!(
        board.run_tracking(F, &mut unordered, |_| {}).err(),
        Some(TdmError::CommandOrder)
    );
}

/// Integer trackers with S-curve ramps in the engine: the sidereal rate from rest, a
/// change to a faster rate, one during that ramp (applied at its end) and a stop, beside
/// a float S-curve tracker and a move; every rise is the float tracker's edge.
#[test]
fn scurve_int_trackers_in_the_engine() {
    let scurve = |rate, amax, int| Kind::Track {
        rate,
        amax,
        start: 0.0,
        int,
        jmax: Some(amax * 10.0),
    };
    let kinds = [
        scurve(Rate::new(15041, 324).unwrap(), 200.0, true),
        scurve(Rate::new(319_999, 10).unwrap(), 64_000.0, true),
        scurve(Rate::new(1000, 1).unwrap(), 5000.0, false),
        Kind::Move(a_move(2000, 5000.0)),
    ];
    let commands = vec![
        TrackCommand::new(F, 0, Rate::new(30082, 324).unwrap()),
        TrackCommand::new(F + F / 10, 0, Rate::new(10_000, 7).unwrap()),
        TrackCommand::new(2 * F, 1, Rate::new(12_345, 1).unwrap()),
        TrackCommand::new(5 * F, 0, Rate::ZERO),
        TrackCommand::new(5 * F, 1, Rate::ZERO),
    ];
    let (pulses, commands) = run_case(&kinds, commands, 24 * F, 2).unwrap();
    assert!(commands
        .iter()
        .all(|c| c.applied_after.is_some() && c.refused.is_none()));
    assert!(pulses[0].len() > 1000 && pulses[1].len() > 50_000);
    // both integer axes stopped before the horizon (the stop waits for the ramp to 10⁴/7
    // steps/s, which ends near 8.5 s; from there at 200 steps/s² about 7.5 s)
    assert!(pulses[0].last().unwrap().rise < 20 * F);
    assert!(pulses[1].last().unwrap().rise < 7 * F);
}

/// An axis tracking the sidereal rate for 24 simulated hours beside a move: the
/// engine's edges are the integer tracker's, which are the float tracker's.
#[test]
fn sidereal_day_in_the_engine() {
    let kinds = [sidereal_from_rest(), Kind::Move(a_move(2000, 5000.0))];
    let (pulses, _) = run_case(&kinds, Vec::new(), 24 * 3600 * F, 1).unwrap();
    assert!(pulses[0].len() > 4_000_000);
}

/// `Board::run` ends with the last move: a tracking axis beside it is cut there (its edges
/// so far its tracker's), and a board of tracking axes alone returns at once.
#[test]
fn run_ends_with_the_last_move() {
    let mv = a_move(1000, 4000.0);
    let kinds = [sidereal_from_rest(), Kind::Move(mv.clone())];
    let mut axes: Vec<Axis> = kinds.iter().map(axis).collect();
    let mut pulses = vec![Vec::new(); 2];
    let r = Board::new(TdmConfig::default(), &mut axes)
        .unwrap()
        .run(|p| pulses[p.axis].push(p));
    assert_eq!(pulses[1].len(), 1000);
    let end = pulses[1].last().unwrap().rise;
    let want = reference(&kinds[0], 0, &[], pulses[0].len());
    assert!(!want.is_empty());
    for (p, e) in pulses[0].iter().zip(&want) {
        assert_eq!(p.rise - r.start_tick, *e);
        assert!(p.rise <= end + 2 * F, "cut near the move's end");
    }
    let mut alone = [axis(&sidereal_from_rest())];
    let r = Board::new(TdmConfig::default(), &mut alone)
        .unwrap()
        .run(|_| {});
    assert_eq!(r.edges, 0);
}
