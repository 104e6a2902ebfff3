//! The controller's domain values, as commands carry them and the board, the store and
//! the trackers take them: an amount to move, a move's options, a signed exact rate,
//! tracking's options. The line protocol (`crate::protocol`) reads and prints them.

use crate::error::CtlError;
use multistep_core::{
    Family, LimitsMove, MoveParams, Order, Param, PhaseMove, PlanError, Profile, PARAMS,
};
use serde::{Deserialize, Serialize};

/// A target or distance: microsteps, or user units with a `u` suffix (`12.5u`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Amount {
    Steps(i64),
    Units(f64),
}

/// Move options by name; anything not given comes from a preset, then the axis settings.
/// Stored presets are these as JSON, the values at the top level beside `preset`/`profile`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MoveOpts {
    pub preset: Option<String>,
    pub profile: Option<String>,
    /// Times, speeds, limits and shape fractions.
    #[serde(flatten)]
    pub params: MoveParams,
}

/// The protocol's short words for some values (`accel=` for `accel_time=`, …); every
/// value is also read by its full name ([`multistep_core::PARAMS`]), and printed short
/// where it has a short word.
const SHORT_WORDS: [(&str, &str); 5] = [
    ("accel", "accel_time"),
    ("cruise", "cruise_time"),
    ("decel", "decel_time"),
    ("vs", "start_speed"),
    ("ve", "end_speed"),
];

/// The value a protocol word names, by its short or full name.
pub fn param_of_word(key: &str) -> Option<&'static Param> {
    let full = SHORT_WORDS.iter().find(|w| w.0 == key).map_or(key, |w| w.1);
    Param::named(full)
}

/// Whether `word=…` on a move line is one of its options (`preset`, `profile`, a
/// value's word): an axis of that name could not be told apart in a group.
pub fn is_move_option(word: &str) -> bool {
    let w = word.to_ascii_lowercase();
    w == "preset" || w == "profile" || param_of_word(&w).is_some()
}

/// The word the protocol prints for a value: its short word, else its name.
pub fn word_of_param(p: &Param) -> &'static str {
    SHORT_WORDS
        .iter()
        .find(|w| w.1 == p.name)
        .map_or(p.name, |w| w.0)
}

impl MoveOpts {
    /// `self` where given, else `base`.
    pub fn over(&self, base: &MoveOpts) -> MoveOpts {
        MoveOpts {
            preset: self.preset.clone().or_else(|| base.preset.clone()),
            profile: self.profile.clone().or_else(|| base.profile.clone()),
            params: self.params.over(&base.params),
        }
    }

    pub fn has_phase_times(&self) -> bool {
        self.params.has_phase_times()
    }

    /// Reads one `key=value` word; false if the key is not a move option.
    pub(crate) fn set(&mut self, key: &str, value: &str) -> Result<bool, CtlError> {
        match key {
            "preset" => self.preset = Some(value.to_string()),
            "profile" => self.profile = Some(value.to_ascii_lowercase()),
            _ => {
                let Some(param) = param_of_word(key) else {
                    return Ok(false);
                };
                let x = value
                    .parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| CtlError::syntax(format!("{key}: '{value}' is not a number")))?;
                *(param.slot)(&mut self.params) = Some(x);
            }
        }
        Ok(true)
    }

    /// Checks every value given as a move checks it (the core's rules, `error:7`), so a
    /// preset never stores a value that every move using it would refuse. Whether the
    /// values suit a move together depends on the move, and is checked when one uses them.
    pub fn check_values(&self) -> Result<(), CtlError> {
        let p = &self.params;
        // Without a family the axis's applies: every family that reads rho, phi or psi.
        let families = match &self.profile {
            Some(f) => vec![f.as_str()],
            None => Family::NAMES.to_vec(),
        };
        for f in families {
            Family::parse(f, p.rho, p.phi, p.psi)?;
        }
        // One-step sample moves carry the values; the core checks each value before it
        // looks at how they combine, so only a value's own error is taken from them.
        let phase = PhaseMove {
            steps: 1,
            accel_time: p.accel_time.unwrap_or(1.0),
            cruise_time: p.cruise_time.unwrap_or(0.0),
            decel_time: p.decel_time.unwrap_or(0.0),
            start_speed: p.start_speed.unwrap_or(0.0),
            end_speed: p.end_speed.unwrap_or(0.0),
            family: Family::Trapezoid,
        };
        let limits = LimitsMove {
            steps: 1,
            order: Order::SCurve4,
            vmax: p.vmax.unwrap_or(1.0),
            amax: p.amax.unwrap_or(1.0),
            jmax: Some(p.jmax.unwrap_or(1.0)),
            smax: Some(p.smax.unwrap_or(1.0)),
            start_speed: 0.0,
            end_speed: 0.0,
        };
        for r in [Profile::phase(&phase), Profile::limits(&limits)] {
            if let Err(
                e @ (PlanError::NotFinite { .. }
                | PlanError::NotPositive { .. }
                | PlanError::Negative { .. }
                | PlanError::FractionOutOfRange { .. }),
            ) = r
            {
                return Err(e.into());
            }
        }
        Ok(())
    }

    /// The `key=value` words that give these options (for presets and the host client).
    pub fn words(&self) -> Vec<String> {
        let mut w = Vec::new();
        if let Some(p) = &self.preset {
            w.push(format!("preset={p}"));
        }
        if let Some(p) = &self.profile {
            w.push(format!("profile={p}"));
        }
        for p in PARAMS {
            if let Some(x) = p.get(&self.params) {
                // shortest exact form, in e-notation when huge or tiny (1e300, not 301 digits)
                w.push(format!("{}={}", word_of_param(p), multistep_core::Num(x)));
            }
        }
        w
    }
}

/// A tracking rate as typed: steps/s, or user units/s with `u`; negative reverses.
/// The magnitude is exact (a decimal or a fraction NUM/DEN, read by the core).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SignedRate {
    pub negative: bool,
    pub rate: multistep_core::Rate,
    pub units: bool,
}

impl SignedRate {
    /// `46.4`, `-15041/324`, `0.5u`; `None` when the word is not a number.
    pub fn parse(w: &str) -> Option<Result<SignedRate, CtlError>> {
        let (units, body) = match w.strip_suffix(['u', 'U']) {
            Some(b) => (true, b),
            None => (false, w),
        };
        let (negative, mag) = match body.strip_prefix('-') {
            Some(m) => (true, m),
            None => (false, body.strip_prefix('+').unwrap_or(body)),
        };
        let numeric = mag.starts_with(|c: char| c.is_ascii_digit() || c == '.');
        if !numeric {
            return None;
        }
        Some(
            multistep_core::Rate::parse(mag)
                .map(|rate| SignedRate {
                    negative: negative && !rate.is_zero(),
                    rate,
                    units,
                })
                .map_err(|e| CtlError::syntax(format!("'{w}': {e}"))),
        )
    }

    /// The signed value (steps/s or units/s) as the nearest f64.
    pub fn value(&self) -> f64 {
        let v = self.rate.to_f64();
        if self.negative {
            -v
        } else {
            v
        }
    }
}

impl std::fmt::Display for SignedRate {
    /// Reads back exactly: the reduced fraction (or the integer), sign and `u`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.negative {
            f.write_str("-")?;
        }
        if self.rate.den() == 1 {
            write!(f, "{}", self.rate.num())?;
        } else {
            write!(f, "{}/{}", self.rate.num(), self.rate.den())?;
        }
        if self.units {
            f.write_str("u")?;
        }
        Ok(())
    }
}

/// The rate of a `track` command: a value, or the name of a stored rate.
#[derive(Clone, Debug, PartialEq)]
pub enum RateArg {
    Value(SignedRate),
    Preset(String),
}

/// Options of `track`: the ramp's acceleration and a lease.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TrackOpts {
    /// The ramps' acceleration: the move value `amax` (steps/s², at most the axis's
    /// amax; default the axis's amax).
    pub amax: Option<f64>,
    /// Seconds (wall clock) after which the axis stops unless the command is sent again:
    /// a jog from a client that may vanish.
    pub lease: Option<f64>,
}

/// Longest jog lease (s).
pub const MAX_LEASE: f64 = 60.0;

impl TrackOpts {
    /// The `key=value` words that give these options.
    pub fn words(&self) -> Vec<String> {
        let mut w = Vec::new();
        if let Some(a) = self.amax {
            w.push(format!("amax={a}"));
        }
        if let Some(l) = self.lease {
            w.push(format!("lease={l}"));
        }
        w
    }
}
