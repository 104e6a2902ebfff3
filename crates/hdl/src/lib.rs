//! multistep-hdl: the TDM step-pulse IP core of seed 000 as synthesizable Verilog-2005
//! (its period calculator runs `multistep_core::int`'s per-step kernel), a testbench
//! generator, and runners for Icarus Verilog, Verilator (lint) and yosys (resource use).

mod board;
pub mod board_sim;
pub mod boards;
pub mod build;
pub mod chain;
mod emit;
mod error;
pub mod link;
mod moves;
mod params;
pub mod pnr;
pub mod report;
pub mod simulator;
pub mod stream;
pub mod sync_sim;
pub mod testbench;
pub mod tools;
pub mod verilator;

pub use board::{BoardTop, BOARD_LIBRARY, CHAIN_LIBRARY, MAX_BAUD_ERROR};
pub use emit::{Arch, Design, LIBRARY};
pub use error::HdlError;
pub use moves::{mode_code, AxisMove, PieceRegs};
pub use params::{CoreParams, Widths};
