//! Core parameters and moves that do not fit the core.

/// A core parameter out of range, or a move or piece the core cannot hold.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FitError {
    /// A core parameter is out of range (checked before any register is written).
    #[error("bad core parameter: {0}")]
    Param(String),
    /// A piece of a move does not fit the core's registers.
    #[error("piece {index} does not fit the core: {reason}")]
    Piece { index: usize, reason: String },
    /// A move does not fit the core (piece count, periods, planning).
    #[error("move does not fit the core: {0}")]
    Move(String),
}
