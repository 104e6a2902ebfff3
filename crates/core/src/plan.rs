//! One entry point per mode, as methods of [`Profile`].

#[cfg(doc)]
use crate::edges::EdgeGenerator;
use crate::edges::{check_ticks, last_tick};
use crate::error::{positive, PlanError};
use crate::int::ExactMove;
use crate::limits;
use crate::moves::{LimitsMove, Move, PhaseMove, Segment, MAX_PHASE_PIECES, MAX_PIECES};
use crate::phase;
use crate::profile::Profile;

impl Profile {
    /// Plans a move in any mode.
    pub fn plan(m: &Move<'_>) -> Result<Profile, PlanError> {
        Self::plan_in(m)
    }

    /// Limits mode: the time-optimal move of its order that never exceeds a limit.
    pub fn limits(m: &LimitsMove) -> Result<Profile, PlanError> {
        Self::limits_in(m)
    }

    /// Limits mode on a clock of `clock_hz`: a trapezoid's accel, cruise and decel times are
    /// rounded up to whole ticks (so no limit is exceeded) and the cruise speed follows from
    /// N, exactly as the integer datapath ([`crate::int::IntProfile::limits`]) and the FPGA
    /// plan it, so all of them emit the same edges. S-curves are planned as [`Profile::limits`].
    pub fn limits_on_clock(m: &LimitsMove, clock_hz: f64) -> Result<Profile, PlanError> {
        Self::limits_on_clock_in(m, clock_hz)
    }

    /// Any mode, with limits-mode trapezoids on whole ticks ([`Profile::limits_on_clock`]):
    /// what a move plays as on a clock of `clock_hz`. A move faster than one step per tick
    /// is refused: at peak speed ≤ clock rate consecutive step times are at least a tick
    /// apart, so their nearest ticks are distinct; above it, steps would share a tick.
    /// A trapezoid with whole speeds and whole-tick times (limits mode: whole limits and
    /// speeds) plays the integer datapath's edges ([`crate::int`]), exact ties included.
    pub fn plan_on_clock(m: &Move<'_>, clock_hz: f64) -> Result<Profile, PlanError> {
        Self::plan_on_clock_in(m, clock_hz)
    }

    /// Phase mode: `vm` follows from N = vs·Ta + (vm−vs)·Ta·G1 + vm·Tb + ve·Tc + (vm−ve)·Tc·G1.
    pub fn phase(m: &PhaseMove) -> Result<Profile, PlanError> {
        Self::phase_in(m)
    }

    /// Segment mode (seed 000): each segment `(v0, T, n)` has `a = 2(n − v0·T)/T²`.
    pub fn segments(segs: &[Segment]) -> Result<Profile, PlanError> {
        Self::segments_in(segs)
    }
}

/// What playing a move on a clock gives before its first edge
/// ([`Profile::check_on_clock`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockCheck {
    /// Steps of the move.
    pub steps: u64,
    /// Duration (s): the last step happens at it.
    pub duration: f64,
    /// The tick of the last step, `round(clock·duration)` ([`EdgeGenerator::last_edge_tick`]).
    pub last_edge_tick: u64,
}

impl Profile {
    /// The steps, duration and last edge tick of `m` planned on a clock of `clock_hz`
    /// ([`Profile::plan_on_clock`]) and played there ([`EdgeGenerator::new`]), with the
    /// error either gives, without keeping the pieces: a phase or limits move is planned
    /// into [`MAX_PHASE_PIECES`] pieces and its integer move (which only settles edges) is
    /// not made.
    pub fn check_on_clock(m: &Move<'_>, clock_hz: f64) -> Result<ClockCheck, PlanError> {
        let clock = positive("clock", clock_hz)?;
        let (steps, duration) = match m {
            Move::Segments(_) => {
                let p = Profile::<MAX_PIECES>::on_clock(m, clock, false)?;
                (p.steps, p.duration)
            }
            _ => {
                let p = Profile::<MAX_PHASE_PIECES>::on_clock(m, clock, false)?;
                (p.steps, p.duration)
            }
        };
        check_ticks(clock, duration)?;
        Ok(ClockCheck {
            steps,
            duration,
            last_edge_tick: last_tick(clock, duration),
        })
    }
}

/// The planners into a profile of `N` pieces: the same pieces, bit for bit, as the
/// full-size planners above; a move of more than `N` pieces is a
/// [`PlanError::TooManyPieces`].
impl<const N: usize> Profile<N> {
    /// [`Profile::plan`] into `N` pieces.
    pub fn plan_in(m: &Move<'_>) -> Result<Self, PlanError> {
        match m {
            Move::Phase(p) => Self::phase_in(p),
            Move::Segments(s) => Self::segments_in(s),
            Move::Limits(l) => Self::limits_in(l),
        }
    }

    /// [`Profile::limits`] into `N` pieces.
    pub fn limits_in(m: &LimitsMove) -> Result<Self, PlanError> {
        limits::plan(m)
    }

    /// [`Profile::limits_on_clock`] into `N` pieces.
    pub fn limits_on_clock_in(m: &LimitsMove, clock_hz: f64) -> Result<Self, PlanError> {
        Self::on_clock(&Move::Limits(*m), positive("clock", clock_hz)?, true)
    }

    /// [`Profile::plan_on_clock`] into `N` pieces.
    pub fn plan_on_clock_in(m: &Move<'_>, clock_hz: f64) -> Result<Self, PlanError> {
        Self::on_clock(m, positive("clock", clock_hz)?, true)
    }

    /// `m` on a clock of `clock_hz` (> 0), with its integer move if `keep_exact` (looked up
    /// without it only when the peak speed check needs it).
    fn on_clock(m: &Move<'_>, clock_hz: f64, keep_exact: bool) -> Result<Self, PlanError> {
        let mut p = match m {
            Move::Limits(l) => limits::plan_on_clock(l, clock_hz)?,
            other => Self::plan_in(other)?,
        };
        // a move the integer datapath plays keeps it: ties are settled on it exactly
        if keep_exact {
            p.exact = ExactMove::of(m, clock_hz, &p);
        }
        let peak = p.peaks().0;
        // an integer limits move never exceeds its whole vmax, however f64 rounds the peak
        let at_most_vmax = || {
            matches!(m, Move::Limits(l) if l.vmax <= clock_hz)
                && (p.exact.is_some() || (!keep_exact && ExactMove::of(m, clock_hz, &p).is_some()))
        };
        if !(peak <= clock_hz || at_most_vmax()) {
            return Err(PlanError::FasterThanClock { peak, clock_hz });
        }
        Ok(p)
    }

    /// [`Profile::phase`] into `N` pieces.
    pub fn phase_in(m: &PhaseMove) -> Result<Self, PlanError> {
        phase::plan(m)
    }

    /// [`Profile::segments`] into `N` pieces.
    pub fn segments_in(segs: &[Segment]) -> Result<Self, PlanError> {
        phase::plan_segments(segs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edges::EdgeGenerator;
    use crate::moves::LimitsMove;

    #[test]
    fn a_move_faster_than_its_clock_is_refused_and_one_at_it_is_not() {
        let m = Move::Limits(LimitsMove::trapezoid(1000, 1000.0, 10_000.0));
        for clock in [1.0, 0.5, 999.0] {
            match Profile::plan_on_clock(&m, clock) {
                Err(PlanError::FasterThanClock { peak, clock_hz }) => {
                    assert!(peak > clock_hz && clock_hz == clock)
                }
                other => panic!("{other:?}"),
            }
        }
        let p = Profile::plan_on_clock(&m, 1000.0).unwrap();
        let edges: Vec<u64> = EdgeGenerator::new(p, 1000.0).unwrap().collect();
        assert_eq!(edges.len(), 1000);
        assert!(edges.windows(2).all(|w| w[1] > w[0]), "steps share a tick");
        // phase mode too: 5 steps in 2e-300 s
        let fast = Move::Phase(PhaseMove {
            steps: 5,
            accel_time: 1e-300,
            cruise_time: 0.0,
            decel_time: 1e-300,
            start_speed: 0.0,
            end_speed: 0.0,
            family: crate::moves::Family::Trapezoid,
        });
        let e = Profile::plan_on_clock(&fast, 50e6).unwrap_err();
        assert!(matches!(e, PlanError::FasterThanClock { .. }), "{e}");
        assert!(Profile::plan_on_clock(&m, 0.0).is_err());
    }

    fn phase(steps: u64, family: crate::moves::Family) -> PhaseMove {
        PhaseMove::new(steps, family, 0.1, 0.2, 0.1)
    }

    #[test]
    fn planning_into_fewer_pieces_gives_the_same_pieces_or_too_many_pieces() {
        use crate::moves::Family;
        let limits = [
            LimitsMove::trapezoid(100_000, 2e4, 1e5),
            LimitsMove::trapezoid(10, 2e4, 1e5), // a triangle
            LimitsMove::scurve(100_000, 2e4, 1e5, 1e6),
            LimitsMove::scurve4(100_000, 2e4, 1e5, 1e6, 1e8).with_speeds(100.0, 50.0),
        ];
        let mut most = 0;
        for m in limits {
            let full = Profile::limits(&m).unwrap();
            let small = Profile::<MAX_PHASE_PIECES>::limits_in(&m).unwrap();
            // PartialEq compares every slot, the unused ones included
            assert_eq!(small.resize::<MAX_PIECES>().unwrap(), full, "{m:?}");
            most = most.max(full.len());
        }
        assert!(most > 7 && most <= MAX_PHASE_PIECES, "{most}");
        // a 4th-order S-curve in phase mode fills the bound: 7 pieces up, the cruise, 7 down
        let four = phase(
            10_000,
            Family::SCurve4 {
                phi: 0.3,
                psi: 0.25,
            },
        );
        let full = Profile::phase(&four).unwrap();
        assert_eq!(full.len(), MAX_PHASE_PIECES);
        let small = Profile::<MAX_PHASE_PIECES>::plan_in(&Move::Phase(four)).unwrap();
        assert_eq!(small.resize::<MAX_PIECES>().unwrap(), full);
        // one piece short: an error, not a panic
        assert!(matches!(
            Profile::<14>::phase_in(&four),
            Err(PlanError::TooManyPieces { max: 14, .. })
        ));
        assert!(matches!(
            full.resize::<14>(),
            Err(PlanError::TooManyPieces { max: 14, .. })
        ));
        let seg = Segment {
            v0: 0.0,
            duration: 0.1,
            steps: 5,
        };
        assert!(matches!(
            Profile::<2>::segments_in(&[seg; 3]),
            Err(PlanError::TooManyPieces { max: 2, .. })
        ));
        assert_eq!(Profile::<3>::segments_in(&[seg; 3]).unwrap().steps(), 15);
    }

    #[test]
    fn check_on_clock_is_what_planning_and_playing_give() {
        use crate::moves::Family;
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
        let moves = [
            Move::Limits(LimitsMove::trapezoid(100_000, 2e4, 1e5)),
            Move::Limits(LimitsMove::scurve(100_000, 2e4, 1e5, 1e6)),
            Move::Limits(LimitsMove::trapezoid(1000, 1000.0, 10_000.0)),
            Move::Phase(phase(10_000, Family::SCurve4 { phi: 0.3, psi: 0.5 })),
            Move::Phase(phase(10_000, Family::Sine)),
            Move::Segments(&segs),
        ];
        // 1000 Hz: the 1000 steps/s trapezoid runs at its clock, the others exceed it;
        // 1e15 Hz: the long moves exceed the generator's ticks
        for clock in [50e6, 1000.0, 999.0, 1e15, 0.0, f64::NAN] {
            for m in &moves {
                let full = Profile::plan_on_clock(m, clock)
                    .and_then(|p| EdgeGenerator::new(p, clock))
                    .map(|g| {
                        (
                            g.profile().steps(),
                            g.profile().duration(),
                            g.last_edge_tick(),
                        )
                    });
                let check = Profile::check_on_clock(m, clock)
                    .map(|c| (c.steps, c.duration, c.last_edge_tick));
                assert_eq!(
                    check.as_ref().map_err(|e| e.to_string()),
                    full.as_ref().map_err(|e| e.to_string()),
                    "{m:?} at {clock} Hz"
                );
            }
        }
        let e = Profile::check_on_clock(&moves[0], 1e15).unwrap_err();
        assert!(matches!(e, PlanError::TooManyTicks { .. }), "{e}");
        let e = Profile::check_on_clock(&moves[0], 999.0).unwrap_err();
        assert!(matches!(e, PlanError::FasterThanClock { .. }), "{e}");
    }
}
