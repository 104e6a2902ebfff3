//! The move flags shared by every subcommand that takes a move (`plan`, `simulate`, …).

use clap::Args;
use multistep_core::{MoveName, MoveSpec, PlanError, Profile, Segment};

#[derive(Args, Clone, Debug, Default)]
pub struct MoveArgs {
    /// Profile family: trapezoid, parabolic, exponential, sine, scurve, scurve4
    #[arg(long, value_name = "FAMILY")]
    pub profile: Option<String>,
    /// Steps (microsteps) to move
    #[arg(long, value_name = "N")]
    pub steps: Option<u64>,
    /// Phase mode: acceleration time (s)
    #[arg(long, value_name = "S")]
    pub accel_time: Option<f64>,
    /// Phase mode: cruise time (s)
    #[arg(long, value_name = "S")]
    pub cruise_time: Option<f64>,
    /// Phase mode: deceleration time (s)
    #[arg(long, value_name = "S")]
    pub decel_time: Option<f64>,
    /// Start speed (steps/s)
    #[arg(long, value_name = "V")]
    pub start_speed: Option<f64>,
    /// End speed (steps/s)
    #[arg(long, value_name = "V")]
    pub end_speed: Option<f64>,
    /// Exponential time constant as a fraction of the phase time (default 0.25)
    #[arg(long, value_name = "R")]
    pub rho: Option<f64>,
    /// S-curve jerk fraction φ in (0, 0.5] (default 0.5)
    #[arg(long, value_name = "F")]
    pub phi: Option<f64>,
    /// 4th-order S-curve snap fraction ψ in (0, 0.5] (default 0.5)
    #[arg(long, value_name = "F")]
    pub psi: Option<f64>,
    /// Segment mode: a constant-acceleration segment V0:T:N (steps/s, s, steps); repeat
    #[arg(long = "segment", value_name = "V0:T:N", value_parser = parse_segment, allow_hyphen_values = true)]
    pub segments: Vec<Segment>,
    /// Limits mode: maximum speed (steps/s)
    #[arg(long, value_name = "V")]
    pub vmax: Option<f64>,
    /// Limits mode: maximum acceleration (steps/s²)
    #[arg(long, value_name = "A")]
    pub amax: Option<f64>,
    /// Limits mode: maximum jerk (steps/s³), scurve and scurve4
    #[arg(long, value_name = "J")]
    pub jmax: Option<f64>,
    /// Limits mode: maximum snap (steps/s⁴), scurve4
    #[arg(long, value_name = "S")]
    pub smax: Option<f64>,
}

pub fn parse_segment(s: &str) -> Result<Segment, String> {
    let parts: Vec<&str> = s.split(':').collect();
    if parts.len() != 3 {
        return Err(format!("'{s}' is not V0:T:N (start speed, time, steps)"));
    }
    let num = |x: &str, what: &str| {
        x.trim()
            .parse::<f64>()
            .map_err(|_| format!("segment '{s}': {what} '{x}' is not a number"))
    };
    let steps = parts[2]
        .trim()
        .parse::<u64>()
        .map_err(|_| format!("segment '{s}': steps '{}' is not a whole number", parts[2]))?;
    Ok(Segment {
        v0: num(parts[0], "start speed")?,
        duration: num(parts[1], "time")?,
        steps,
    })
}

impl MoveArgs {
    pub fn spec(&self) -> MoveSpec<'_> {
        MoveSpec {
            profile: self.profile.as_deref(),
            steps: self.steps,
            accel_time: self.accel_time,
            cruise_time: self.cruise_time,
            decel_time: self.decel_time,
            start_speed: self.start_speed,
            end_speed: self.end_speed,
            vmax: self.vmax,
            amax: self.amax,
            jmax: self.jmax,
            smax: self.smax,
            rho: self.rho,
            phi: self.phi,
            psi: self.psi,
            segments: &self.segments,
        }
    }

    /// The move as it plays on a clock of `clock_hz` ([`MoveSpec::plan_on_clock`]).
    pub fn plan(&self, clock_hz: f64) -> Result<Profile, PlanError> {
        self.spec().plan_on_clock(clock_hz)
    }

    /// A short name of the mode and family, for summaries: the core's [`MoveName`] (the
    /// error's text if the move does not resolve).
    pub fn describe(&self) -> String {
        self.spec()
            .resolve()
            .map(|m| MoveName::of(&m).to_string())
            .unwrap_or_else(|e| e.to_string())
    }
}
