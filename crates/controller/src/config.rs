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
    /// Which axes are ASCOM Alpaca devices; read and checked by the Alpaca server
    /// (multistep-alpaca), kept as plain TOML here.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpaca: Option<toml::Table>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardSection {
    pub name: String,
    /// Step clock of the board (Hz).
    pub clock_hz: f64,
    /// Depth of each axis's period FIFO in the TDM engine.
    pub fifo_depth: usize,
    /// The FPGA board behind the axes, `serial:DEVICE[@BAUD]`; none: simulated.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub link: Option<String>,
    /// A simulated board's SYNC line: a file shared by the simulated boards of a
    /// cross-board group on this machine (an FPGA board's SYNC line is its pin).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sync_line: Option<std::path::PathBuf>,
}

impl Default for BoardSection {
    fn default() -> Self {
        BoardSection {
            name: "board".into(),
            clock_hz: multistep_core::DEFAULT_CLOCK_HZ,
            fifo_depth: 4,
            link: None,
            sync_line: None,
        }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct AxisConfig {
    pub name: String,
    #[serde(flatten)]
    pub settings: AxisSettings,
}

// By hand: serde's `flatten` would let misspelt setting names through silently.
impl<'de> Deserialize<'de> for AxisConfig {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let mut t = toml::Table::deserialize(d)?;
        let name = match t.remove("name") {
            Some(toml::Value::String(s)) => s,
            _ => return Err(D::Error::custom("every [[axis]] needs name = \"…\"")),
        };
        let settings = toml::Value::Table(t)
            .try_into()
            .map_err(|e| D::Error::custom(format!("axis {name}: {e}")))?;
        Ok(AxisConfig { name, settings })
    }
}

impl Default for BoardConfig {
    /// Without a file: four axes X, Y, Z, A with default settings.
    fn default() -> Self {
        BoardConfig {
            board: BoardSection::default(),
            axes: ["X", "Y", "Z", "A"]
                .iter()
                .map(|n| AxisConfig {
                    name: n.to_string(),
                    settings: AxisSettings::default(),
                })
                .collect(),
            alpaca: None,
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
        if !(self.board.clock_hz.is_finite() && (1e3..=1e9).contains(&self.board.clock_hz)) {
            return Err(CtlError::Setting(format!(
                "board.clock_hz must be in [1000, 1e9] (got {})",
                multistep_core::Num(self.board.clock_hz)
            )));
        }
        if let Some(l) = &self.board.link {
            crate::backend::LinkSpec::parse(l)?;
            if self.board.sync_line.is_some() {
                return Err(CtlError::Setting(
                    "board.sync_line is the simulated boards' SYNC line; an FPGA board (board.link) uses its SYNC pin"
                        .into(),
                ));
            }
        }
        if !(1..=1024).contains(&self.board.fifo_depth) {
            return Err(CtlError::Setting(format!(
                "board.fifo_depth must be in [1, 1024] (got {})",
                self.board.fifo_depth
            )));
        }
        // Board and axis names are written in `BOARD:AXIS` and on protocol lines.
        if !valid_axis_name(&self.board.name) {
            return Err(CtlError::Setting(format!(
                "board.name {:?} is not a valid name ({NAME_RULE})",
                self.board.name
            )));
        }
        for (i, a) in self.axes.iter().enumerate() {
            if !valid_axis_name(&a.name) {
                return Err(CtlError::Setting(format!(
                    "{:?} is not a valid axis name ({NAME_RULE})",
                    a.name
                )));
            }
            if crate::domain::is_move_option(&a.name) {
                return Err(CtlError::Setting(format!(
                    "axis name {:?} is a move option's word: `group move {}=…` could not \
                     tell the axis from the option; name it otherwise",
                    a.name, a.name
                )));
            }
            if self.axes[..i].iter().any(|b| b.name == a.name) {
                return Err(CtlError::Setting(format!(
                    "axis '{}' is named twice",
                    a.name
                )));
            }
            a.settings
                .validate()
                .map_err(|e| CtlError::Setting(format!("axis {}: {e}", a.name)))?;
        }
        Ok(())
    }
}

/// What a board or axis name may be ([`valid_axis_name`]), for error messages.
pub const NAME_RULE: &str = "1 to 32 letters, digits, '_' or '-', not 'ok' or 'all'";

impl BoardSection {
    /// The TDM engine that times this board's moves (seed 000's calculator latencies).
    pub fn tdm(&self) -> multistep_core::tdm::TdmConfig {
        multistep_core::tdm::TdmConfig {
            clock_hz: self.clock_hz,
            fifo_depth: self.fifo_depth,
            ..multistep_core::tdm::TdmConfig::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_two_board_telescope_example_has_17_axes() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/telescope");
        let a = BoardConfig::load(&std::path::Path::new(dir).join("board-a.toml")).unwrap();
        let b = BoardConfig::load(&std::path::Path::new(dir).join("board-b.toml")).unwrap();
        assert_eq!((a.axes.len(), b.axes.len()), (12, 5));
        assert_eq!(a.axes[0].settings.period, Some(4000));
        assert_eq!(a.axes[0].settings.sim.seed, 1);
    }

    #[test]
    fn unknown_keys_and_bad_values_are_refused() {
        assert!(BoardConfig::parse("[[axis]]\nname = \"X\"\nvmaxx = 3.0\n").is_err());
        assert!(BoardConfig::parse("[[axis]]\nname = \"X\"\nvmax = -3.0\n").is_err());
        assert!(BoardConfig::parse("[[axis]]\nname = \"X:1\"\n").is_err());
        for bad in ["", "a b", "a\\nb", "all", "a:b", &"b".repeat(33)] {
            let text = format!("[board]\nname = \"{bad}\"\n[[axis]]\nname = \"X\"\n");
            let e = BoardConfig::parse(&text).unwrap_err().to_string();
            assert!(
                e.contains("board.name") && e.contains(NAME_RULE),
                "{bad}: {e}"
            );
            assert!(!e.contains('\n'), "{e}");
        }
        assert!(
            BoardConfig::parse("[board]\nname = \"optics-2_b\"\n[[axis]]\nname = \"X\"\n").is_ok()
        );
        assert!(BoardConfig::parse("[[axis]]\nname = \"X\"\n[[axis]]\nname = \"X\"\n").is_err());
        // a group line reads `ve=5` as the end speed, never as an axis named `ve`
        for word in ["ve", "VMAX", "accel", "profile", "preset", "rho"] {
            let e = BoardConfig::parse(&format!("[[axis]]\nname = \"{word}\"\n"))
                .unwrap_err()
                .to_string();
            assert!(e.contains("move option"), "{word}: {e}");
        }
        let c = BoardConfig::parse("[[axis]]\nname = \"X\"\nvmax = 3.0\n").unwrap();
        assert_eq!(c.axes[0].settings.vmax, 3.0);
    }
}
