//! What an axis is doing and the status a client sees: its fields and its `status` line.

use super::decimal::{push_float, push_int, push_tenths};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

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
    pub store: Cow<'static, str>,
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

fn store_ok() -> Cow<'static, str> {
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
        out.push_str(&self.axis);
        out.push_str(" pos=");
        push_int(out, self.position);
        out.push_str(" units=");
        push_float(out, self.units);
        out.push_str(" state=");
        out.push_str(self.state.name());
        flag(out, " homed=", self.homed);
        flag(out, " trusted=", self.trusted);
        out.push_str(" target=");
        opt(out, self.target);
        out.push_str(" speed=");
        push_tenths(out, self.speed);
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
            Some(r) => push_float(out, r),
            None => out.push_str("none"),
        }
        // a board whose clock the host has fitted only: other boards' lines are as before
        if let Some(p) = self.clock_ppm {
            use std::fmt::Write;
            let _ = write!(out, " clock_ppm={p:.4}"); // writing into a String cannot fail
            flag(out, " clock_fix=", self.clock_fix.unwrap_or(false));
        }
        flag(out, " en=", self.enabled);
        out.push_str(" num=");
        push_int(out, self.number);
        // a board with a link only: other boards' lines are as before
        if let Some(l) = self.link {
            out.push_str(" link=");
            out.push_str(l.name());
        }
        if let Some(a) = self.age_ms {
            out.push_str(" age_ms=");
            push_int(out, a);
        }
    }
}

fn flag(out: &mut String, key: &str, on: bool) {
    out.push_str(key);
    out.push(if on { '1' } else { '0' });
}

fn opt(out: &mut String, o: Option<i64>) {
    match o {
        Some(x) => push_int(out, x),
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
