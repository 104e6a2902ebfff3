//! Per-axis settings, state and the status a client sees.

use crate::error::CtlError;
use serde::{Deserialize, Serialize};

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

/// What an axis is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisState {
    Idle,
    Moving,
    Homing,
    /// Open-ended motion at a rate (`track`), until stopped.
    Tracking,
    Fault,
}

impl AxisState {
    pub fn name(self) -> &'static str {
        match self {
            AxisState::Idle => "idle",
            AxisState::Moving => "moving",
            AxisState::Homing => "homing",
            AxisState::Tracking => "tracking",
            AxisState::Fault => "fault",
        }
    }
}

/// One axis as a client sees it (`status json`, `multistep ctl status --json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AxisStatus {
    pub axis: String,
    /// The axis's 0-based number on its board (accepted wherever its name is).
    #[serde(default)]
    pub number: usize,
    /// Counted position (microsteps).
    pub position: i64,
    /// `position / steps_per_unit`.
    pub units: f64,
    pub state: AxisState,
    pub homed: bool,
    /// False whenever the count might differ from the mechanics.
    pub trusted: bool,
    /// Target of the move under way.
    pub target: Option<i64>,
    /// Commanded speed now (steps/s, signed).
    pub speed: f64,
    /// Debounced Hall-sensor level.
    pub sensor: bool,
    /// Motor minus load position (microsteps, 0 … `backlash`): `backlash` once the slack is
    /// taken up by a move forward, 0 once by a move backward.
    #[serde(default)]
    pub slack: i64,
    /// Counted minus expected position at the last pass over the sensor edge.
    pub drift: Option<i64>,
    /// Sensor passes checked during normal moves.
    pub drift_checks: u64,
    /// Tick (board clock) at which the last move started and ends.
    pub move_start: Option<u64>,
    pub move_end: Option<u64>,
    /// Why the axis is in fault.
    pub fault: Option<String>,
    /// The simulated mechanical position (simulation only; a real board cannot know it).
    pub sim_position: i64,
    /// Level of the DIR line for the last move: high for positive counts, unless
    /// `invert_dir` (wiring) flips it.
    pub dir_level: bool,
    /// The rate a tracking axis runs at or ramps towards (steps/s, signed; none otherwise).
    #[serde(default)]
    pub rate: Option<f64>,
    /// The board's crystal error as the host fitted it from readings of its tick counter
    /// (ppm), once it has; the same on every axis of the board.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock_ppm: Option<f64>,
    /// Tracking rates and phase-time moves are corrected by `clock_ppm`: they follow host
    /// time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock_fix: Option<bool>,
    /// The driver is energized.
    #[serde(default = "energized")]
    pub enabled: bool,
    /// Level of the ENABLE line (`enabled`, flipped unless `enable_active_high`).
    #[serde(default)]
    pub enable_level: bool,
    /// The board's store: `ok`, `failing` (writes fail) or `gone` (its file was deleted or
    /// replaced); the same on every axis.
    #[serde(default = "store_ok")]
    pub store: String,
    /// A board reached over a link (`serve --board-link`): whether it answers now. The
    /// rest of the line is the board as last read, `age_ms` ago.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub link: Option<Link>,
    /// Milliseconds since the board's registers shown were read (a board with a link).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub age_ms: Option<u64>,
}

/// The state of a board's link in `status` (`link=up|down`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Link {
    Up,
    Down,
}

impl Link {
    pub fn name(self) -> &'static str {
        match self {
            Link::Up => "up",
            Link::Down => "down",
        }
    }
}

fn store_ok() -> String {
    "ok".into()
}

fn energized() -> bool {
    true
}

impl AxisStatus {
    /// The one-line `key=value` form of the text protocol.
    pub fn line(&self) -> String {
        let mut s = String::with_capacity(160);
        self.write_line(&mut s);
        s
    }

    /// Appends [`AxisStatus::line`] to `out`, with no allocation of its own: a fault's
    /// spaces become `_` and its line breaks spaces here, where the text is produced, so
    /// the line never needs escaping again.
    pub fn write_line(&self, out: &mut String) {
        use std::fmt::Write;
        // writing into a String cannot fail
        out.push_str(&self.axis);
        let _ = write!(out, " pos={} units={}", self.position, self.units);
        out.push_str(" state=");
        out.push_str(self.state.name());
        flag(out, " homed=", self.homed);
        flag(out, " trusted=", self.trusted);
        out.push_str(" target=");
        opt(out, self.target);
        let _ = write!(out, " speed={:.1}", self.speed);
        flag(out, " sensor=", self.sensor);
        out.push_str(" drift=");
        opt(out, self.drift);
        out.push_str(" fault=");
        match &self.fault {
            Some(f) => escaped(out, f, '_'),
            None => out.push_str("none"),
        }
        out.push_str(" store=");
        escaped(out, &self.store, ' ');
        out.push_str(" rate=");
        match self.rate {
            Some(r) => {
                let _ = write!(out, "{r}");
            }
            None => out.push_str("none"),
        }
        // a board whose clock the host has fitted only: other boards' lines are as before
        if let Some(p) = self.clock_ppm {
            let _ = write!(out, " clock_ppm={p:.4}");
            flag(out, " clock_fix=", self.clock_fix.unwrap_or(false));
        }
        flag(out, " en=", self.enabled);
        let _ = write!(out, " num={}", self.number);
        // a board with a link only: other boards' lines are as before
        if let Some(l) = self.link {
            out.push_str(" link=");
            out.push_str(l.name());
        }
        if let Some(a) = self.age_ms {
            let _ = write!(out, " age_ms={a}");
        }
    }
}

fn flag(out: &mut String, key: &str, on: bool) {
    out.push_str(key);
    out.push(if on { '1' } else { '0' });
}

fn opt(out: &mut String, o: Option<i64>) {
    use std::fmt::Write;
    match o {
        Some(x) => {
            let _ = write!(out, "{x}");
        }
        None => out.push_str("none"),
    }
}

/// `text` with each line break as a space (as every data line of a reply) and each space
/// as `space`, copied a run at a time.
fn escaped(out: &mut String, text: &str, space: char) {
    let mut rest = text;
    while let Some(i) = rest.find([' ', '\n', '\r']) {
        out.push_str(&rest[..i]);
        out.push(if rest.as_bytes()[i] == b' ' {
            space
        } else {
            ' '
        });
        rest = &rest[i + 1..];
    }
    out.push_str(rest);
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
mod tests {
    use super::*;
    use crate::protocol::Reply;

    /// The line as it was first written: one `format!` and a replace per field, then the
    /// reply's replace of line breaks over the whole line.
    fn reference(s: &AxisStatus) -> String {
        let opt = |o: Option<i64>| o.map_or("none".to_string(), |x| x.to_string());
        format!(
            "{} pos={} units={} state={} homed={} trusted={} target={} speed={:.1} sensor={} drift={} fault={} store={} rate={} en={} num={}",
            s.axis, s.position, s.units, s.state.name(), s.homed as u8, s.trusted as u8,
            opt(s.target), s.speed, s.sensor as u8, opt(s.drift),
            s.fault.as_deref().unwrap_or("none").replace(' ', "_"), s.store,
            s.rate.map_or("none".to_string(), |r| r.to_string()), s.enabled as u8, s.number,
        )
        .replace(['\n', '\r'], " ")
    }

    #[test]
    fn the_status_line_is_the_reference_byte_for_byte() {
        let mut s = AxisStatus {
            axis: "X".into(),
            number: 3,
            position: -123_456,
            units: -1.2345678901234567,
            state: AxisState::Fault,
            homed: true,
            trusted: false,
            target: Some(99),
            speed: -2500.04999,
            sensor: true,
            slack: 0,
            drift: None,
            drift_checks: 0,
            move_start: None,
            move_end: None,
            fault: Some("stall at\n 12 \r\nsteps  ".into()),
            sim_position: 0,
            dir_level: false,
            rate: Some(1e-7),
            clock_ppm: None,
            clock_fix: None,
            enabled: false,
            enable_level: false,
            store: "fail ing\n".into(),
            link: None,
            age_ms: None,
        };
        let a = s.line();
        assert_eq!(a, reference(&s));
        assert!(
            a.contains("fault=stall_at _12_  steps__ store=fail ing  rate=0.0000001"),
            "{a}"
        );
        let text = Reply::ok(vec![a.clone()]).to_text();
        let a = a.as_str();
        assert_eq!(text, format!("{a}\nok\n"));
        (s.fault, s.rate, s.target, s.drift) = (None, None, None, Some(-4));
        assert_eq!(s.line(), reference(&s));
        let json = serde_json::to_string(&s).unwrap();
        assert!(!json.contains("link") && !json.contains("age_ms"), "{json}");
        // a board with a link: the two fields after the others, in both forms
        (s.link, s.age_ms) = (Some(Link::Down), Some(12));
        assert_eq!(s.line(), format!("{} link=down age_ms=12", reference(&s)));
        let json = serde_json::to_string(&s).unwrap();
        assert!(json.contains(r#""link":"down","age_ms":12"#), "{json}");
        assert_eq!(serde_json::from_str::<AxisStatus>(&json).unwrap(), s);
    }
}
