//! What goes wrong: core parameters and moves that do not fit the core ([`FitError`]),
//! frames that do not decode and exchanges that fail ([`LinkError`]).

use crate::Status;

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

/// What went wrong decoding or using the link.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum LinkError {
    #[error("frame is {got} bytes, a {what} is {need}")]
    Length {
        what: &'static str,
        need: usize,
        got: usize,
    },
    #[error("frame starts with {got:#04x}, not {want:#04x}")]
    Sync { got: u8, want: u8 },
    #[error("frame CRC {got:#06x}, computed {want:#06x}")]
    Crc { got: u16, want: u16 },
    #[error("unknown command {0:#04x}")]
    Command(u8),
    #[error("unknown status {0:#04x}")]
    StatusCode(u8),
    #[error("board answered {status:?} to the request for {addr:#06x}")]
    Refused { addr: u16, status: Status },
    #[error("reply has sequence number {got}, the request {want}")]
    Sequence { got: u8, want: u8 },
    #[error("axis {axis} out of range (the board has {axes})")]
    Axis { axis: u32, axes: u32 },
    #[error("{0}")]
    Move(String),
    /// The byte stream failed (closed, or an error other than a timeout).
    #[error("link I/O: {0}")]
    Io(String),
    /// No reply within the port's own read timeout.
    #[error("link I/O: no reply in time: {0}")]
    Timeout(String),
}

/// A port's timeout is a late reply (sent again); any other I/O error ends the exchange.
pub(crate) fn io_err(e: std::io::Error) -> LinkError {
    match e.kind() {
        std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock => {
            LinkError::Timeout(e.to_string())
        }
        _ => LinkError::Io(e.to_string()),
    }
}

impl LinkError {
    /// Whether the request may or may not have been executed: its reply was damaged or
    /// did not come (a refusal as a bad CRC executed nothing, but is sent again too).
    pub fn in_doubt(&self) -> bool {
        matches!(
            self,
            LinkError::Length { .. }
                | LinkError::Sync { .. }
                | LinkError::Crc { .. }
                | LinkError::StatusCode(_)
                | LinkError::Sequence { .. }
                | LinkError::Timeout(_)
                | LinkError::Refused {
                    status: Status::BadCrc,
                    ..
                }
        )
    }
}

impl From<FitError> for LinkError {
    fn from(e: FitError) -> Self {
        LinkError::Move(e.to_string())
    }
}
