//! One entry point per mode, as methods of [`Profile`].

use crate::error::{positive, PlanError};
use crate::int::ExactMove;
use crate::limits;
use crate::moves::{LimitsMove, Move, PhaseMove, Segment};
use crate::phase;
use crate::profile::Profile;

impl Profile {
    /// Plans a move in any mode.
    pub fn plan(m: &Move<'_>) -> Result<Profile, PlanError> {
        match m {
            Move::Phase(p) => Profile::phase(p),
            Move::Segments(s) => Profile::segments(s),
            Move::Limits(l) => Profile::limits(l),
        }
    }

    /// Limits mode: the time-optimal move of its order that never exceeds a limit.
    pub fn limits(m: &LimitsMove) -> Result<Profile, PlanError> {
        limits::plan(m)
    }

    /// Limits mode on a clock of `clock_hz`: a trapezoid's accel, cruise and decel times are
    /// rounded up to whole ticks (so no limit is exceeded) and the cruise speed follows from
    /// N, exactly as the integer datapath ([`crate::int::IntProfile::limits`]) and the FPGA
    /// plan it, so all of them emit the same edges. S-curves are planned as [`Profile::limits`].
    pub fn limits_on_clock(m: &LimitsMove, clock_hz: f64) -> Result<Profile, PlanError> {
        let mut p = limits::plan_on_clock(m, clock_hz)?;
        // a move the integer datapath plays keeps it: ties are settled on it exactly
        p.exact = ExactMove::of(&Move::Limits(*m), clock_hz, &p);
        Ok(p)
    }

    /// Any mode, with limits-mode trapezoids on whole ticks ([`Profile::limits_on_clock`]):
    /// what a move plays as on a clock of `clock_hz`. A move faster than one step per tick
    /// is refused: at peak speed ≤ clock rate consecutive step times are at least a tick
    /// apart, so their nearest ticks are distinct; above it, steps would share a tick.
    /// A trapezoid with whole speeds and whole-tick times (limits mode: whole limits and
    /// speeds) plays the integer datapath's edges ([`crate::int`]), exact ties included.
    pub fn plan_on_clock(m: &Move<'_>, clock_hz: f64) -> Result<Profile, PlanError> {
        let clock_hz = positive("clock", clock_hz)?;
        let p = match m {
            Move::Limits(l) => Profile::limits_on_clock(l, clock_hz)?,
            other => {
                let mut p = Profile::plan(other)?;
                p.exact = ExactMove::of(other, clock_hz, &p);
                p
            }
        };
        let peak = p.peaks().0;
        // an integer limits move never exceeds its whole vmax, however f64 rounds the peak
        let at_most_vmax = matches!(m, Move::Limits(l) if p.exact.is_some() && l.vmax <= clock_hz);
        if !(peak <= clock_hz || at_most_vmax) {
            return Err(PlanError::FasterThanClock { peak, clock_hz });
        }
        Ok(p)
    }

    /// Phase mode: `vm` follows from N = vs·Ta + (vm−vs)·Ta·G1 + vm·Tb + ve·Tc + (vm−ve)·Tc·G1.
    pub fn phase(m: &PhaseMove) -> Result<Profile, PlanError> {
        phase::plan(m)
    }

    /// Segment mode (seed 000): each segment `(v0, T, n)` has `a = 2(n − v0·T)/T²`.
    pub fn segments(segs: &[Segment]) -> Result<Profile, PlanError> {
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
}
