//! A move as named values — the command line's flags, the TDM config's keys and the
//! controller protocol's words all resolve through here, so there is one reading of them.

use crate::error::PlanError;
use crate::profile::{Family, LimitsMove, Move, Order, PhaseMove, Profile, Segment};

/// Every value a move can be given by name; `None` means "not given".
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MoveSpec<'a> {
    /// The family's name.
    pub profile: Option<&'a str>,
    /// Steps of the move.
    pub steps: Option<u64>,
    /// Accel time Ta (s).
    pub accel_time: Option<f64>,
    /// Cruise time Tb (s).
    pub cruise_time: Option<f64>,
    /// Decel time Tc (s).
    pub decel_time: Option<f64>,
    /// Start speed (steps/s).
    pub start_speed: Option<f64>,
    /// End speed (steps/s).
    pub end_speed: Option<f64>,
    /// Speed limit (steps/s).
    pub vmax: Option<f64>,
    /// Acceleration limit (steps/s²).
    pub amax: Option<f64>,
    /// Jerk limit (steps/s³; S-curves).
    pub jmax: Option<f64>,
    /// Snap limit (steps/s⁴; scurve4).
    pub smax: Option<f64>,
    /// Exponential ρ.
    pub rho: Option<f64>,
    /// S-curve φ.
    pub phi: Option<f64>,
    /// scurve4 ψ.
    pub psi: Option<f64>,
    /// Segment mode: the segments (give nothing else with them).
    pub segments: &'a [Segment],
}

impl<'a> MoveSpec<'a> {
    /// Decides the mode and checks that the values fit it.
    pub fn resolve(&self) -> Result<Move<'a>, PlanError> {
        let has_phase =
            self.accel_time.is_some() || self.cruise_time.is_some() || self.decel_time.is_some();
        let has_limits = self.vmax.is_some() || self.amax.is_some();
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
        let name = self.profile.unwrap_or("trapezoid");
        let family = Family::parse(name, self.rho, self.phi, self.psi)?;
        let start_speed = self.start_speed.unwrap_or(0.0);
        let end_speed = self.end_speed.unwrap_or(0.0);
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
                vmax: self.vmax.ok_or(PlanError::Missing("vmax"))?,
                amax: self.amax.ok_or(PlanError::Missing("amax"))?,
                jmax: self.jmax,
                smax: self.smax,
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
            accel_time: self.accel_time.unwrap_or(0.0),
            cruise_time: self.cruise_time.unwrap_or(0.0),
            decel_time: self.decel_time.unwrap_or(0.0),
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
