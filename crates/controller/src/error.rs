//! One typed error for everything the controller refuses; each has a stable protocol code.

use multistep_core::PlanError;

#[derive(Debug, thiserror::Error)]
pub enum CtlError {
    #[error("line is longer than {max} bytes")]
    LineTooLong { max: usize },
    #[error("line is not valid UTF-8")]
    InvalidUtf8,
    #[error("{0}")]
    Syntax(String),
    #[error("unknown axis '{0}'")]
    UnknownAxis(String),
    #[error("target {target} is outside the soft limits [{min}, {max}] of axis {axis}")]
    OutOfLimits {
        axis: String,
        target: i128,
        min: String,
        max: String,
    },
    #[error("axis {axis} is {state}; wait for it or stop it first")]
    Busy { axis: String, state: &'static str },
    #[error("the move cannot be planned: {0}")]
    Plan(#[from] PlanError),
    #[error("unknown {what} '{name}'")]
    UnknownName { what: &'static str, name: String },
    #[error("setting: {0}")]
    Setting(String),
    #[error("storage: {0}")]
    Store(String),
    #[error("emergency stop is active; send 'reset' first")]
    EStopped,
    #[error("homing axis {axis} failed: {why}")]
    Homing { axis: String, why: String },
    #[error("{0}")]
    Io(String),
    #[error("{0}")]
    TooFast(String),
    #[error("timing: {0}")]
    Timing(String),
    #[error("{0}")]
    Unauthorized(String),
    #[error("{0}")]
    Connection(String),
    #[error("'sim' commands exist only on a simulated board")]
    NotSimulated,
    /// A command this board's backend cannot carry out yet.
    #[error("{0}")]
    Unsupported(String),
    /// The database file was deleted or replaced while the board ran: nothing more is
    /// stored until the board is restarted on the data directory as it is now.
    #[error("storage: {0}")]
    StoreGone(String),
    /// The FPGA board's link is down or a request got no intact reply after its retries.
    #[error("{0}")]
    Link(String),
    /// The FPGA board refused a request, or cannot carry out what it asks for.
    #[error("{0}")]
    LinkRefused(String),
    /// Too much long work (moves and previews to time) is waiting already.
    #[error("busy: {0}")]
    Overloaded(String),
    /// The mount refused a `mount` command: a value out of range, a slew beyond its
    /// limits, parked, or not possible in its present state.
    #[error("mount: {0}")]
    Mount(String),
}

impl CtlError {
    /// The number after `error:` in a reply. Stable: programs may switch on it.
    pub fn code(&self) -> u16 {
        match self {
            CtlError::LineTooLong { .. } => 1,
            CtlError::InvalidUtf8 => 2,
            CtlError::Syntax(_) => 3,
            CtlError::UnknownAxis(_) => 4,
            CtlError::OutOfLimits { .. } => 5,
            CtlError::Busy { .. } => 6,
            CtlError::Plan(_) => 7,
            CtlError::UnknownName { .. } => 8,
            CtlError::Setting(_) => 9,
            CtlError::Store(_) => 10,
            CtlError::EStopped => 11,
            CtlError::Homing { .. } => 12,
            CtlError::Io(_) => 13,
            CtlError::TooFast(_) => 14,
            CtlError::Timing(_) => 15,
            CtlError::Unauthorized(_) => 16,
            CtlError::Connection(_) => 17,
            CtlError::NotSimulated => 18,
            CtlError::Unsupported(_) => 19,
            CtlError::StoreGone(_) => 20,
            CtlError::Link(_) => 21,
            CtlError::LinkRefused(_) => 22,
            CtlError::Overloaded(_) => 23,
            CtlError::Mount(_) => 24,
        }
    }

    pub fn syntax(msg: impl Into<String>) -> Self {
        CtlError::Syntax(msg.into())
    }
}

impl From<redb::Error> for CtlError {
    fn from(e: redb::Error) -> Self {
        CtlError::Store(e.to_string())
    }
}

macro_rules! store_err {
    ($($t:ty),*) => {$(
        impl From<$t> for CtlError {
            fn from(e: $t) -> Self {
                CtlError::Store(e.to_string())
            }
        }
    )*};
}
store_err!(
    redb::DatabaseError,
    redb::TransactionError,
    redb::TableError,
    redb::StorageError,
    redb::CommitError,
    serde_json::Error
);
