//! Board configuration file (TOML): the board's name and its axes with their settings.
//!
//! ```toml
//! [board]
//! name = "a"
//! [[axis]]
//! name = "wp1"
//! period = 14400     # every other key of AxisSettings may be given
//! ```

use crate::axis::{valid_axis_name, AxisSettings};
use crate::error::CtlError;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoardConfig {
    #[serde(default)]
    pub board: BoardSection,
    #[serde(default, rename = "axis")]
    pub axes: Vec<AxisConfig>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardSection {
    pub name: String,
    /// Step clock of the board (Hz).
    pub clock_hz: f64,
}

impl Default for BoardSection {
    fn default() -> Self {
        BoardSection { name: "board".into(), clock_hz: multistep_core::DEFAULT_CLOCK_HZ }
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct AxisConfig {
    pub name: String,
    #[serde(flatten)]
    pub settings: AxisSettings,
}

impl Default for BoardConfig {
    /// Without a file: four axes X, Y, Z, A with default settings.
    fn default() -> Self {
        BoardConfig {
            board: BoardSection::default(),
            axes: ["X", "Y", "Z", "A"]
                .iter()
                .map(|n| AxisConfig { name: n.to_string(), settings: AxisSettings::default() })
                .collect(),
        }
    }
}

impl BoardConfig {
    pub fn parse(text: &str) -> Result<BoardConfig, CtlError> {
        let c: BoardConfig =
            toml::from_str(text).map_err(|e| CtlError::Setting(format!("board config: {e}")))?;
        c.validate()?;
        Ok(c)
    }

    pub fn load(path: &std::path::Path) -> Result<BoardConfig, CtlError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| CtlError::Io(format!("cannot read {}: {e}", path.display())))?;
        Self::parse(&text)
    }

    pub fn validate(&self) -> Result<(), CtlError> {
        if self.axes.is_empty() || self.axes.len() > crate::MAX_AXES {
            return Err(CtlError::Setting(format!(
                "a board has 1 to {} axes (config has {})",
                crate::MAX_AXES,
                self.axes.len()
            )));
        }
        if !(self.board.clock_hz.is_finite() && self.board.clock_hz >= 1e3) {
            return Err(CtlError::Setting("board.clock_hz must be at least 1000".into()));
        }
        for (i, a) in self.axes.iter().enumerate() {
            if !valid_axis_name(&a.name) {
                return Err(CtlError::Setting(format!("'{}' is not a valid axis name", a.name)));
            }
            if self.axes[..i].iter().any(|b| b.name == a.name) {
                return Err(CtlError::Setting(format!("axis '{}' is named twice", a.name)));
            }
            a.settings
                .validate()
                .map_err(|e| CtlError::Setting(format!("axis {}: {e}", a.name)))?;
        }
        Ok(())
    }
}
