//! The records the store keeps: what survives a power cycle of an axis, a link session,
//! a mount's sync offsets, named positions, and the simulated mechanics' file.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What survives a power cycle of one axis.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AxisRecord {
    pub position: i64,
    pub homed: bool,
    pub trusted: bool,
    /// Written before motion starts, cleared when it ends: present at start-up means the
    /// board died mid-move and the position is not known.
    pub moving: Option<MovingMarker>,
    /// Simulation only: the mechanical position (the simulated world, kept with the board).
    pub sim_position: i64,
    /// Motor minus load position (0 … the axis's backlash): which side the slack is taken
    /// up on (see [`crate::axis::AxisSettings::backlash`]).
    #[serde(default)]
    pub slack: i64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MovingMarker {
    pub from: i64,
    pub target: i64,
    /// The motion is a homing (any phase, or the park after it): a host restarted while
    /// it runs cannot finish it.
    #[serde(default)]
    pub homing: bool,
}

/// What a restarted host needs to adopt the FPGA board it left running: the token it
/// wrote to the board's `Session` register, and what of each axis's motion lives only in
/// the host.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkSession {
    pub token: u32,
    /// Per axis: what the host adds to the board's `Position` while the axis runs.
    pub offsets: Vec<i64>,
    /// Axes whose motion the host streams (it cannot go on without the host).
    pub streamed: u32,
    /// Of those, axes whose computed move the host loads as it runs: at rest after a
    /// restart, the board ended it after the pieces it held.
    #[serde(default)]
    pub rolled: u32,
    /// Axes of a group armed for the SYNC line.
    pub armed: u32,
    /// An offset being folded into an idle axis's `Position` register: kept before the
    /// register is written, so a host killed between the two knows which it holds.
    #[serde(default)]
    pub folding: Option<Fold>,
}

/// An idle axis's offset on its way into the board's counter ([`LinkSession::folding`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fold {
    pub axis: usize,
    /// The `Position` register before the fold (after it: this plus the offset).
    pub register: u32,
    pub offset: i64,
}

/// What a telescope mount keeps across restarts beside its park position.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MountRecord {
    /// Degrees added to each axis's counted angle by sync, [polar, dec].
    pub sync: [f64; 2],
}

/// A named set of axis positions (seed 002: stored line-centre positions).
pub type NamedPosition = BTreeMap<String, i64>;

/// Where the simulated mechanics of a moving axis were lately (a file beside the database,
/// rewritten often while axes move): after a crash they come back there, as a real axis's
/// mechanics stay where they stopped. Tied to the moving marker it was written under.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimMechanics {
    pub from: i64,
    pub target: i64,
    pub sim_position: i64,
}

/// The file of [`SimMechanics`] records.
pub const SIM_FILE: &str = "sim-mechanics.json";
