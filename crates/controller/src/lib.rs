//! # multistep-controller
//!
//! A stepper-motor controller board after seed 002: up to 16 axes, Hall-sensor homing with
//! a debounce filter, positions persisted in redb, periodic axes, named positions and speed
//! presets, and a line protocol served over TCP and serial lines. Its pins are a
//! [`backend::BoardBackend`]: simulated (edges from the exact edge generator, simulated
//! mechanics and sensors) or the FPGA board over its serial host link. [`Controller`] is the one API: the protocol, the host
//! client and any other front end call its methods.

pub mod access;
pub mod axis;
pub mod backend;
pub mod board;
pub mod client;
pub mod clock_rate;
pub mod config;
pub mod controller;
pub mod domain;
pub mod error;
pub mod group;
pub mod hall;
pub mod motion;
pub mod mount;
pub mod pool;
pub mod protocol;
pub mod service;
pub mod store;
pub mod tracking;

pub use axis::{AxisSettings, AxisState, AxisStatus, SimSettings};
pub use board::Board;
pub use config::BoardConfig;
pub use controller::Controller;
pub use error::CtlError;
pub use protocol::{Command, MoveOpts, Reply};

/// Most axes on one board (a board setting; the engine itself takes up to
/// [`multistep_core::tdm::MAX_AXES`]).
pub const MAX_AXES: usize = 16;

// Group moves run every axis of a board through one TDM engine.
const _: () = assert!(MAX_AXES <= multistep_core::tdm::MAX_AXES);
