//! One board read at one moment, and how often boards are read: what the board links
//! (`boards.rs`) produce and the event stream (`events.rs`) sends.

use multistep_controller::AxisStatus;
use serde::Serialize;
use std::time::Duration;

/// Period of updates while any axis moves or homes (20 Hz), and at rest.
pub const MOVING_PERIOD: Duration = Duration::from_millis(50);
pub const IDLE_PERIOD: Duration = Duration::from_millis(250);

#[derive(Clone, Serialize)]
pub struct BoardSnapshot {
    pub board: usize,
    pub name: String,
    pub tick: u64,
    pub clock_hz: f64,
    pub estop: bool,
    pub warnings: Vec<String>,
    pub axes: Vec<AxisStatus>,
    /// Why a remote board could not be read.
    pub error: Option<String>,
}
