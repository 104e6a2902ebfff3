//! A move as named values — the command line's flags, the TDM config's keys and the
//! controller protocol's words all resolve through here, so there is one reading of them.

use crate::error::PlanError;
use crate::params::MoveParams;
use crate::profile::{Family, LimitsMove, Move, Order, PhaseMove, Profile, Segment};

/// A move by name; `None` means "not given".
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MoveSpec<'a> {
    /// The family's name.
    pub profile: Option<&'a str>,
    /// Steps of the move.
    pub steps: Option<u64>,
    /// Times, speeds, limits and shape fractions.
    pub params: MoveParams,
    /// Segment mode: the segments (give nothing else with them).
    pub segments: &'a [Segment],
}

impl<'a> MoveSpec<'a> {
    /// Decides the mode and checks that the values fit it.
    pub fn resolve(&self) -> Result<Move<'a>, PlanError> {
        let p = &self.params;
        let (has_phase, has_limits) = (p.has_phase_times(), p.has_limits());
        if !self.segments.is_empty() {
            if has_phase || has_limits || self.steps.is_some() || self.profile.is_some() {
                return Err(PlanError::AmbiguousMode(
                    "segments carry their own steps and times, give nothing else with them",
                ));
            }
            return Ok(Move::Segments(self.segments));
        }
        let steps = self
            .steps
            .ok_or(PlanError::Missing("the number of steps"))?;
        // the default family, trapezoid, takes no shape parameter
        let family = match self.profile {
            Some(name) => Family::parse(name, p.rho, p.phi, p.psi)?,
            None => Family::Trapezoid,
        };
        let start_speed = p.start_speed.unwrap_or(0.0);
        let end_speed = p.end_speed.unwrap_or(0.0);
        if has_limits {
            if has_phase {
                return Err(PlanError::AmbiguousMode("not both phase times and limits"));
            }
            let order = match family {
                Family::Trapezoid => Order::Trapezoid,
                Family::SCurve { .. } => Order::SCurve,
                Family::SCurve4 { .. } => Order::SCurve4,
                other => {
                    return Err(PlanError::NoLimitsMode {
                        family: other.name(),
                    })
                }
            };
            return Ok(Move::Limits(LimitsMove {
                steps,
                order,
                vmax: p.vmax.ok_or(PlanError::Missing("vmax"))?,
                amax: p.amax.ok_or(PlanError::Missing("amax"))?,
                jmax: p.jmax,
                smax: p.smax,
                start_speed,
                end_speed,
            }));
        }
        if !has_phase {
            return Err(PlanError::Missing(
                "phase times (accel/cruise/decel time) or limits (vmax, amax)",
            ));
        }
        Ok(Move::Phase(PhaseMove {
            steps,
            accel_time: p.accel_time.unwrap_or(0.0),
            cruise_time: p.cruise_time.unwrap_or(0.0),
            decel_time: p.decel_time.unwrap_or(0.0),
            start_speed,
            end_speed,
            family,
        }))
    }

    /// Resolves and plans the move (limits mode at ideal, not whole-tick, times).
    pub fn plan(&self) -> Result<Profile, PlanError> {
        Profile::plan(&self.resolve()?)
    }

    /// Resolves and plans the move as it plays on a clock of `clock_hz`
    /// ([`Profile::plan_on_clock`]).
    pub fn plan_on_clock(&self, clock_hz: f64) -> Result<Profile, PlanError> {
        Profile::plan_on_clock(&self.resolve()?, clock_hz)
    }
}
