//! multistep-hdl: the TDM step-pulse IP core of seed 000 as synthesizable Verilog-2005
//! (its period calculator runs `multistep_core::int`'s per-step kernel), a testbench
//! generator, and runners for Icarus Verilog, Verilator (lint) and yosys (resource use).

mod board;
pub mod board_sim;
pub mod boards;
pub mod build;
mod emit;
mod error;
pub mod modules;
pub mod pnr;
pub mod report;
pub mod simulator;
pub mod sync_sim;
pub mod testbench;
pub mod tools;
pub mod verilator;

pub use board::{
    filter_latest, BoardTop, BOARD_LIBRARY, CHAIN_LIBRARY, FILTER_BITS, MAX_BAUD_ERROR,
};
pub use emit::{Arch, Design, LIBRARY, RECURRENCE_UNIT};
pub use error::HdlError;
// The host link, the core's parameters and the move writes, at their old paths.
pub use multistep_link as link;
pub use multistep_link::{chain, stream};
pub use multistep_link::{mode_code, AxisMove, CoreParams, FitError, PieceRegs, Widths};
