//! Per-axis settings, state and the status a client sees.

mod decimal;
mod status;

use crate::error::CtlError;
use serde::{Deserialize, Serialize};
pub use status::*;

/// Everything a user may set on one axis (protocol `set AXIS KEY VALUE`, board config,
/// persisted in the store). Positions and distances are in microsteps.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AxisSettings {
    /// Driver microsteps per full step (informational: all counts are microsteps).
    pub microsteps: u32,
    /// Microsteps per user unit (degrees, mm, …): `moveto X 12.5u`.
    pub steps_per_unit: f64,
    /// Default profile family for moves on this axis.
    pub profile: String,
    /// Default limits (steps/s, steps/s², steps/s³, steps/s⁴); also the ceiling for any move.
    pub vmax: f64,
    pub amax: f64,
    pub jmax: Option<f64>,
    pub smax: Option<f64>,
    /// Soft limits on the counted position (non-periodic axes only).
    pub soft_min: Option<i64>,
    pub soft_max: Option<i64>,
    /// Periodic axis: its period in microsteps (seed 002: a wave plate repeats every 90°).
    pub period: Option<u64>,
    /// Play between motor and load (microsteps): a move that reverses turns the motor this
    /// much further, in the same profile, before the load follows (docs/PROTOCOL.md,
    /// "Backlash").
    pub backlash: u64,
    /// Counted position given to the sensor edge by homing.
    pub home_offset: i64,
    /// Homing direction: -1 or +1.
    pub home_dir: i8,
    /// Hall-sensor debounce: a level must hold this long (s) to count.
    pub debounce: f64,
    /// Homing seek speed (steps/s).
    pub home_speed: f64,
    /// Homing slow re-approach speed (steps/s); clamped to one microstep per 2 debounce times.
    pub home_slow_speed: f64,
    /// Homing back-off distance past the edge (microsteps).
    pub home_backoff: u64,
    /// Homing gives up after this many microsteps without finding the sensor.
    pub home_search: u64,
    /// Flip the DIR line level (wiring); the count direction is unchanged.
    pub invert_dir: bool,
    /// Level of the ENABLE line that energizes the driver (false: active low, the usual).
    pub enable_active_high: bool,
    /// Seconds the driver needs after being energized before the first step.
    pub enable_settle: f64,
    /// Seconds of rest after which the driver is released (`none`/`never`: held for ever).
    pub idle_release: Option<f64>,
    /// A released axis keeps its position (detent torque or a brake); otherwise releasing
    /// makes it untrusted, as it may be turned by hand.
    pub release_keeps_position: bool,
    /// The simulated axis: where its sensor is and how noisy it is.
    pub sim: SimSettings,
}

/// The simulated mechanics and Hall sensor of one axis.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimSettings {
    /// True (mechanical) position of the sensor edge met when moving in `home_dir`.
    pub sensor_at: i64,
    /// Width of the sensor's active window (microsteps).
    pub sensor_width: u64,
    /// Up to this many pairs of extra toggles after each real edge (contact bounce)…
    pub bounce_count: u32,
    /// …all within this time (s) of the edge.
    pub bounce_time: f64,
    /// Mean rate of noise glitches (1/s): the signal flips for a short time.
    pub glitch_rate: f64,
    /// Longest glitch (s).
    pub glitch_max: f64,
    /// Shortest quiet time between glitches (s).
    pub glitch_gap: f64,
    /// Seed of the glitch and bounce generator.
    pub seed: u64,
}

impl Default for SimSettings {
    fn default() -> Self {
        SimSettings {
            sensor_at: 0,
            sensor_width: 400,
            bounce_count: 0,
            bounce_time: 0.0002,
            glitch_rate: 0.0,
            glitch_max: 0.0005,
            glitch_gap: 0.005,
            seed: 1,
        }
    }
}

impl Default for AxisSettings {
    fn default() -> Self {
        AxisSettings {
            microsteps: 16,
            steps_per_unit: 1.0,
            profile: "trapezoid".into(),
            vmax: 4000.0,
            amax: 20000.0,
            jmax: None,
            smax: None,
            soft_min: None,
            soft_max: None,
            period: None,
            backlash: 0,
            home_offset: 0,
            home_dir: -1,
            debounce: 0.002,
            home_speed: 2000.0,
            home_slow_speed: 400.0,
            home_backoff: 200,
            home_search: 1_000_000,
            invert_dir: false,
            enable_active_high: false,
            enable_settle: 0.0,
            idle_release: None,
            release_keeps_position: false,
            sim: SimSettings::default(),
        }
    }
}

/// Largest position, distance or offset anywhere on a board (microsteps): ±10^15, well
/// inside what an f64 holds exactly, so unit conversions and sums never overflow an i64.
pub const MAX_POSITION: i64 = 1_000_000_000_000_000;

/// The allowed range of one numeric setting (inclusive at both ends).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    pub key: &'static str,
    pub min: f64,
    pub max: f64,
}

const P: f64 = MAX_POSITION as f64;

/// Every numeric setting and its range (docs/PROTOCOL.md lists the same table). The upper
/// bounds keep every command's work small: the simulation's cost per step, per sensor edge
/// and per second of motion is bounded by them.
pub const RANGES: &[Range] = &[
    Range {
        key: "microsteps",
        min: 1.0,
        max: 256.0,
    },
    Range {
        key: "steps_per_unit",
        min: 1e-6,
        max: 1e9,
    },
    Range {
        key: "vmax",
        min: 1e-3,
        max: 1e6,
    },
    Range {
        key: "amax",
        min: 1e-3,
        max: 1e9,
    },
    Range {
        key: "jmax",
        min: 1e-3,
        max: 1e13,
    },
    Range {
        key: "smax",
        min: 1e-3,
        max: 1e17,
    },
    Range {
        key: "soft_min",
        min: -P,
        max: P,
    },
    Range {
        key: "soft_max",
        min: -P,
        max: P,
    },
    Range {
        key: "period",
        min: 1.0,
        max: P,
    },
    Range {
        key: "backlash",
        min: 0.0,
        max: 1e6,
    },
    Range {
        key: "home_offset",
        min: -P,
        max: P,
    },
    Range {
        key: "home_dir",
        min: -1.0,
        max: 1.0,
    },
    Range {
        key: "debounce",
        min: 1e-6,
        max: 10.0,
    },
    Range {
        key: "home_speed",
        min: 1e-3,
        max: 1e6,
    },
    Range {
        key: "home_slow_speed",
        min: 1e-3,
        max: 1e6,
    },
    Range {
        key: "home_backoff",
        min: 1.0,
        max: 1e9,
    },
    Range {
        key: "home_search",
        min: 1.0,
        max: P,
    },
    Range {
        key: "enable_settle",
        min: 0.0,
        max: 10.0,
    },
    Range {
        key: "idle_release",
        min: 0.0,
        max: 86_400.0,
    },
    Range {
        key: "sim.sensor_at",
        min: -P,
        max: P,
    },
    Range {
        key: "sim.sensor_width",
        min: 1.0,
        max: P,
    },
    Range {
        key: "sim.bounce_count",
        min: 0.0,
        max: 100.0,
    },
    Range {
        key: "sim.bounce_time",
        min: 0.0,
        max: 1.0,
    },
    Range {
        key: "sim.glitch_rate",
        min: 0.0,
        max: 1e4,
    },
    Range {
        key: "sim.glitch_max",
        min: 0.0,
        max: 1.0,
    },
    Range {
        key: "sim.glitch_gap",
        min: 0.0,
        max: 3600.0,
    },
];

impl Range {
    pub fn contains(&self, v: f64) -> bool {
        v.is_finite() && v >= self.min && v <= self.max
    }
}

/// A number as the docs print it: integers without a fraction, big ones in e-notation.
pub fn show_bound(v: f64) -> String {
    if v.abs() >= 1e7 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

impl AxisSettings {
    /// The numeric settings by key, `None` for an unset optional one.
    fn numbers(&self) -> Vec<(&'static str, Option<f64>)> {
        let s = &self.sim;
        vec![
            ("microsteps", Some(self.microsteps as f64)),
            ("steps_per_unit", Some(self.steps_per_unit)),
            ("vmax", Some(self.vmax)),
            ("amax", Some(self.amax)),
            ("jmax", self.jmax),
            ("smax", self.smax),
            ("soft_min", self.soft_min.map(|x| x as f64)),
            ("soft_max", self.soft_max.map(|x| x as f64)),
            ("period", self.period.map(|x| x as f64)),
            ("backlash", Some(self.backlash as f64)),
            ("home_offset", Some(self.home_offset as f64)),
            ("home_dir", Some(self.home_dir as f64)),
            ("debounce", Some(self.debounce)),
            ("home_speed", Some(self.home_speed)),
            ("home_slow_speed", Some(self.home_slow_speed)),
            ("home_backoff", Some(self.home_backoff as f64)),
            ("home_search", Some(self.home_search as f64)),
            ("enable_settle", Some(self.enable_settle)),
            ("idle_release", self.idle_release),
            ("sim.sensor_at", Some(s.sensor_at as f64)),
            ("sim.sensor_width", Some(s.sensor_width as f64)),
            ("sim.bounce_count", Some(s.bounce_count as f64)),
            ("sim.bounce_time", Some(s.bounce_time)),
            ("sim.glitch_rate", Some(s.glitch_rate)),
            ("sim.glitch_max", Some(s.glitch_max)),
            ("sim.glitch_gap", Some(s.glitch_gap)),
        ]
    }

    /// Checks every setting against its range and the values against each other.
    pub fn validate(&self) -> Result<(), CtlError> {
        let bad = |m: String| Err(CtlError::Setting(m));
        for (key, v) in self.numbers() {
            let Some(v) = v else { continue };
            let r = range_of(key);
            if !r.contains(v) {
                return bad(format!(
                    "{key} must be in [{}, {}] (got {})",
                    show_bound(r.min),
                    show_bound(r.max),
                    multistep_core::Num(v)
                ));
            }
        }
        if self.home_dir != 1 && self.home_dir != -1 {
            return bad(format!("home_dir must be -1 or 1 (got {})", self.home_dir));
        }
        if let (Some(lo), Some(hi)) = (self.soft_min, self.soft_max) {
            if lo > hi {
                return bad(format!("soft_min {lo} is above soft_max {hi}"));
            }
        }
        // a bad value of a setting, not a move that cannot be planned
        multistep_core::Family::parse(&self.profile, None, None, None)
            .map_err(|e| CtlError::Setting(format!("profile: {e}")))?;
        Ok(())
    }

    /// Brings every numeric setting into its range (values stored by an older build that
    /// checked less); returns one line per value changed.
    pub fn clamp_to_ranges(&mut self) -> Vec<String> {
        let mut notes = Vec::new();
        for (key, v) in self.numbers() {
            let Some(v) = v else { continue };
            let r = range_of(key);
            if r.contains(v) {
                continue;
            }
            let to = if v.is_nan() || v < r.min {
                r.min
            } else {
                r.max
            };
            let text = if to.fract() == 0.0 && to.abs() < 1e16 {
                format!("{}", to as i64)
            } else {
                format!("{to:e}")
            };
            if self.set_unchecked(key, &text).is_ok() {
                notes.push(format!(
                    "{key} {v} is outside [{}, {}]; using {text}",
                    show_bound(r.min),
                    show_bound(r.max)
                ));
            }
        }
        notes
    }

    /// `set` without the final check (clamping one value while others are still out).
    fn set_unchecked(&mut self, key: &str, value: &str) -> Result<(), CtlError> {
        let mut v = serde_json::to_value(&*self)?;
        let slot = lookup_mut(&mut v, key).ok_or_else(|| unknown_key(key))?;
        *slot = serde_json::from_str(value)?;
        *self = serde_json::from_value(v)?;
        Ok(())
    }

    /// The slow re-approach speed actually used: at most one microstep per two debounce
    /// times. The filter's edge is at most one glitch plus one debounce time (< 2 debounce)
    /// early, so at this speed it is less than one microstep off.
    pub fn effective_slow_speed(&self) -> f64 {
        self.home_slow_speed.min(0.5 / self.debounce)
    }

    /// Reads one setting as text (`get AXIS KEY`); keys are the field names, `sim.x` for sim.
    pub fn get(&self, key: &str) -> Result<String, CtlError> {
        let v = serde_json::to_value(self)?;
        let field = lookup(&v, key).ok_or_else(|| unknown_key(key))?;
        Ok(match field {
            serde_json::Value::String(s) => s.clone(),
            other => other.to_string(),
        })
    }

    /// Every setting as `key=value` (sim keys as `sim.key`), in a stable order.
    pub fn list(&self) -> Vec<String> {
        let v = serde_json::to_value(self).unwrap_or_default();
        let mut out = Vec::new();
        flatten("", &v, &mut out);
        out
    }

    /// Sets one setting from text, through serde so names and types have one definition.
    pub fn set(&mut self, key: &str, value: &str) -> Result<(), CtlError> {
        let mut v = serde_json::to_value(&*self)?;
        let slot = lookup_mut(&mut v, key).ok_or_else(|| unknown_key(key))?;
        // A group is set key by key: a whole object would reset every key it leaves out.
        if let Some(group) = slot.as_object() {
            let keys: Vec<String> = group.keys().map(|k| format!("{key}.{k}")).collect();
            return Err(CtlError::Setting(format!(
                "'{key}' is a group of settings; set one of {}",
                keys.join(", ")
            )));
        }
        *slot = match slot {
            serde_json::Value::String(_) => serde_json::Value::String(value.to_string()),
            _ if value == "none" || (key == "idle_release" && value == "never") => {
                serde_json::Value::Null
            }
            _ => serde_json::from_str(value).map_err(|_| {
                CtlError::Setting(format!("'{value}' is not a valid value for {key}"))
            })?,
        };
        let new: AxisSettings =
            serde_json::from_value(v).map_err(|e| CtlError::Setting(format!("{key}: {e}")))?;
        new.validate()?;
        *self = new;
        Ok(())
    }
}

fn range_of(key: &str) -> Range {
    *RANGES
        .iter()
        .find(|r| r.key == key)
        .expect("every numeric setting has a range")
}

fn unknown_key(key: &str) -> CtlError {
    CtlError::Setting(format!("unknown setting '{key}' (see 'get AXIS')"))
}

fn lookup<'v>(v: &'v serde_json::Value, key: &str) -> Option<&'v serde_json::Value> {
    key.split('.')
        .try_fold(v, |node, part| node.as_object()?.get(part))
}

fn lookup_mut<'v>(v: &'v mut serde_json::Value, key: &str) -> Option<&'v mut serde_json::Value> {
    key.split('.')
        .try_fold(v, |node, part| node.as_object_mut()?.get_mut(part))
}

fn flatten(prefix: &str, v: &serde_json::Value, out: &mut Vec<String>) {
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, x, out);
            }
        }
        serde_json::Value::String(s) => out.push(format!("{prefix}={s}")),
        serde_json::Value::Null => out.push(format!("{prefix}=none")),
        other => out.push(format!("{prefix}={other}")),
    }
}

/// Axis names: what can be typed in a terminal and split on ':' by the host client.
pub fn valid_axis_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 32
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        && !name.eq_ignore_ascii_case("ok")
        && !name.eq_ignore_ascii_case("all")
}

#[cfg(test)]
mod tests;
