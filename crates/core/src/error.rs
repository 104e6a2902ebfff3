//! Every way a move can be malformed or infeasible. Library code returns these; it never
//! panics on user input.

use thiserror::Error;

#[derive(Clone, Debug, Error, PartialEq)]
pub enum PlanError {
    #[error("{name} must be a finite number (got {value})")]
    NotFinite { name: &'static str, value: f64 },
    #[error("{name} must be greater than zero (got {value})")]
    NotPositive { name: &'static str, value: f64 },
    #[error("{name} must not be negative (got {value})")]
    Negative { name: &'static str, value: f64 },
    #[error("the move must have at least one step")]
    NoSteps,
    #[error("{steps} steps is more than the {max} a move may have")]
    TooManySteps { steps: u64, max: u64 },
    #[error("the phases add up to zero time: accel, cruise and decel time cannot all be 0")]
    ZeroDuration,
    #[error("{name} must be in (0, 0.5] (got {value})")]
    FractionOutOfRange { name: &'static str, value: f64 },
    #[error(
        "the move cannot be done: {steps} steps are too few for a start speed of {start_speed} \
         and end speed of {end_speed} steps/s in these phase times (the cruise speed would be {cruise_speed:.6} steps/s)"
    )]
    CannotShed {
        steps: u64,
        start_speed: f64,
        end_speed: f64,
        cruise_speed: f64,
    },
    #[error(
        "segment {index}: end speed 2n/T − v0 = {end_speed} steps/s is negative; the motor would reverse"
    )]
    SegmentReverses { index: usize, end_speed: f64 },
    #[error("a move may have at most {max} pieces ({what})")]
    TooManyPieces { max: usize, what: &'static str },
    #[error("{name} ({value} steps/s) is above vmax ({vmax} steps/s)")]
    SpeedAboveLimit {
        name: &'static str,
        value: f64,
        vmax: f64,
    },
    #[error(
        "{steps} steps are too few to go from {start_speed} to {end_speed} steps/s within the \
         acceleration limits (needs at least {needed:.6} steps)"
    )]
    TooShortForLimits {
        steps: u64,
        start_speed: f64,
        end_speed: f64,
        needed: f64,
    },
    #[error("the {family} profile in limits mode needs {missing}")]
    MissingLimit {
        family: &'static str,
        missing: &'static str,
    },
    #[error("limits mode supports trapezoid, scurve and scurve4, not {family}")]
    NoLimitsMode { family: &'static str },
    #[error("unknown profile family '{0}' (expected trapezoid, parabolic, exponential, sine, scurve or scurve4)")]
    UnknownFamily(UnknownName),
    #[error("the move lasts {ticks:.0} ticks at this clock; at most {max:.0} ticks are supported")]
    TooManyTicks { ticks: f64, max: f64 },
    #[error("a move takes one of: phase times (accel/cruise/decel), limits (vmax/amax) or segments; {0}")]
    AmbiguousMode(&'static str),
    #[error(
        "the planned pieces end at step {reached}, not on step {steps} (the move's values are \
         too far apart for f64)"
    )]
    MissesLastStep { reached: f64, steps: u64 },
    #[error("missing {0}")]
    Missing(&'static str),
}

/// A family name that was not recognised (kept short and `Copy`-free of allocation).
#[derive(Clone, Debug, PartialEq)]
pub struct UnknownName {
    buf: [u8; 24],
    len: usize,
}

impl UnknownName {
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
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(&self.buf[..self.len]).unwrap_or("?")
    }
}

impl core::fmt::Display for UnknownName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
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
