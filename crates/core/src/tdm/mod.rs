//! Time-division-multiplexed (TDM) multi-axis engine (seed 000 §1.2, DESIGN.md §3).
//!
//! One period calculator serves k axes in turn. Each axis has a FIFO of periods and a pulse
//! unit that consumes one period per step. The model is cycle-accurate and event-driven: the
//! calculator's only cost is its timing ([`Latencies`]); the period values come from the
//! core's [`EdgeGenerator`](crate::EdgeGenerator), so with no underrun every axis emits
//! exactly the edges `multistep plan` gives.
//!
//! Nothing allocates: axes live in caller-provided storage (`&mut [Axis]`), FIFOs are fixed
//! arrays of at most [`MAX_FIFO_DEPTH`] entries, a board holds at most [`MAX_AXES`] axes.

pub mod analysis;
pub mod board;
pub mod calculator;
pub mod chain;
pub mod fifo;
pub mod pulse;
pub mod scheduler;
pub mod stream;

pub use analysis::{k_eq12, k_max, min_period_ticks, rate_move, KMax};
pub use board::{Axis, AxisStats, Board, Report, TdmConfig, TrackCommand, MAX_AXES};
pub use calculator::Latencies;
pub use fifo::{Fifo, MAX_FIFO_DEPTH};
pub use pulse::{PulseShape, PulseUnit, StepPulse};
pub use scheduler::Policy;

use crate::error::PlanError;
use thiserror::Error;

/// Every way a TDM board can be misconfigured.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum TdmError {
    #[error("a board needs at least one axis")]
    NoAxes,
    #[error("{axes} axes is more than the {max} one board holds")]
    TooManyAxes { axes: usize, max: usize },
    #[error("fifo_depth must be 1 to {max} (got {depth})")]
    FifoDepth { depth: usize, max: usize },
    #[error("the calculator must take at least one cycle per period")]
    ZeroCycles,
    #[error("a fixed pulse width must be at least one tick")]
    ZeroPulseWidth,
    #[error("axis {axis} counts edges at {axis_hz} Hz but the board clock is {board_hz} Hz")]
    ClockMismatch {
        axis: usize,
        axis_hz: f64,
        board_hz: f64,
    },
    #[error("the run could last past tick 2^57 (the scheduler's tick range)")]
    TooLong,
    #[error("axis {axis} is not a tracking axis (or there is no such axis)")]
    NotTracking { axis: usize },
    #[error("tracking commands must be in tick order")]
    CommandOrder,
    #[error("unknown policy (expected round-robin or earliest-deadline)")]
    UnknownPolicy,
    #[error(transparent)]
    Plan(#[from] PlanError),
}
