//! The `[alpaca]` section of the board configuration: which axis is which device.
//!
//! ```toml
//! [[alpaca.focuser]]
//! axis = "focus"
//! microns_per_unit = 1000.0   # the axis's user unit is a millimetre (the default)
//!
//! [[alpaca.rotator]]
//! axis = "pa"                 # periodic, one period = 360 units (degrees)
//! min_deg = -90.0             # optional travel (axis degrees): no move crosses the rest
//! max_deg = 200.0             # of the turn (a cable wrap); both or neither
//!
//! [[alpaca.filterwheel]]
//! axis = "wheel"
//! slots = [
//!   { name = "Halpha", position = 0, focus_offset = 0 },
//!   { name = "CaK" },         # the board's saved named position "CaK"
//! ]
//! ```
//!
//! Devices of one type are numbered 0, 1, … in the order they are listed.

use crate::mapping::Travel;
use multistep_controller::axis::{valid_axis_name, MAX_POSITION};
use multistep_controller::config::NAME_RULE;
use multistep_controller::mount::MountConfig;
use multistep_controller::BoardConfig;
use serde::Deserialize;

#[derive(Clone, Debug, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AlpacaSection {
    pub focuser: Vec<FocuserConfig>,
    pub rotator: Vec<RotatorConfig>,
    pub filterwheel: Vec<FilterWheelConfig>,
    /// Mounts (settings and ranges: `multistep_controller::mount::config`).
    pub telescope: Vec<MountConfig>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FocuserConfig {
    pub axis: String,
    /// Device name shown to clients; default "<board> focuser <axis>".
    pub name: Option<String>,
    /// Micrometres per axis unit (`steps_per_unit` microsteps): StepSize is this over
    /// steps_per_unit. Default 1000: the unit is a millimetre.
    #[serde(default = "one_mm")]
    pub microns_per_unit: f64,
}

fn one_mm() -> f64 {
    1000.0
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotatorConfig {
    pub axis: String,
    pub name: Option<String>,
    /// Allowed travel in the axis's degrees (position / steps_per_unit): `min_deg` in
    /// [-360, 360], `max_deg` above it and at most 360 further. Without them the rotator
    /// turns freely, the short way.
    pub min_deg: Option<f64>,
    pub max_deg: Option<f64>,
}

impl RotatorConfig {
    /// The travel the keys give (None: free), checked.
    pub fn travel(&self) -> Result<Option<Travel>, ConfigError> {
        match (self.min_deg, self.max_deg) {
            (None, None) => Ok(None),
            (Some(lo), Some(hi)) => Travel::new(lo, hi)
                .map(Some)
                .map_err(|e| ConfigError(format!("rotator '{}': {e}", self.axis))),
            _ => Err(ConfigError(format!(
                "rotator '{}': give both min_deg and max_deg, or neither",
                self.axis
            ))),
        }
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilterWheelConfig {
    pub axis: String,
    pub name: Option<String>,
    pub slots: Vec<SlotConfig>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlotConfig {
    pub name: String,
    /// Axis position of the slot (microsteps); without it, the axis's entry in the board's
    /// saved named position of the same name (`save NAME AXIS`).
    pub position: Option<i64>,
    /// Focuser steps to add for this filter (FocusOffsets).
    #[serde(default)]
    pub focus_offset: i32,
}

/// What is wrong with an `[alpaca]` section.
#[derive(Debug, thiserror::Error)]
#[error("board config [alpaca]: {0}")]
pub struct ConfigError(pub String);

impl AlpacaSection {
    /// Reads and checks the section of `config` (empty when there is none).
    pub fn from_board(config: &BoardConfig) -> Result<AlpacaSection, ConfigError> {
        let Some(table) = &config.alpaca else {
            return Ok(AlpacaSection::default());
        };
        let s: AlpacaSection = toml::Value::Table(table.clone())
            .try_into()
            .map_err(|e: toml::de::Error| ConfigError(e.message().to_string()))?;
        s.validate(config)?;
        Ok(s)
    }

    pub fn is_empty(&self) -> bool {
        self.focuser.is_empty()
            && self.rotator.is_empty()
            && self.filterwheel.is_empty()
            && self.telescope.is_empty()
    }

    fn validate(&self, config: &BoardConfig) -> Result<(), ConfigError> {
        let err = |m: String| Err(ConfigError(m));
        let mut used: Vec<&str> = Vec::new();
        let axes = self
            .focuser
            .iter()
            .map(|f| ("focuser", f.axis.as_str()))
            .chain(self.rotator.iter().map(|r| ("rotator", r.axis.as_str())))
            .chain(
                self.filterwheel
                    .iter()
                    .map(|w| ("filterwheel", w.axis.as_str())),
            )
            .chain(
                self.telescope
                    .iter()
                    .flat_map(|t| t.axes().into_iter().map(|a| ("telescope", a))),
            );
        for (kind, axis) in axes {
            let Some(a) = config.axes.iter().find(|a| a.name == axis) else {
                return err(format!("{kind} axis '{axis}' is not an axis of the board"));
            };
            if used.contains(&axis) {
                return err(format!("axis '{axis}' is given to two devices"));
            }
            used.push(axis);
            let s = &a.settings;
            match kind {
                "focuser" => {
                    if s.period.is_some() {
                        return err(format!(
                            "focuser axis '{axis}' is periodic; a focuser needs soft limits"
                        ));
                    }
                    match s.soft_max {
                        Some(hi) if (1..=i32::MAX as i64).contains(&hi) => {}
                        _ => {
                            return err(format!(
                                "focuser axis '{axis}' needs soft_max between 1 and {} (MaxStep)",
                                i32::MAX
                            ))
                        }
                    }
                }
                "rotator" => {
                    // Position is in degrees: one period must be 360 user units.
                    let turn = s.period.map(|p| p as f64 / s.steps_per_unit);
                    if !turn.is_some_and(|t| (t - 360.0).abs() < 1e-9 * 360.0) {
                        return err(format!(
                            "rotator axis '{axis}' must be periodic with period = 360 × steps_per_unit (one turn in degrees)"
                        ));
                    }
                }
                _ => {}
            }
        }
        for (k, t) in self.telescope.iter().enumerate() {
            t.validate(config).map_err(ConfigError)?;
            // INDI names a device by its name: two telescopes need two names.
            if let Some(n) = &t.name {
                if self.telescope[..k]
                    .iter()
                    .any(|u| u.name.as_ref() == Some(n))
                {
                    return err(format!("two telescopes are named '{n}'"));
                }
            }
        }
        for r in &self.rotator {
            r.travel()?;
        }
        for f in &self.focuser {
            if !(f.microns_per_unit.is_finite() && f.microns_per_unit > 0.0) {
                return err(format!(
                    "focuser '{}': microns_per_unit must be a positive number",
                    f.axis
                ));
            }
        }
        for w in &self.filterwheel {
            if w.slots.is_empty() {
                return err(format!("filterwheel '{}' has no slots", w.axis));
            }
            for (i, s) in w.slots.iter().enumerate() {
                if s.name.trim().is_empty() || w.slots[..i].iter().any(|t| t.name == s.name) {
                    return err(format!(
                        "filterwheel '{}': slot names must be non-empty and distinct ('{}')",
                        w.axis, s.name
                    ));
                }
                match s.position {
                    Some(p) if p.unsigned_abs() > MAX_POSITION as u64 => {
                        return err(format!(
                            "filterwheel '{}': slot '{}' position {p} is outside \
                             [-{MAX_POSITION}, {MAX_POSITION}] (microsteps)",
                            w.axis, s.name
                        ))
                    }
                    // Without a position the name is a saved named position's.
                    None if !valid_axis_name(&s.name) => {
                        return err(format!(
                            "filterwheel '{}': slot {:?} has no position and is not a \
                             saved position's name ({NAME_RULE})",
                            w.axis, s.name
                        ))
                    }
                    _ => {}
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section(extra: &str) -> Result<AlpacaSection, String> {
        let text = format!(
            "[[axis]]\nname = \"F\"\nsoft_min = 0\nsoft_max = 5000\n\
             [[axis]]\nname = \"R\"\nperiod = 3600\nsteps_per_unit = 10.0\n\
             [[axis]]\nname = \"W\"\nperiod = 4000\n{extra}"
        );
        let c = BoardConfig::parse(&text).map_err(|e| e.to_string())?;
        AlpacaSection::from_board(&c).map_err(|e| e.to_string())
    }

    #[test]
    fn a_good_section_parses() {
        let s = section(
            "[[alpaca.focuser]]\naxis = \"F\"\n[[alpaca.rotator]]\naxis = \"R\"\n\
             [[alpaca.filterwheel]]\naxis = \"W\"\nslots = [{ name = \"a\", position = 0 }, { name = \"b\" }, \
             { name = \"H alpha\", position = -1000000000000000 }]\n",
        )
        .unwrap();
        assert_eq!(s.focuser[0].microns_per_unit, 1000.0);
        assert_eq!(s.filterwheel[0].slots[1].position, None);
        assert!(section("").unwrap().is_empty());
        let r =
            section("[[alpaca.rotator]]\naxis = \"R\"\nmin_deg = -90\nmax_deg = 180.5\n").unwrap();
        assert_eq!(
            r.rotator[0].travel().unwrap(),
            Some(Travel {
                min_deg: -90.0,
                max_deg: 180.5
            })
        );
    }

    #[test]
    fn the_optics_example_has_three_devices() {
        let p = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/alpaca-optics.toml"
        );
        let c = BoardConfig::load(std::path::Path::new(p)).unwrap();
        let s = AlpacaSection::from_board(&c).unwrap();
        assert_eq!(
            (s.focuser.len(), s.rotator.len(), s.filterwheel.len()),
            (1, 1, 1)
        );
        assert_eq!(s.filterwheel[0].slots.len(), 5);
    }

    #[test]
    fn the_mount_example_has_a_telescope_beside_the_optics() {
        let p = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../examples/telescope-mount.toml"
        );
        let c = BoardConfig::load(std::path::Path::new(p)).unwrap();
        let s = AlpacaSection::from_board(&c).unwrap();
        let t = &s.telescope[0];
        assert_eq!(
            (t.ra_axis.as_str(), t.dec_axis.as_deref()),
            ("ha", Some("dec"))
        );
        assert_eq!(
            (s.focuser.len(), s.rotator.len(), s.filterwheel.len()),
            (1, 1, 1)
        );
    }

    #[test]
    fn bad_sections_are_refused_with_a_reason() {
        for (extra, says) in [
            ("[[alpaca.focuser]]\naxis = \"Q\"\n", "not an axis"),
            ("[[alpaca.focuser]]\naxis = \"R\"\n", "periodic"),
            ("[[alpaca.focuser]]\naxis = \"W\"\n", "periodic"),
            ("[[alpaca.rotator]]\naxis = \"W\"\n", "360"),
            ("[[alpaca.rotator]]\naxis = \"F\"\n", "360"),
            ("[[alpaca.rotator]]\naxis = \"R\"\nmin_deg = 0.0\n", "both min_deg and max_deg"),
            ("[[alpaca.rotator]]\naxis = \"R\"\nmin_deg = 0.0\nmax_deg = 400.0\n", "at most 360"),
            ("[[alpaca.rotator]]\naxis = \"R\"\nmin_deg = 10.0\nmax_deg = -10.0\n", "above it"),
            ("[[alpaca.rotator]]\naxis = \"R\"\n[[alpaca.filterwheel]]\naxis = \"R\"\nslots = [{ name = \"a\" }]\n", "two devices"),
            ("[[alpaca.filterwheel]]\naxis = \"W\"\nslots = []\n", "no slots"),
            ("[[alpaca.filterwheel]]\naxis = \"W\"\nslots = [{ name = \"a\" }, { name = \"a\" }]\n", "distinct"),
            ("[[alpaca.focuser]]\naxis = \"F\"\nspeed = 3\n", "unknown field"),
            ("[[alpaca.telescope]]\naxis = \"F\"\n", "unknown field"),
            ("[[alpaca.telescope]]\nmount = \"fork\"\nra_axis = \"F\"\ndec_axis = \"W\"\n\
              ra_steps_per_rev = 10\ndec_steps_per_rev = 10\nlatitude = 0.0\nlongitude = 0.0\n", "periodic"),
            ("[[alpaca.telescope]]\nmount = \"coelostat\"\nra_axis = \"F\"\n\
              ra_steps_per_rev = 10\nlatitude = 0.0\nlongitude = 0.0\n[[alpaca.focuser]]\naxis = \"F\"\n", "two devices"),
            ("[[alpaca.focuser]]\naxis = \"F\"\nmicrons_per_unit = -1.0\n", "positive"),
            ("[[axis]]\nname = \"A\"\n[[alpaca.telescope]]\nname = \"T\"\nmount = \"coelostat\"\n\
              ra_axis = \"F\"\nra_steps_per_rev = 10\nlatitude = 0.0\nlongitude = 0.0\n\
              [[alpaca.telescope]]\nname = \"T\"\nmount = \"coelostat\"\nra_axis = \"A\"\n\
              ra_steps_per_rev = 10\nlatitude = 0.0\nlongitude = 0.0\n", "two telescopes are named 'T'"),
            ("[[alpaca.filterwheel]]\naxis = \"W\"\nslots = [{ name = \"\", position = 0 }]\n", "non-empty"),
            ("[[alpaca.filterwheel]]\naxis = \"W\"\nslots = [{ name = \"a\", position = 9223372036854775807 }]\n", "outside [-1000000000000000, 1000000000000000]"),
            ("[[alpaca.filterwheel]]\naxis = \"W\"\nslots = [{ name = \"a\", position = -9223372036854775808 }]\n", "outside"),
            ("[[alpaca.filterwheel]]\naxis = \"W\"\nslots = [{ name = \"H alpha\" }]\n", "saved position's name"),
        ] {
            let e = section(extra).unwrap_err();
            assert!(e.contains(says), "{extra}: {e}");
        }
    }
}
