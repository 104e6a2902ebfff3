//! The values that shape a move, defined once: the command line's move flags (clap
//! `flatten`, feature `clap`), the controller's stored presets (serde `flatten`, feature
//! `serde`), and, through the table [`PARAMS`], the TDM config's keys, the controller
//! protocol's `key=value` words and the Python package's keywords.
//!
//! Adding a value means a field here and a row in [`PARAMS`]; a compile-time check
//! refuses a field without its row.

/// The numeric values of a move by name; `None` means "not given". Which ones a move uses
/// depends on its mode ([`crate::MoveSpec::resolve`]). The family's name, the step count
/// and segment lists are given beside these, in the form each front end reads them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default))]
pub struct MoveParams {
    /// Phase mode: acceleration time (s)
    #[cfg_attr(feature = "clap", arg(long, value_name = "S"))]
    pub accel_time: Option<f64>,
    /// Phase mode: cruise time (s)
    #[cfg_attr(feature = "clap", arg(long, value_name = "S"))]
    pub cruise_time: Option<f64>,
    /// Phase mode: deceleration time (s)
    #[cfg_attr(feature = "clap", arg(long, value_name = "S"))]
    pub decel_time: Option<f64>,
    /// Start speed (steps/s)
    #[cfg_attr(feature = "clap", arg(long, value_name = "V"))]
    pub start_speed: Option<f64>,
    /// End speed (steps/s)
    #[cfg_attr(feature = "clap", arg(long, value_name = "V"))]
    pub end_speed: Option<f64>,
    /// Exponential time constant as a fraction of the phase time (default 0.25)
    #[cfg_attr(feature = "clap", arg(long, value_name = "R"))]
    pub rho: Option<f64>,
    /// S-curve jerk fraction φ in (0, 0.5] (default 0.5)
    #[cfg_attr(feature = "clap", arg(long, value_name = "F"))]
    pub phi: Option<f64>,
    /// 4th-order S-curve snap fraction ψ in (0, 0.5] (default 0.5)
    #[cfg_attr(feature = "clap", arg(long, value_name = "F"))]
    pub psi: Option<f64>,
    /// Limits mode: maximum speed (steps/s)
    #[cfg_attr(feature = "clap", arg(long, value_name = "V"))]
    pub vmax: Option<f64>,
    /// Limits mode: maximum acceleration (steps/s²)
    #[cfg_attr(feature = "clap", arg(long, value_name = "A"))]
    pub amax: Option<f64>,
    /// Limits mode: maximum jerk (steps/s³), scurve and scurve4
    #[cfg_attr(feature = "clap", arg(long, value_name = "J"))]
    pub jmax: Option<f64>,
    /// Limits mode: maximum snap (steps/s⁴), scurve4
    #[cfg_attr(feature = "clap", arg(long, value_name = "S"))]
    pub smax: Option<f64>,
}

/// One row of [`PARAMS`]: a value's name and where it lives in [`MoveParams`].
#[derive(Clone, Copy)]
pub struct Param {
    /// The name in snake_case: the TOML key, the protocol's and Python's keyword; the
    /// command line's flag is `--` and this with `-` for `_`.
    pub name: &'static str,
    /// The value's slot.
    pub slot: fn(&mut MoveParams) -> &mut Option<f64>,
}

impl core::fmt::Debug for Param {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name)
    }
}

impl Param {
    /// The value in `p`.
    pub fn get(&self, p: &MoveParams) -> Option<f64> {
        let mut p = *p;
        *(self.slot)(&mut p)
    }

    /// The row called `name` (snake_case), if there is one.
    pub fn named(name: &str) -> Option<&'static Param> {
        PARAMS.iter().find(|p| p.name == name)
    }
}

macro_rules! rows {
    ($($field:ident),* $(,)?) => {
        [$(Param { name: stringify!($field), slot: |p| &mut p.$field }),*]
    };
}

/// Every value of [`MoveParams`], in the order the protocol prints them.
pub const PARAMS: &[Param] = &rows!(
    vmax,
    amax,
    jmax,
    smax,
    accel_time,
    cruise_time,
    decel_time,
    start_speed,
    end_speed,
    rho,
    phi,
    psi,
);

// A field without its row in PARAMS would be invisible to every front end that walks it.
const _: () = assert!(
    PARAMS.len() * core::mem::size_of::<Option<f64>>() == core::mem::size_of::<MoveParams>()
);

impl MoveParams {
    /// `self` where given, else `base`.
    pub fn over(&self, base: &MoveParams) -> MoveParams {
        let mut out = *self;
        for p in PARAMS {
            let slot = (p.slot)(&mut out);
            if slot.is_none() {
                *slot = p.get(base);
            }
        }
        out
    }

    /// Whether any phase time (accel, cruise, decel) is given.
    pub fn has_phase_times(&self) -> bool {
        self.accel_time.is_some() || self.cruise_time.is_some() || self.decel_time.is_some()
    }

    /// Whether a limit that selects limits mode (vmax, amax) is given.
    pub fn has_limits(&self) -> bool {
        self.vmax.is_some() || self.amax.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_field_has_one_row_and_rows_reach_their_own_field() {
        let mut p = MoveParams::default();
        for (k, row) in PARAMS.iter().enumerate() {
            assert!(row.get(&p).is_none(), "{} shares a field", row.name);
            *(row.slot)(&mut p) = Some(k as f64);
            assert!(Param::named(row.name).is_some_and(|r| r.get(&p) == Some(k as f64)));
        }
        // Naming every field: a new one fails to compile here until it is listed.
        let MoveParams {
            accel_time,
            cruise_time,
            decel_time,
            start_speed,
            end_speed,
            rho,
            phi,
            psi,
            vmax,
            amax,
            jmax,
            smax,
        } = p;
        let by_name = [
            ("accel_time", accel_time),
            ("cruise_time", cruise_time),
            ("decel_time", decel_time),
            ("start_speed", start_speed),
            ("end_speed", end_speed),
            ("rho", rho),
            ("phi", phi),
            ("psi", psi),
            ("vmax", vmax),
            ("amax", amax),
            ("jmax", jmax),
            ("smax", smax),
        ];
        for (name, v) in by_name {
            assert_eq!(Param::named(name).unwrap().get(&p), v, "{name}");
        }
        assert!(Param::named("steps").is_none());
    }

    #[test]
    fn over_keeps_given_values_and_fills_the_rest() {
        let a = MoveParams {
            vmax: Some(1.0),
            ..MoveParams::default()
        };
        let b = MoveParams {
            vmax: Some(2.0),
            amax: Some(3.0),
            ..MoveParams::default()
        };
        let c = a.over(&b);
        assert_eq!((c.vmax, c.amax, c.jmax), (Some(1.0), Some(3.0), None));
        assert!(c.has_limits() && !c.has_phase_times());
    }
}
