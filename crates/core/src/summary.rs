//! What one planned move amounts to: its mode, duration, peaks and period range. The
//! command line's `plan --format json` and the Python package's `Plan.summary` are this
//! one type, so they always carry the same fields.

use crate::edges::EdgeGenerator;
use crate::profile::{Move, Order, Profile};
use core::borrow::Borrow;
use core::fmt;

/// The mode and family of a move, shown as `trapezoid (phases)`, `scurve (limits)` or
/// `segments (3)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MoveName {
    /// A phase-mode move of the named family.
    Phases(&'static str),
    /// A limits-mode move of the named family.
    Limits(&'static str),
    /// A chain of this many constant-acceleration segments.
    Segments(usize),
}

impl MoveName {
    /// The name of move `m`.
    pub fn of(m: &Move<'_>) -> MoveName {
        match m {
            Move::Phase(p) => MoveName::Phases(p.family.name()),
            Move::Segments(s) => MoveName::Segments(s.len()),
            Move::Limits(l) => MoveName::Limits(match l.order {
                Order::Trapezoid => "trapezoid",
                Order::SCurve => "scurve",
                Order::SCurve4 => "scurve4",
            }),
        }
    }
}

impl fmt::Display for MoveName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MoveName::Phases(fam) => write!(f, "{fam} (phases)"),
            MoveName::Limits(fam) => write!(f, "{fam} (limits)"),
            MoveName::Segments(n) => write!(f, "segments ({n})"),
        }
    }
}

#[cfg(feature = "serde")]
impl serde::Serialize for MoveName {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// A move's summary, found by running its whole edge stream (O(1) memory).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct PlanSummary {
    /// The move's mode and family.
    pub mode: MoveName,
    /// Steps in the move.
    pub steps: u64,
    /// The clock the edges are counted in (Hz).
    pub clock_hz: f64,
    /// The planned duration (s).
    pub duration_s: f64,
    /// The tick of the last step's edge.
    pub last_edge_tick: u64,
    /// The highest speed of the profile (steps/s).
    pub peak_speed_steps_per_s: f64,
    /// The largest |acceleration| of the profile (steps/s²).
    pub peak_accel_steps_per_s2: f64,
    /// The shortest interval between consecutive edges (ticks; the first from tick 0).
    pub min_period_ticks: u64,
    /// The longest interval between consecutive edges (ticks).
    pub max_period_ticks: u64,
    /// Edges settled in double-double because f64 could not decide the nearest tick.
    pub settled_edges: u64,
}

impl PlanSummary {
    /// Runs `gen` to its end from where it is and summarises the move: ramps at a few
    /// instructions per edge on top of the generator's, each constant-speed run in O(1)
    /// ([`EdgeGenerator::period_extremes`]).
    pub fn run<P: Borrow<Profile>>(mode: MoveName, gen: &mut EdgeGenerator<P>) -> PlanSummary {
        PlanSummary::run_in_parts(mode, gen, u64::MAX, |_| {})
    }

    /// [`run`](Self::run) in parts of at least `part` edges, calling `progress` with the
    /// steps done after each (a long move's summary can show how far it is).
    pub fn run_in_parts<P: Borrow<Profile>>(
        mode: MoveName,
        gen: &mut EdgeGenerator<P>,
        part: u64,
        mut progress: impl FnMut(u64),
    ) -> PlanSummary {
        let (vpk, apk) = gen.profile().peaks();
        let (steps, duration) = (gen.profile().steps(), gen.profile().duration());
        let (mut min_p, mut max_p, mut last) = (u64::MAX, 0, 0);
        if part == u64::MAX {
            // one pass, no loop around it (the ramp loop keeps its registers)
            if let Some(x) = gen.period_extremes(0) {
                (min_p, max_p, last) = x;
                progress(steps);
            }
        } else {
            while let Some((lo, hi, l)) = gen.period_extremes_for(last, part.max(1)) {
                (min_p, max_p, last) = (min_p.min(lo), max_p.max(hi), l);
                progress(steps - gen.remaining());
            }
        }
        PlanSummary {
            mode,
            steps,
            clock_hz: gen.clock(),
            duration_s: duration,
            last_edge_tick: last,
            peak_speed_steps_per_s: vpk,
            peak_accel_steps_per_s2: apk,
            min_period_ticks: min_p,
            max_period_ticks: max_p,
            settled_edges: gen.settled_count(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::MoveSpec;
    use crate::MoveParams;
    use crate::Segment;

    #[test]
    fn names_every_mode() {
        let segs = [
            Segment {
                v0: 0.0,
                duration: 0.1,
                steps: 50,
            },
            Segment {
                v0: 1000.0,
                duration: 0.1,
                steps: 100,
            },
        ];
        let cases = [
            (
                MoveSpec {
                    steps: Some(10),
                    params: MoveParams {
                        accel_time: Some(0.1),
                        ..MoveParams::default()
                    },
                    ..Default::default()
                },
                "trapezoid (phases)",
            ),
            (
                MoveSpec {
                    profile: Some("scurve"),
                    steps: Some(10),
                    params: MoveParams {
                        vmax: Some(100.0),
                        amax: Some(100.0),
                        jmax: Some(1000.0),
                        ..MoveParams::default()
                    },
                    ..Default::default()
                },
                "scurve (limits)",
            ),
            (
                MoveSpec {
                    segments: &segs,
                    ..Default::default()
                },
                "segments (2)",
            ),
        ];
        for (spec, want) in cases {
            let name = MoveName::of(&spec.resolve().unwrap());
            assert_eq!(std::format!("{name}"), want);
        }
    }

    #[test]
    fn summary_matches_the_edges() {
        let spec = MoveSpec {
            steps: Some(2400),
            params: MoveParams {
                accel_time: Some(0.02),
                cruise_time: Some(0.01),
                decel_time: Some(0.02),
                ..MoveParams::default()
            },
            ..Default::default()
        };
        let m = spec.resolve().unwrap();
        let mut gen = EdgeGenerator::new(spec.plan().unwrap(), 50e6).unwrap();
        let edges: std::vec::Vec<u64> = gen.clone().collect();
        let s = PlanSummary::run(MoveName::of(&m), &mut gen);
        assert_eq!(s.steps, 2400);
        assert_eq!(s.last_edge_tick, *edges.last().unwrap());
        let periods: std::vec::Vec<u64> = core::iter::once(edges[0])
            .chain(edges.windows(2).map(|w| w[1] - w[0]))
            .collect();
        assert_eq!(s.min_period_ticks, *periods.iter().min().unwrap());
        assert_eq!(s.max_period_ticks, *periods.iter().max().unwrap());
        assert_eq!(gen.next(), None);
    }

    /// In parts of any size the summary is the whole run's, and progress ends at every step.
    #[test]
    fn a_summary_in_parts_is_the_whole_runs() {
        let segs = [
            Segment {
                v0: 0.0,
                duration: 0.01,
                steps: 50,
            },
            Segment {
                v0: 10000.0,
                duration: 0.02,
                steps: 200,
            },
        ];
        let p = |family, a, b, c| {
            Move::Phase(crate::moves::PhaseMove {
                steps: 3000,
                accel_time: a,
                cruise_time: b,
                decel_time: c,
                start_speed: 0.0,
                end_speed: 0.0,
                family: crate::Family::parse(family, None, None, None).unwrap(),
            })
        };
        let moves = [
            p("trapezoid", 0.1, 0.2, 0.1),
            p("exponential", 0.1, 0.0, 0.2),
            p("sine", 0.05, 0.1, 0.05),
            p("scurve4", 0.1, 0.1, 0.1),
            Move::Segments(&segs),
        ];
        for m in moves {
            let gen = EdgeGenerator::new(Profile::plan(&m).unwrap(), 50e6).unwrap();
            let whole = PlanSummary::run(MoveName::of(&m), &mut gen.clone());
            for part in [0, 1, 7, 1000, u64::MAX] {
                let mut seen = std::vec::Vec::new();
                let s = PlanSummary::run_in_parts(MoveName::of(&m), &mut gen.clone(), part, |d| {
                    seen.push(d)
                });
                assert_eq!(s, whole, "{m:?}, parts of {part}");
                assert_eq!(seen.last(), Some(&whole.steps), "{m:?}, parts of {part}");
                assert!(
                    seen.windows(2).all(|w| w[0] < w[1]),
                    "progress goes forward"
                );
                // a ramp goes in parts; a constant-speed run counts whole
                if part == 7 && whole.steps == 3000 {
                    assert!(seen.len() > 100, "{m:?}: {} parts", seen.len());
                }
            }
        }
    }
}
