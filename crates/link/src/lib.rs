//! The board's host link (`rtl/board/ms_link.v`, `ms_regs.v`): request and reply frames
//! with their CRC, the register map as types, and a move as the register writes and frames
//! that load and start it. Decoding never panics: every malformed input is a
//! [`LinkError`].
//!
//! The core's parameters ([`CoreParams`], from a board's [`BuildId`]) and a move as the
//! core's piece registers ([`AxisMove`]), chained ([`chain`]) or streamed ([`stream`]),
//! live here too: the host needs them without the Verilog tooling.
//!
//! Request (11 bytes): `A5 seq cmd addr_lo addr_hi d0 d1 d2 d3 crc_hi crc_lo`, cmd 1 read,
//! 2 write; bulk write (cmd 3, [`BulkWrite`]): `A5 seq 03 addr_lo addr_hi len byte0 ..
//! byte(len−1) crc_hi crc_lo`, up to 255 bytes for a stream buffer. Reply (9 bytes):
//! `5A seq status d0 d1 d2 d3 crc_hi crc_lo`. The CRC is CRC-16/CCITT-FALSE
//! (`CRC_16_IBM_3740`: polynomial 0x1021, initial 0xFFFF) over every byte before it; data
//! is little-endian.
//!
//! Modules by job: [`frame`] (frames, CRC, the reply decoder), [`regs`] (the register
//! map), [`writes`] (a move as register writes), [`host`] (the exchange over a byte
//! stream), [`chain`] and [`stream`] (chained and streamed moves); everything is also
//! at the crate's root.

pub mod chain;
mod error;
pub mod frame;
pub mod host;
mod moves;
mod params;
pub mod recur;
pub mod regs;
pub mod stream;
pub mod writes;

pub use error::{FitError, LinkError};
pub use frame::*;
pub use host::*;
pub use moves::{mode_code, AxisMove, PieceRegs};
pub use params::{CoreParams, Widths};
pub use recur::RecurRegs;
pub use regs::*;
pub use writes::*;
