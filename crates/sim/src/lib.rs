//! # multistep-sim
//!
//! A two-phase hybrid stepper motor and microstepping driver simulator (DESIGN.md §4) that
//! runs on the exact edge stream of `multistep-core`, and tells whether a move loses steps
//! and how far the rotor lags.
//!
//! ```
//! use multistep_sim::{simulate_profile, Motor, SimConfig};
//! use multistep_core::{MoveParams, MoveSpec};
//! let motor = Motor::load("42mm").unwrap();
//! let params = MoveParams { accel_time: Some(0.05), cruise_time: Some(0.05),
//!     decel_time: Some(0.05), ..Default::default() };
//! let profile = MoveSpec { steps: Some(3200), params, ..Default::default() }.plan().unwrap();
//! let r = simulate_profile(&motor, &SimConfig::for_motor(&motor), profile, 50e6, 1.0).unwrap();
//! assert_eq!(r.lost_steps, 0);
//! ```
#![forbid(unsafe_code)]

pub mod analysis;
pub mod driver;
pub mod error;
pub mod experiments;
pub mod hall;
pub mod integrate;
pub mod measures;
pub mod model;
pub mod motor;
pub mod plot;
pub mod progress;
pub mod trace;

pub use driver::{DriverConfig, DriverMode};
pub use error::SimError;
pub use measures::EnergyBalance;
pub use motor::Motor;

use multistep_core::{EdgeGenerator, Profile};
use serde::Serialize;

/// Default integration step: 1 µs.
pub const DEFAULT_DT: f64 = 1e-6;

/// How to simulate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimConfig {
    pub driver: DriverConfig,
    /// RK4 step (s): at least [`integrate::MIN_DT`], and small enough for RK4 to be stable
    /// on the motor and driver ([`integrate::check_step`] names the largest).
    pub dt: f64,
    /// Longest settling after the last edge (s); default 8/(ζ·ω_n) within 5 ms…0.5 s. The run
    /// ends earlier once the rotor rests within `settle_tolerance` of an equilibrium.
    pub settle_max: Option<f64>,
    /// Settled: within this fraction of a full step of an equilibrium, at rest (default 0.05).
    pub settle_tolerance: f64,
    /// End the run at the first lost step (for searches that only need yes or no).
    pub stop_at_first_loss: bool,
    /// Record a trace row every this many seconds (rounded to whole dt).
    pub trace_interval: Option<f64>,
    /// Peak shaft speed (rad/s) if known, so the dt check also covers the electrical frequency.
    pub peak_speed_hint: Option<f64>,
    /// Show a progress bar on stderr (when it is a terminal) for a planned run long enough
    /// to take more than a few seconds.
    pub progress: bool,
}

impl SimConfig {
    pub fn for_motor(m: &Motor) -> SimConfig {
        SimConfig {
            driver: DriverConfig::for_motor(m),
            dt: DEFAULT_DT,
            settle_max: None,
            settle_tolerance: 0.05,
            stop_at_first_loss: false,
            trace_interval: None,
            peak_speed_hint: None,
            progress: false,
        }
    }
}

/// One sample of the trace (angles and speeds in the direction of the move).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct TraceRow {
    pub t: f64,
    pub commanded_deg: f64,
    pub actual_deg: f64,
    pub commanded_speed_deg_s: f64,
    pub actual_speed_deg_s: f64,
    pub error_deg: f64,
    pub ia: f64,
    pub ib: f64,
}

/// The outcome of one simulated move.
#[derive(Clone, Debug, Serialize)]
pub struct SimResult {
    /// Edges consumed (microsteps commanded).
    pub steps: u64,
    pub microsteps: u32,
    pub mode: DriverMode,
    /// Microsteps the settled rotor is behind (negative: ahead); a multiple of 4 full steps.
    pub lost_steps: i64,
    /// Whether any step was lost: |N_r·(θ* − θ)| > π at some instant, or a residual remains.
    pub lost: bool,
    /// Time of the first instant with |N_r·(θ* − θ)| > π (s).
    pub first_loss_s: Option<f64>,
    pub peak_following_error_deg: f64,
    /// Most negative (rotor ahead) and most positive (rotor behind) following error (°).
    pub min_following_error_deg: f64,
    pub max_following_error_deg: f64,
    pub final_error_deg: f64,
    pub peak_following_error_steps: f64,
    /// Time of the last edge (s).
    pub move_time_s: f64,
    pub simulated_s: f64,
    pub dt_s: f64,
    /// ζ of the rotor oscillation at rest (with D_s), and its natural frequency.
    pub damping_ratio: f64,
    pub natural_frequency_hz: f64,
    pub peak_speed_deg_s: f64,
    /// Energy accounts (`rl` mode only).
    pub energy: Option<EnergyBalance>,
    #[serde(skip)]
    pub trace: Vec<TraceRow>,
}

/// Simulates a move given as edge ticks (step i at the i-th item) of a `clock_hz` clock, in
/// `direction` (+1 or −1). This is the entry point for any edge source — the core's
/// [`EdgeGenerator`] or a multi-axis engine's per-axis pulse stream.
pub fn simulate_edges(
    motor: &Motor,
    cfg: &SimConfig,
    edges: impl Iterator<Item = u64>,
    clock_hz: f64,
    direction: f64,
) -> Result<SimResult, SimError> {
    integrate::run(motor, cfg, edges, clock_hz, direction)
}

/// Simulates a planned move: its exact edges from [`EdgeGenerator`] at `clock_hz`. The
/// work is checked first: a run of more than [`integrate::MAX_RK4_STEPS`] RK4 steps is
/// refused before it starts.
pub fn simulate_profile(
    motor: &Motor,
    cfg: &SimConfig,
    profile: Profile,
    clock_hz: f64,
    direction: f64,
) -> Result<SimResult, SimError> {
    let mut cfg = cfg.clone();
    if cfg.peak_speed_hint.is_none() {
        let micro = motor.microstep_angle(cfg.driver.microsteps);
        cfg.peak_speed_hint = Some(profile.peak_speed() * micro);
    }
    let work = (profile.duration(), profile.steps());
    let gen = EdgeGenerator::new(profile, clock_hz)?;
    integrate::run_planned(motor, &cfg, gen, clock_hz, direction, work)
}
