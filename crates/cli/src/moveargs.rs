//! The move flags shared by every subcommand that takes a move (`plan`, `simulate`, …).

use clap::Args;
use multistep_core::{MoveName, MoveParams, MoveSpec, PlanError, Profile, Segment};

#[derive(Args, Clone, Debug, Default)]
pub struct MoveArgs {
    #[command(flatten)]
    pub shape: ShapeArgs,
    /// Steps (microsteps) to move
    #[arg(long, value_name = "N")]
    pub steps: Option<u64>,
    /// Segment mode: a constant-acceleration segment V0:T:N (steps/s, s, steps); repeat
    #[arg(long = "segment", value_name = "V0:T:N", value_parser = parse_segment, allow_hyphen_values = true)]
    pub segments: Vec<Segment>,
}

/// The family and its values, without the distance: also `ctl`'s move flags (its distance
/// is an argument).
#[derive(Args, Clone, Debug, Default)]
pub struct ShapeArgs {
    /// Profile family: trapezoid, parabolic, exponential, sine, scurve, scurve4
    #[arg(long, value_name = "FAMILY")]
    pub profile: Option<String>,
    // times, speeds, limits and shape fractions: the core's one list of them
    #[command(flatten)]
    pub params: MoveParams,
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
            profile: self.shape.profile.as_deref(),
            steps: self.steps,
            params: self.shape.params,
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
