//! Every way a move can be malformed or infeasible. Library code returns these; it never
//! panics on user input.

use thiserror::Error;

#[derive(Clone, Debug, Error, PartialEq)]
/// Why a move cannot be planned.
pub enum PlanError {
    #[error("{name} must be a finite number (got {})", Num(*.value))]
    /// A value is NaN or infinite.
    NotFinite {
        /// Which value, as the command line names it.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    #[error("{name} must be greater than zero (got {})", Num(*.value))]
    /// A value that must be positive is not.
    NotPositive {
        /// Which value, as the command line names it.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    #[error("{name} must not be negative (got {})", Num(*.value))]
    /// A value that must not be negative is.
    Negative {
        /// Which value, as the command line names it.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    #[error("the move must have at least one step")]
    /// The move has no steps.
    NoSteps,
    #[error("{steps} steps is more than the {max} a move may have")]
    /// More steps than [`MAX_STEPS`](crate::MAX_STEPS).
    TooManySteps {
        /// Steps of the move.
        steps: u64,
        /// The most allowed.
        max: u64,
    },
    #[error("the phases add up to zero time: accel, cruise and decel time cannot all be 0")]
    /// The phases add up to zero time.
    ZeroDuration,
    #[error("{name} must be in (0, 0.5] (got {})", Num(*.value))]
    /// φ or ψ outside (0, ½].
    FractionOutOfRange {
        /// Which value, as the command line names it.
        name: &'static str,
        /// The value given.
        value: f64,
    },
    #[error(
        "the move cannot be done: {steps} steps are too few for a start speed of {} \
         and end speed of {} steps/s in these phase times (the cruise speed would be {:.6} steps/s)",
        Num(*.start_speed), Num(*.end_speed), Num(*.cruise_speed)
    )]
    /// Phase mode: too few steps for the start and end speeds in these times.
    CannotShed {
        /// Steps of the move.
        steps: u64,
        /// Start speed (steps/s).
        start_speed: f64,
        /// End speed (steps/s).
        end_speed: f64,
        /// The cruise speed these phase times would need (steps/s; negative).
        cruise_speed: f64,
    },
    #[error(
        "segment {index}: end speed 2n/T − v0 = {} steps/s is negative; the motor would reverse",
        Num(*.end_speed)
    )]
    /// Segment mode: a segment would end below zero speed.
    SegmentReverses {
        /// The segment (0-based).
        index: usize,
        /// End speed (steps/s).
        end_speed: f64,
    },
    #[error("a move may have at most {max} pieces ({what})")]
    /// More pieces than a profile holds.
    TooManyPieces {
        /// The most allowed.
        max: usize,
        /// What the pieces come from.
        what: &'static str,
    },
    #[error("{name} ({} steps/s) is above vmax ({} steps/s)", Num(*.value), Num(*.vmax))]
    /// Limits mode: a start or end speed above vmax.
    SpeedAboveLimit {
        /// Which value, as the command line names it.
        name: &'static str,
        /// The value given.
        value: f64,
        /// The speed limit (steps/s).
        vmax: f64,
    },
    #[error(
        "{steps} steps are too few to go from {} to {} steps/s within the \
         acceleration limits (needs at least {:.6} steps)",
        Num(*.start_speed), Num(*.end_speed), Num(*.needed)
    )]
    /// Limits mode: too few steps for the end speeds within the limits.
    TooShortForLimits {
        /// Steps of the move.
        steps: u64,
        /// Start speed (steps/s).
        start_speed: f64,
        /// End speed (steps/s).
        end_speed: f64,
        /// The fewest steps any move within the limits needs.
        needed: f64,
    },
    #[error("the {family} profile in limits mode needs {missing}")]
    /// Limits mode: an S-curve without its jerk (and snap) limit.
    MissingLimit {
        /// The family.
        family: &'static str,
        /// The limits it lacks.
        missing: &'static str,
    },
    #[error("limits mode supports trapezoid, scurve and scurve4, not {family}")]
    /// Limits mode for a family that has none.
    NoLimitsMode {
        /// The family.
        family: &'static str,
    },
    #[error("unknown profile family '{0}' (expected trapezoid, parabolic, exponential, sine, scurve or scurve4)")]
    /// A family name that is not one of [`Family::NAMES`](crate::Family::NAMES).
    UnknownFamily(UnknownName),
    #[error(
        "the move lasts {ticks:.3e} ticks at this clock; at most {max:.0} (2^50) are supported"
    )]
    /// The move is longer than [`MAX_TICKS`](crate::MAX_TICKS) at this clock.
    TooManyTicks {
        /// The move's length in ticks.
        ticks: f64,
        /// The most allowed.
        max: f64,
    },
    #[error("a move takes one of: phase times (accel/cruise/decel), limits (vmax/amax) or segments; {0}")]
    /// Values of more than one mode, or of none.
    AmbiguousMode(&'static str),
    #[error(
        "the planned pieces end at step {}, not on step {steps} (the move's values are \
         too far apart for f64)",
        Num(*.reached)
    )]
    /// The planned pieces do not end on step N (values too far apart for f64).
    MissesLastStep {
        /// Where the pieces end (steps).
        reached: f64,
        /// Steps of the move.
        steps: u64,
    },
    #[error(
        "the move peaks at {:.3} steps/s, faster than one step per tick of the {} Hz clock",
        Num(*.peak), Num(*.clock_hz)
    )]
    /// The move is faster than the clock: two steps would fall on one tick.
    FasterThanClock {
        /// The move's peak speed (steps/s).
        peak: f64,
        /// The clock (Hz).
        clock_hz: f64,
    },
    #[error(
        "the limits are too small for the move: its {steps} steps would take more than \
         {seconds:e} s (amax, jmax or smax is too small)"
    )]
    /// Limits mode: limits so small that the move would last beyond any clock's range.
    LimitsTooSmall {
        /// Steps of the move.
        steps: u64,
        /// The least time it would take (s).
        seconds: f64,
    },
    #[error("missing {0}")]
    /// A required value is missing.
    Missing(&'static str),
}

/// A family name that was not recognised (kept short and `Copy`-free of allocation).
#[derive(Clone, Debug, PartialEq)]
pub struct UnknownName {
    buf: [u8; 24],
    len: usize,
}

impl UnknownName {
    /// Keeps the first 24 bytes of `s` (whole characters).
    pub fn new(s: &str) -> Self {
        let mut buf = [0u8; 24];
        let mut len = 0;
        for c in s.chars() {
            let mut tmp = [0u8; 4];
            let enc = c.encode_utf8(&mut tmp);
            if len + enc.len() > buf.len() {
                break;
            }
            buf[len..len + enc.len()].copy_from_slice(enc.as_bytes());
            len += enc.len();
        }
        UnknownName { buf, len }
    }
    /// The name as given (truncated).
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(&self.buf[..self.len]).unwrap_or("?")
    }
}

impl core::fmt::Display for UnknownName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A number for messages: as is from 10⁻⁴ to 10¹⁵, in e-notation outside that range, so
/// 1e308 is not printed as 309 digits. A precision (`{:.3}`) is kept in both forms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Num(pub f64);

impl core::fmt::Display for Num {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let a = self.0.abs();
        let plain = a == 0.0 || !a.is_finite() || (1e-4..1e15).contains(&a);
        match (plain, f.precision()) {
            (true, Some(p)) => write!(f, "{:.*}", p, self.0),
            (true, None) => write!(f, "{}", self.0),
            (false, Some(p)) => write!(f, "{:.*e}", p, self.0),
            (false, None) => write!(f, "{:e}", self.0),
        }
    }
}

/// Checks that `value` is finite and > 0.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64, PlanError> {
    if !value.is_finite() {
        return Err(PlanError::NotFinite { name, value });
    }
    if value <= 0.0 {
        return Err(PlanError::NotPositive { name, value });
    }
    Ok(value)
}

/// Checks that `value` is finite and ≥ 0.
pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<f64, PlanError> {
    if !value.is_finite() {
        return Err(PlanError::NotFinite { name, value });
    }
    if value < 0.0 {
        return Err(PlanError::Negative { name, value });
    }
    Ok(value)
}

/// Checks a shape fraction φ or ψ in (0, ½].
pub(crate) fn fraction(name: &'static str, value: f64) -> Result<f64, PlanError> {
    if !(value > 0.0 && value <= 0.5) {
        return Err(PlanError::FractionOutOfRange { name, value });
    }
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::Num;

    #[test]
    fn numbers_in_messages_are_compact() {
        assert_eq!(format!("{}", Num(1e308)), "1e308");
        assert_eq!(format!("{}", Num(-2.5e-300)), "-2.5e-300");
        assert_eq!(format!("{:.3}", Num(1e308)), "1.000e308");
        assert_eq!(format!("{}", Num(5.9)), "5.9");
        assert_eq!(format!("{:.3}", Num(0.5)), "0.500");
        assert_eq!(format!("{}", Num(0.0)), "0");
        assert_eq!(format!("{}", Num(f64::INFINITY)), "inf");
        assert_eq!(format!("{}", Num(123456789012345.0)), "123456789012345");
    }
}
