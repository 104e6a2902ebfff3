//! One entry point per mode, as methods of [`Profile`].

use crate::error::PlanError;
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
        limits::plan_on_clock(m, clock_hz)
    }

    /// Any mode, with limits-mode trapezoids on whole ticks ([`Profile::limits_on_clock`]):
    /// what a move plays as on a clock of `clock_hz`.
    pub fn plan_on_clock(m: &Move<'_>, clock_hz: f64) -> Result<Profile, PlanError> {
        match m {
            Move::Limits(l) => Profile::limits_on_clock(l, clock_hz),
            other => Profile::plan(other),
        }
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
