//! One entry point per mode, as methods of [`Profile`].

use crate::builder::planned;
#[cfg(doc)]
use crate::edges::EdgeGenerator;
use crate::edges::{check_ticks, last_tick};
use crate::error::{positive, PlanError};
use crate::int::ExactMove;
use crate::limits;
use crate::moves::{LimitsMove, Move, Order, PhaseMove, Segment, MAX_PHASE_PIECES, MAX_PIECES};
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
        // planned into as few pieces as the move has (a profile is set up before planning)
        let (steps, duration) = match m {
            Move::Segments(_) => Profile::<MAX_PIECES>::steps_on_clock(m, clock)?,
            Move::Limits(l) => match l.order {
                // a phase trapezoid on whole ticks: accel, cruise, decel
                Order::Trapezoid => Profile::<3>::steps_on_clock(m, clock)?,
                // three pieces up, the cruise, three down
                Order::SCurve => Profile::<7>::steps_on_clock(m, clock)?,
                Order::SCurve4 => Profile::<MAX_PHASE_PIECES>::steps_on_clock(m, clock)?,
            },
            Move::Phase(_) => Profile::<MAX_PHASE_PIECES>::steps_on_clock(m, clock)?,
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
        planned(|p| p.plan_into(m))
    }

    /// [`Profile::plan_in`] into this profile's storage (its pieces unspecified on an error).
    fn plan_into(&mut self, m: &Move<'_>) -> Result<(), PlanError> {
        match m {
            Move::Phase(p) => phase::plan_into(p, self),
            Move::Segments(s) => phase::plan_segments_into(s, self),
            Move::Limits(l) => limits::plan_into(l, self),
        }
    }

    /// [`Profile::limits`] into `N` pieces.
    pub fn limits_in(m: &LimitsMove) -> Result<Self, PlanError> {
        limits::plan(m)
    }

    /// [`Profile::limits_in`] into this profile's storage, replacing its pieces, as a
    /// planner called once per move reuses one profile (Ruckig's `calculate` writes into a
    /// `Trajectory` it is given); no profile is set up or copied. On an error the profile
    /// is left with no pieces.
    pub fn replan_limits(&mut self, m: &LimitsMove) -> Result<(), PlanError> {
        limits::plan_into(m, self)
    }

    /// [`Profile::limits_on_clock`] into `N` pieces.
    pub fn limits_on_clock_in(m: &LimitsMove, clock_hz: f64) -> Result<Self, PlanError> {
        Self::plan_on_clock_in(&Move::Limits(*m), clock_hz)
    }

    /// [`Profile::plan_on_clock`] into `N` pieces.
    pub fn plan_on_clock_in(m: &Move<'_>, clock_hz: f64) -> Result<Self, PlanError> {
        let clock = positive("clock", clock_hz)?;
        planned(|p| p.on_clock_into(m, clock, true))
    }

    /// The steps and duration of `m` planned on a clock of `clock_hz` (> 0) into `N` pieces,
    /// its integer move not made.
    fn steps_on_clock(m: &Move<'_>, clock_hz: f64) -> Result<(u64, f64), PlanError> {
        let mut p = Self::empty();
        p.on_clock_into(m, clock_hz, false)?;
        Ok((p.steps, p.duration))
    }

    /// `m` on a clock of `clock_hz` (> 0) into this profile's storage, with its integer
    /// move if `keep_exact` (looked up without it only when the peak speed check needs it).
    fn on_clock_into(
        &mut self,
        m: &Move<'_>,
        clock_hz: f64,
        keep_exact: bool,
    ) -> Result<(), PlanError> {
        match m {
            Move::Limits(l) => limits::plan_on_clock_into(l, clock_hz, self)?,
            other => self.plan_into(other)?,
        };
        // a move the integer datapath plays keeps it: ties are settled on it exactly
        if keep_exact {
            self.exact = ExactMove::of(m, clock_hz, self);
        }
        // a limits move's speed stays within its pieces' rounding of vmax (far less than
        // 10⁻⁹ of it; the tests check 10⁻¹²): well below the clock it need not be found
        if matches!(m, Move::Limits(l) if l.vmax * (1.0 + 1e-9) < clock_hz) {
            return Ok(());
        }
        let p = &*self;
        let peak = p.peak_speed();
        // an integer limits move never exceeds its whole vmax, however f64 rounds the peak
        let at_most_vmax = || {
            matches!(m, Move::Limits(l) if l.vmax <= clock_hz)
                && (p.exact.is_some() || (!keep_exact && ExactMove::of(m, clock_hz, p).is_some()))
        };
        if !(peak <= clock_hz || at_most_vmax()) {
            return Err(PlanError::FasterThanClock { peak, clock_hz });
        }
        Ok(())
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

    #[test]
    fn replanning_one_profile_gives_each_moves_pieces_and_none_after_an_error() {
        let moves = [
            LimitsMove::scurve4(100_000, 2e4, 1e5, 1e6, 1e8).with_speeds(100.0, 50.0),
            LimitsMove::trapezoid(10, 2e4, 1e5), // a triangle: fewer pieces than before
            LimitsMove::trapezoid(10, -1.0, 1e5), // refused
            LimitsMove::scurve(100_000, 2e4, 1e5, 1e6),
            LimitsMove::trapezoid(100, 2e4, 1e5).with_speeds(2e4, 0.0),
            LimitsMove::trapezoid(1, 2e4, 1e5).with_speeds(2e4, 2e4), // too short to stop
            LimitsMove::trapezoid(100_000, 2e4, 1e5),
        ];
        let mut p = Profile::<MAX_PHASE_PIECES>::default();
        let mut planned = 0;
        for m in &moves {
            let fresh = Profile::<MAX_PHASE_PIECES>::limits_in(m);
            let again = p.replan_limits(m);
            match (&fresh, &again) {
                (Ok(f), Ok(())) => {
                    assert_eq!(&p, f, "{m:?}");
                    // the same bits in every used slot, whatever the slots held before
                    assert_eq!(p.resize::<MAX_PIECES>(), f.resize::<MAX_PIECES>());
                    assert_eq!(p.pieces().len(), f.len());
                    planned += 1;
                }
                (Err(a), Err(b)) => {
                    assert_eq!(a.to_string(), b.to_string());
                    assert_eq!(p, Profile::default(), "{m:?}");
                    assert_eq!(p.len(), 0);
                }
                _ => panic!("{m:?}: {fresh:?} against {again:?}"),
            }
        }
        assert_eq!(planned, 5);
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
}
