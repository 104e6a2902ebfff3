//! The three ways of specifying a move (DESIGN.md §2): phase mode, segment mode and limits
//! mode, and the velocity-curve families.

use crate::error::{fraction, positive, PlanError, UnknownName};
use crate::shape::Shape;

/// Most pieces one profile holds (a fixed array: planning and generation never allocate).
pub const MAX_PIECES: usize = 64;
/// Most pieces a phase-mode or limits-mode move has: a 4th-order S-curve's 7 pieces up,
/// its cruise and 7 down.
pub const MAX_PHASE_PIECES: usize = 15;
/// Most steps one move may have: positions stay exact integers in f64 with room to spare.
pub const MAX_STEPS: u64 = 1 << 48;

/// A velocity-curve family (DESIGN.md §2 table).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Family {
    /// `g = u`: constant acceleration (seed 000 segments, seed 001).
    #[default]
    Trapezoid,
    /// `g = √u` (seed 001 eq. (9)–(15)).
    Parabolic,
    /// `g = (1 − e^(−u/ρ)) / (1 − e^(−1/ρ))` (seed 001; seed 003 eq. (2)).
    Exponential {
        /// Exponential ρ.
        rho: f64,
    },
    /// `g = (1 − cos πu)/2`.
    Sine,
    /// 3rd order: jerk +J, 0, −J (DESIGN.md §2).
    SCurve {
        /// S-curve φ.
        phi: f64,
    },
    /// 4th order, snap-limited and jerk-continuous (seed 003).
    SCurve4 {
        /// S-curve φ.
        phi: f64,
        /// scurve4 ψ.
        psi: f64,
    },
}

/// Default ρ of the exponential family.
pub const DEFAULT_RHO: f64 = 0.25;
/// Default φ of both S-curves.
pub const DEFAULT_PHI: f64 = 0.5;
/// Default ψ of scurve4.
pub const DEFAULT_PSI: f64 = 0.5;

impl Family {
    /// Every family's name, as [`Family::parse`] takes it.
    pub const NAMES: [&'static str; 6] = [
        "trapezoid",
        "parabolic",
        "exponential",
        "sine",
        "scurve",
        "scurve4",
    ];

    /// The family's name.
    pub fn name(&self) -> &'static str {
        match self {
            Family::Trapezoid => "trapezoid",
            Family::Parabolic => "parabolic",
            Family::Exponential { .. } => "exponential",
            Family::Sine => "sine",
            Family::SCurve { .. } => "scurve",
            Family::SCurve4 { .. } => "scurve4",
        }
    }

    /// Parses a family name with its optional shape parameters (defaults: ρ = 0.25, φ = ψ = ½).
    pub fn parse(
        name: &str,
        rho: Option<f64>,
        phi: Option<f64>,
        psi: Option<f64>,
    ) -> Result<Family, PlanError> {
        let phi_v = || fraction("phi", phi.unwrap_or(DEFAULT_PHI));
        Ok(match name {
            "trapezoid" => Family::Trapezoid,
            "parabolic" => Family::Parabolic,
            "sine" => Family::Sine,
            "exponential" => Family::Exponential {
                rho: positive("rho", rho.unwrap_or(DEFAULT_RHO))?,
            },
            "scurve" => Family::SCurve { phi: phi_v()? },
            "scurve4" => Family::SCurve4 {
                phi: phi_v()?,
                psi: fraction("psi", psi.unwrap_or(DEFAULT_PSI))?,
            },
            other => return Err(PlanError::UnknownFamily(UnknownName::new(other))),
        })
    }

    pub(crate) fn shape(&self) -> Option<Shape> {
        match *self {
            Family::Parabolic => Some(Shape::Parabolic),
            Family::Sine => Some(Shape::Sine),
            Family::Exponential { rho } => Some(Shape::Exponential { rho }),
            _ => None,
        }
    }

    /// `G(1) = ∫₀¹ g(u) du`.
    pub fn g1(&self) -> f64 {
        match self.shape() {
            Some(s) => s.g1(),
            // trapezoid and both S-curves have g(u) + g(1−u) = 1
            None => 0.5,
        }
    }
}

/// Phase mode: N steps in accel, cruise and decel times (the seeds' way).
///
/// `Default` is a trapezoid with no steps and no times: fill in what the move has,
/// `PhaseMove { steps: 2400, accel_time: 0.02, ..PhaseMove::default() }`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseMove {
    /// Steps of the move.
    pub steps: u64,
    /// Accel time Ta (s).
    pub accel_time: f64,
    /// Cruise time Tb (s).
    pub cruise_time: f64,
    /// Decel time Tc (s).
    pub decel_time: f64,
    /// Start speed (steps/s).
    pub start_speed: f64,
    /// End speed (steps/s).
    pub end_speed: f64,
    /// The velocity-curve family.
    pub family: Family,
}

/// One constant-acceleration segment of seed 000's register model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Start speed (steps/s).
    pub v0: f64,
    /// Duration (s).
    pub duration: f64,
    /// Steps covered.
    pub steps: u64,
}

/// The order of a limits-mode profile: which derivative is bounded last.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Order {
    /// vmax, amax.
    #[default]
    Trapezoid,
    /// vmax, amax, jmax.
    SCurve,
    /// vmax, amax, jmax, smax.
    SCurve4,
}

/// Limits mode: the time-optimal move of N steps under kinematic limits.
///
/// Built with [`LimitsMove::trapezoid`], [`LimitsMove::scurve`] or [`LimitsMove::scurve4`];
/// `Default` has no steps and no limits.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LimitsMove {
    /// Steps of the move.
    pub steps: u64,
    /// Which derivatives are limited.
    pub order: Order,
    /// Speed limit (steps/s).
    pub vmax: f64,
    /// Acceleration limit (steps/s²).
    pub amax: f64,
    /// Jerk limit (steps/s³; S-curves).
    pub jmax: Option<f64>,
    /// Snap limit (steps/s⁴; scurve4).
    pub smax: Option<f64>,
    /// Start speed (steps/s).
    pub start_speed: f64,
    /// End speed (steps/s).
    pub end_speed: f64,
}

impl PhaseMove {
    /// `steps` of `family` in these accel, cruise and decel times (s), from rest to rest.
    pub const fn new(steps: u64, family: Family, accel: f64, cruise: f64, decel: f64) -> Self {
        PhaseMove {
            steps,
            accel_time: accel,
            cruise_time: cruise,
            decel_time: decel,
            start_speed: 0.0,
            end_speed: 0.0,
            family,
        }
    }

    /// The same move starting at `start` and ending at `end` steps/s.
    pub const fn with_speeds(self, start: f64, end: f64) -> Self {
        PhaseMove {
            start_speed: start,
            end_speed: end,
            ..self
        }
    }
}

impl LimitsMove {
    /// A trapezoid from rest to rest: `n` steps under `vmax` (steps/s) and `amax` (steps/s²).
    pub const fn trapezoid(steps: u64, vmax: f64, amax: f64) -> Self {
        LimitsMove {
            steps,
            order: Order::Trapezoid,
            vmax,
            amax,
            jmax: None,
            smax: None,
            start_speed: 0.0,
            end_speed: 0.0,
        }
    }

    /// A jerk-limited S-curve from rest to rest (`jmax` in steps/s³).
    pub const fn scurve(steps: u64, vmax: f64, amax: f64, jmax: f64) -> Self {
        LimitsMove {
            order: Order::SCurve,
            jmax: Some(jmax),
            ..LimitsMove::trapezoid(steps, vmax, amax)
        }
    }

    /// A snap-limited 4th-order S-curve from rest to rest (`smax` in steps/s⁴).
    pub const fn scurve4(steps: u64, vmax: f64, amax: f64, jmax: f64, smax: f64) -> Self {
        LimitsMove {
            order: Order::SCurve4,
            jmax: Some(jmax),
            smax: Some(smax),
            ..LimitsMove::trapezoid(steps, vmax, amax)
        }
    }

    /// The same move starting at `start` and ending at `end` steps/s.
    pub const fn with_speeds(self, start: f64, end: f64) -> Self {
        LimitsMove {
            start_speed: start,
            end_speed: end,
            ..self
        }
    }
}

/// A move in any of the three modes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Move<'a> {
    /// Phase mode.
    Phase(PhaseMove),
    /// Segment mode.
    Segments(&'a [Segment]),
    /// Limits mode.
    Limits(LimitsMove),
}

/// A limits move of order `order` (0 trapezoid, 1 scurve, else scurve4) with its speeds
/// given as fractions of vmax: what the random-move tests draw.
#[cfg(test)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn limits_of_order(
    order: usize,
    steps: u64,
    [vmax, amax, jmax, smax]: [f64; 4],
    [vs, ve]: [f64; 2],
) -> LimitsMove {
    match order {
        0 => LimitsMove::trapezoid(steps, vmax, amax),
        1 => LimitsMove::scurve(steps, vmax, amax, jmax),
        _ => LimitsMove::scurve4(steps, vmax, amax, jmax, smax),
    }
    .with_speeds(vs * vmax, ve * vmax)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constructors_and_defaults_spell_the_same_moves() {
        let p = PhaseMove::new(2400, Family::Sine, 0.02, 0.01, 0.02).with_speeds(5.0, 6.0);
        let q = PhaseMove {
            steps: 2400,
            accel_time: 0.02,
            cruise_time: 0.01,
            decel_time: 0.02,
            start_speed: 5.0,
            end_speed: 6.0,
            family: Family::Sine,
        };
        assert_eq!(p, q);
        assert_eq!(PhaseMove::default().family, Family::Trapezoid);
        let l = LimitsMove::scurve4(100, 1e3, 1e4, 1e5, 1e6).with_speeds(1.0, 2.0);
        assert_eq!(
            (l.order, l.jmax, l.smax, l.start_speed, l.end_speed),
            (Order::SCurve4, Some(1e5), Some(1e6), 1.0, 2.0)
        );
        assert_eq!(
            LimitsMove {
                steps: 10,
                vmax: 1.0,
                amax: 2.0,
                ..LimitsMove::default()
            },
            LimitsMove::trapezoid(10, 1.0, 2.0)
        );
    }
}
