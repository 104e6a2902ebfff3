//! A mount's settings: the board configuration's `[[alpaca.telescope]]` entry.
//!
//! ```toml
//! [[alpaca.telescope]]
//! mount = "german"            # german | fork | coelostat
//! ra_axis = "ha"              # the polar (hour angle) axis
//! dec_axis = "dec"            # the declination axis (none on a coelostat)
//! ra_steps_per_rev = 4608000  # microsteps per turn of the axis
//! dec_steps_per_rev = 4608000
//! latitude = 52.1             # degrees, north positive
//! longitude = 4.4             # degrees, east positive
//! elevation = 10.0            # metres
//! ```

use super::coords::Geometry;
use crate::axis::valid_axis_name;
use crate::config::BoardConfig;
use serde::Deserialize;

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MountConfig {
    /// Device name; default "<board> telescope".
    pub name: Option<String>,
    #[serde(default = "german")]
    pub mount: Geometry,
    pub ra_axis: String,
    pub dec_axis: Option<String>,
    /// Microsteps per turn of each axis: 1 to 2^40.
    pub ra_steps_per_rev: u64,
    pub dec_steps_per_rev: Option<u64>,
    /// −90 to 90.
    pub latitude: f64,
    /// −180 to 180.
    pub longitude: f64,
    /// −500 to 10000 m.
    #[serde(default)]
    pub elevation: f64,
    /// Slews keep the polar axis within ±this many degrees of counterweight-down
    /// (German) or of the meridian (fork; a coelostat's mirror turns half): 0 to 180,
    /// default 100.
    #[serde(default = "ha_limit")]
    pub ha_limit: f64,
    /// Lowest altitude a slew may end at: −10 to 89 degrees, default 0.
    #[serde(default)]
    pub horizon: f64,
    /// Pulse-guiding rates as fractions of the sidereal rate: above 0, at most 1;
    /// default 0.5.
    #[serde(default = "half")]
    pub guide_rate_ra: f64,
    #[serde(default = "half")]
    pub guide_rate_dec: f64,
    /// A coelostat's declination (set by hand on its second mirror): −90 to 90.
    #[serde(default)]
    pub coelostat_dec: f64,
    /// Backlash of each axis's gears, microsteps: 0 (default) to 1000000. Slews and
    /// parks end approaching their target by at least this much from one side.
    #[serde(default)]
    pub ra_backlash: u64,
    #[serde(default)]
    pub dec_backlash: u64,
}

fn german() -> Geometry {
    Geometry::German
}
fn ha_limit() -> f64 {
    100.0
}
fn half() -> f64 {
    0.5
}

/// Most microsteps per axis turn.
pub const MAX_STEPS_PER_REV: u64 = 1 << 40;
/// Most backlash, microsteps.
pub const MAX_BACKLASH: u64 = 1_000_000;

impl MountConfig {
    /// The axes the mount drives.
    pub fn axes(&self) -> Vec<&str> {
        std::iter::once(self.ra_axis.as_str())
            .chain(self.dec_axis.as_deref())
            .collect()
    }

    /// The name under which the park position is stored (a named position).
    pub fn park_name(&self) -> String {
        format!("{}-park", self.ra_axis)
    }
    /// Present while the mount is parked, so a restart finds it parked.
    pub fn parked_name(&self) -> String {
        format!("{}-parked", self.ra_axis)
    }

    /// Checks ranges and that the axes are the board's, not periodic.
    pub fn validate(&self, board: &BoardConfig) -> Result<(), String> {
        let range = |what: &str, x: f64, lo: f64, hi: f64| {
            if x.is_finite() && (lo..=hi).contains(&x) {
                Ok(())
            } else {
                Err(format!("telescope {what} = {x} is outside {lo} to {hi}"))
            }
        };
        range("latitude", self.latitude, -90.0, 90.0)?;
        range("longitude", self.longitude, -180.0, 180.0)?;
        range("elevation", self.elevation, -500.0, 10_000.0)?;
        range("ha_limit", self.ha_limit, 0.0, 180.0)?;
        range("horizon", self.horizon, -10.0, 89.0)?;
        range("coelostat_dec", self.coelostat_dec, -90.0, 90.0)?;
        for (what, g) in [
            ("guide_rate_ra", self.guide_rate_ra),
            ("guide_rate_dec", self.guide_rate_dec),
        ] {
            if !(g.is_finite() && g > 0.0 && g <= 1.0) {
                return Err(format!(
                    "telescope {what} = {g} must be above 0 and at most 1 (× sidereal)"
                ));
            }
        }
        let coelostat = self.mount == Geometry::Coelostat;
        match (&self.dec_axis, self.dec_steps_per_rev, coelostat) {
            (None, None, true) => {}
            (Some(_), Some(_), false) => {}
            (_, _, true) => {
                return Err(
                    "a coelostat turns one axis: give no dec_axis or dec_steps_per_rev".into(),
                )
            }
            _ => return Err("telescope needs dec_axis and dec_steps_per_rev".into()),
        }
        for spr in std::iter::once(self.ra_steps_per_rev).chain(self.dec_steps_per_rev) {
            if !(1..=MAX_STEPS_PER_REV).contains(&spr) {
                return Err(format!(
                    "telescope steps per turn {spr} is outside 1 to {MAX_STEPS_PER_REV}"
                ));
            }
        }
        for (what, b) in [
            ("ra_backlash", self.ra_backlash),
            ("dec_backlash", self.dec_backlash),
        ] {
            if b > MAX_BACKLASH {
                return Err(format!(
                    "telescope {what} = {b} is outside 0 to {MAX_BACKLASH}"
                ));
            }
        }
        if coelostat && self.dec_backlash != 0 {
            return Err("a coelostat has no dec axis: give no dec_backlash".into());
        }
        if self.dec_axis.as_deref() == Some(self.ra_axis.as_str()) {
            return Err(format!("telescope axis '{}' given twice", self.ra_axis));
        }
        for axis in self.axes() {
            let Some(a) = board.axes.iter().find(|a| a.name == axis) else {
                return Err(format!(
                    "telescope axis '{axis}' is not an axis of the board"
                ));
            };
            if a.settings.period.is_some() {
                return Err(format!(
                    "telescope axis '{axis}' is periodic; a mount's axes count past a turn"
                ));
            }
        }
        // The stored park names are named positions: the protocol's name rule.
        if !valid_axis_name(&self.parked_name()) {
            return Err(format!(
                "telescope ra_axis '{}' is too long to name its park position",
                self.ra_axis
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(extra: &str) -> Result<MountConfig, String> {
        let board = BoardConfig::parse(
            "[[axis]]\nname = \"ha\"\n[[axis]]\nname = \"dec\"\n[[axis]]\nname = \"w\"\nperiod = 100\n",
        )
        .unwrap();
        let m: MountConfig = toml::from_str(&format!(
            "ra_axis = \"ha\"\nra_steps_per_rev = 1296000\nlatitude = 50.0\nlongitude = 5.0\n{extra}"
        ))
        .map_err(|e| e.message().to_string())?;
        m.validate(&board).map(|_| m)
    }

    #[test]
    fn good_settings_pass_and_bad_ones_say_why() {
        let m = check("dec_axis = \"dec\"\ndec_steps_per_rev = 1296000\n").unwrap();
        assert_eq!(
            (m.mount, m.ha_limit, m.guide_rate_ra),
            (Geometry::German, 100.0, 0.5)
        );
        assert!(check("mount = \"coelostat\"\n").is_ok());
        for (extra, says) in [
            ("", "needs dec_axis"),
            ("mount = \"coelostat\"\ndec_axis = \"dec\"\n", "one axis"),
            (
                "dec_axis = \"dec\"\ndec_steps_per_rev = 0\n",
                "outside 1 to",
            ),
            ("dec_axis = \"ha\"\ndec_steps_per_rev = 5\n", "given twice"),
            ("dec_axis = \"q\"\ndec_steps_per_rev = 5\n", "not an axis"),
            ("dec_axis = \"w\"\ndec_steps_per_rev = 5\n", "periodic"),
            ("mount = \"coelostat\"\nhorizon = 90.0\n", "horizon"),
            ("mount = \"coelostat\"\nguide_rate_ra = 1.5\n", "at most 1"),
            ("mount = \"coelostat\"\nelevation = nan\n", "elevation"),
            ("mount = \"altaz\"\n", "unknown variant"),
            ("mount = \"coelostat\"\nspeed = 1\n", "unknown field"),
            (
                "mount = \"coelostat\"\nra_backlash = 1000001\n",
                "ra_backlash",
            ),
            (
                "mount = \"coelostat\"\ndec_backlash = 5\n",
                "no dec_backlash",
            ),
        ] {
            let e = check(extra).unwrap_err();
            assert!(e.contains(says), "{extra}: {e}");
        }
    }
}
