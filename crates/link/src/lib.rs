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
//! byte(len−1) crc_hi crc_lo`, up to 255 bytes for a stream buffer. Reply (9 bytes): `5A seq status d0 d1 d2 d3 crc_hi crc_lo`. The CRC is
//! CRC-16/CCITT-FALSE (`CRC_16_IBM_3740`: polynomial 0x1021, initial 0xFFFF) over every
//! byte before it; data is little-endian.

pub mod chain;
mod error;
mod moves;
mod params;
pub mod stream;

pub use error::FitError;
pub use moves::{mode_code, AxisMove, PieceRegs};
pub use params::{CoreParams, Widths};

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// First byte of a request.
pub const REQUEST_SYNC: u8 = 0xA5;
/// First byte of a reply.
pub const REPLY_SYNC: u8 = 0x5A;
// The frame sizes are the link model's (`multistep_core::tdm::stream`), defined there once.
pub const REQUEST_LEN: usize = multistep_core::tdm::stream::REQUEST_BYTES as usize;
pub const REPLY_LEN: usize = 9;

const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

/// The CRC of a frame's bytes before its CRC field.
pub fn crc16(bytes: &[u8]) -> u16 {
    CRC16.checksum(bytes)
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
fn io_err(e: std::io::Error) -> LinkError {
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

/// Read or write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    Read = 1,
    Write = 2,
    /// A [`BulkWrite`]'s command byte (never in a [`Request`]).
    Bulk = 3,
}

/// A reply's status (`ms_link.v`, `ms_regs.v`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Ok = 0,
    /// The request's CRC was wrong (nothing executed).
    BadCrc = 1,
    /// Unknown command byte.
    BadCommand = 2,
    /// No such register, or a read of a write-only one / a write of a read-only one.
    BadAddress = 3,
    /// The write would change a running move (or a setting while any axis runs).
    Busy = 4,
    /// The e-stop is latched (start refused) or still active (clear refused).
    Estop = 5,
    /// A value out of range (an axis mask with bits beyond K, an empty start).
    BadValue = 6,
    /// A bulk write larger than the free space of the axis's stream buffer (nothing kept).
    StreamFull = 7,
}

impl Status {
    pub fn from_code(c: u8) -> Result<Status, LinkError> {
        Ok(match c {
            0 => Status::Ok,
            1 => Status::BadCrc,
            2 => Status::BadCommand,
            3 => Status::BadAddress,
            4 => Status::Busy,
            5 => Status::Estop,
            6 => Status::BadValue,
            7 => Status::StreamFull,
            c => return Err(LinkError::StatusCode(c)),
        })
    }
}

/// Board registers (`0x00xx`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoardReg {
    /// R: `0x4D53_0000 | version` ("MS").
    Id = 0x00,
    /// R: `K << 24 | log2 FIFO depth << 16 | slot bits << 8 | radix bits`.
    Config = 0x01,
    /// R: `step bits << 24 | tick bits << 16 | radicand bits << 8 | kernel bits`.
    Widths = 0x02,
    /// R: clock (Hz).
    ClockHz = 0x03,
    /// R: UART baud.
    Baud = 0x04,
    /// R/W: the host's session token: written (nonzero) by the host after it connects,
    /// 0 after configuration and every reset; any other readback than the token written
    /// means the board lost its state ([`HostLink::claim`]).
    Session = 0x05,
    /// R: bit 0 e-stop latched, 1 e-stop input active, 2 group pending, 3 the pending group
    /// is armed (waits for SYNC), 4 the SYNC edge came before the armed group was ready,
    /// 5 the SYNC line (synchronized), 6 the armed group is ready, 7 an armed group was cut
    /// by [`BoardReg::ArmTimeout`] (until the next `Arm`), 31:16 bad frames.
    Status = 0x06,
    /// R: busy axes.
    Busy = 0x07,
    /// R/W: write 1 latches the e-stop, 0 clears it (refused while the input is active).
    Estop = 0x08,
    /// W: start these axes as one group.
    Start = 0x09,
    /// W: stop these axes now (STEP low at the next clock).
    Stop = 0x0A,
    /// R/W: STEP high time in ticks, 0 = 50 % duty (busy: refused).
    PulseWidth = 0x0B,
    /// R/W: least ticks from DIR to the group's start (busy: refused).
    DirSetup = 0x0C,
    /// R/W: Hall and limit debounce, ticks.
    Debounce = 0x0D,
    /// R/W: ENABLE outputs (axis mask).
    Enable = 0x0E,
    /// R/W: active levels (see [`Levels`]; busy: refused).
    Levels = 0x0F,
    /// R/W: axes that run their stop ramp at an accepted Hall edge.
    HallStop = 0x10,
    /// R/W: axes that stop at an accepted limit edge.
    LimitStop = 0x11,
    /// W: clear the Hall flag, the stopped and e-stopped flags of these axes.
    Clear = 0x12,
    /// W: load these axes as one group, as `Start` does, but hold its start for the next
    /// falling edge of the SYNC line (boards built with SYNC).
    Arm = 0x13,
    /// W: pull the SYNC line low for 1 us (at least 4 clocks).
    Fire = 0x14,
    /// R: the free-running clock count at the last falling edge of the SYNC line (after
    /// the synchronizer).
    SyncTick = 0x15,
    /// R/W: axes whose DIR pin is inverted against `Levels` (the DIR bit stays logical,
    /// the position counts as before; a running axis's bit cannot change: busy).
    DirInvert = 0x16,
    /// R/W: axes whose ENABLE pin is active low against `Levels`; the e-stop and a reset
    /// force ENABLE to this level's inactive side. Both masks are kept over a reset.
    EnableLow = 0x17,
    /// R: the bytes of a chain record ([`crate::chain::ChainLayout::record_bytes`]) on a
    /// board with a chain unit per axis (`AxisReg::ChainSteps`); status 3 without them.
    Chains = 0x18,
    /// R/W (boards built with SYNC): clocks an armed group may wait for the SYNC edge
    /// after its `Arm` write, 0 (the reset value) for no bound. Past it the group is cut
    /// (its axes halted, never started) and `Status` bit 7 is set until the next `Arm`.
    ArmTimeout = 0x19,
}

/// Axis registers (`0x2000 | axis << 4 | r`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisReg {
    /// R: [`AxisState`].
    State = 0,
    /// R/W: the step position (signed; writable while idle).
    Position = 1,
    /// R: the position latched at the last accepted Hall edge.
    HallPosition = 2,
    /// R: ticks between the last two STEP rises (0 before the second).
    Period = 3,
    /// R/W: the slot of the stop ramp (writable while idle).
    StopSlot = 4,
    /// R/W: write N >= 1: the axis's next start replays a streamed schedule of N steps
    /// (the stream buffer is emptied); 0: the next start is computed (writable while
    /// idle). Read: 1 while armed.
    StreamSteps = 5,
    /// R: free bytes in the axis's stream buffer.
    StreamFree = 6,
    /// Bulk writes only ([`BulkWrite`]): bytes of the streamed schedule (or of the chain
    /// records).
    StreamData = 7,
    /// W (boards with chain units, `BoardReg::Chains`): write N >= 1: the axis's next start
    /// runs the chain records in its stream buffer (emptied here), N steps in all
    /// (writable while idle).
    ChainSteps = 8,
}

/// A register address.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reg {
    Board(BoardReg),
    Axis(u32, AxisReg),
    /// The core's bus word (`ms_core.v`), write only.
    Core(u16),
}

impl Reg {
    pub fn addr(self) -> u16 {
        match self {
            Reg::Board(r) => r as u16,
            Reg::Axis(a, r) => 0x2000 | ((a as u16 & 0x3F) << 4) | r as u16,
            Reg::Core(a) => 0x1000 | (a & 0x0FFF),
        }
    }
}

/// A position register (`AxisReg::Position`, `HallPosition`) as a count: the register
/// holds the low 32 bits of the board's two's-complement counter (sign-extended here),
/// `offset` the steps the host keeps outside it.
pub fn position_count(raw: u32, offset: i64) -> i64 {
    i64::from(raw as i32) + offset
}

/// A count at rest written back to the position register: its low 32 bits.
pub fn position_register(count: i64) -> u32 {
    count as u32
}

/// The core bus address `{cmd, axis, word}` (`ms_core.v`).
pub fn core_addr(w: &Widths, cmd: bool, axis: u32, word: u32) -> u16 {
    ((u32::from(cmd) << (w.aw - 1)) | (axis << 5) | word) as u16
}

/// Active levels (`BoardReg::Levels`): true = active high.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Levels {
    pub step: bool,
    pub dir: bool,
    pub enable: bool,
    pub hall: bool,
    pub limit: bool,
    /// The e-stop also drops every ENABLE.
    pub estop_disables: bool,
}

impl Default for Levels {
    /// The board's reset value: all active high, the e-stop drops ENABLE.
    fn default() -> Self {
        Levels::from_bits(0x3F)
    }
}

impl Levels {
    pub fn bits(self) -> u32 {
        [
            self.step,
            self.dir,
            self.enable,
            self.hall,
            self.limit,
            self.estop_disables,
        ]
        .iter()
        .enumerate()
        .map(|(i, &b)| u32::from(b) << i)
        .sum()
    }
    pub fn from_bits(b: u32) -> Levels {
        let bit = |i: u32| b >> i & 1 == 1;
        Levels {
            step: bit(0),
            dir: bit(1),
            enable: bit(2),
            hall: bit(3),
            limit: bit(4),
            estop_disables: bit(5),
        }
    }
}

/// An axis's state as `AxisReg::State` reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisRun {
    Idle = 0,
    Running = 1,
    /// The last or current move had a late edge (until the next start).
    Underrun = 2,
    /// Stopped by the STOP register, a limit or the Hall stop ramp (until start or clear).
    Stopped = 3,
    /// Stopped by the e-stop (until start or clear).
    Estopped = 4,
}

/// `AxisReg::State`, decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisState {
    pub run: AxisRun,
    pub busy: bool,
    pub underrun: bool,
    pub stopped: bool,
    pub estopped: bool,
    pub hall_flag: bool,
    pub hall: bool,
    pub limit: bool,
    pub dir: bool,
    /// The next start replays a streamed schedule.
    pub stream_armed: bool,
    /// The replay unit met a bad code and stopped (the axis underruns until stopped).
    pub stream_fault: bool,
}

impl AxisState {
    pub fn decode(v: u32) -> Result<AxisState, LinkError> {
        let bit = |i: u32| v >> i & 1 == 1;
        let run = match v & 7 {
            0 => AxisRun::Idle,
            1 => AxisRun::Running,
            2 => AxisRun::Underrun,
            3 => AxisRun::Stopped,
            4 => AxisRun::Estopped,
            c => return Err(LinkError::StatusCode(c as u8)),
        };
        Ok(AxisState {
            run,
            busy: bit(3),
            underrun: bit(4),
            stopped: bit(5),
            estopped: bit(6),
            hall_flag: bit(7),
            hall: bit(8),
            limit: bit(9),
            dir: bit(10),
            stream_armed: bit(11),
            stream_fault: bit(12),
        })
    }
}

/// What the board says it is (`Id`, `Config`, `Widths`, `ClockHz`, `Baud`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuildId {
    pub version: u16,
    pub axes: u32,
    pub fifo_depth_bits: u32,
    pub slot_bits: u32,
    pub radix_bits: u32,
    pub step_bits: u32,
    pub tick_bits: u32,
    pub radicand_bits: u32,
    pub kernel_bits: u32,
    pub clock_hz: u32,
    pub baud: u32,
}

impl BuildId {
    /// From the five registers' values in the order above; the id must carry "MS".
    pub fn decode(
        id: u32,
        config: u32,
        widths: u32,
        clock: u32,
        baud: u32,
    ) -> Result<Self, LinkError> {
        if id >> 16 != 0x4D53 {
            return Err(LinkError::Move(format!(
                "build id {id:#010x} is not an ms_board's"
            )));
        }
        let b = |v: u32, i: u32| (v >> (8 * i)) & 0xFF;
        Ok(BuildId {
            version: id as u16,
            axes: b(config, 3),
            fifo_depth_bits: b(config, 2),
            slot_bits: b(config, 1),
            radix_bits: b(config, 0),
            step_bits: b(widths, 3),
            tick_bits: b(widths, 2),
            radicand_bits: b(widths, 1),
            kernel_bits: b(widths, 0),
            clock_hz: clock,
            baud,
        })
    }

    /// The build id a board with these parameters reports.
    pub fn of(p: &CoreParams, baud: u32) -> Result<BuildId, FitError> {
        let w = p.widths()?;
        Ok(BuildId {
            version: crate_version(),
            axes: p.axes,
            fifo_depth_bits: w.lf,
            slot_bits: w.ls,
            radix_bits: w.rb,
            step_bits: w.wn,
            tick_bits: w.wd,
            radicand_bits: w.wy,
            kernel_bits: w.wk,
            clock_hz: p.clock_hz as u32,
            baud,
        })
    }
}

/// This crate's version as the board's 16-bit version: major << 12 | minor << 4 | patch.
pub fn crate_version() -> u16 {
    let n = |s: &str| s.parse::<u16>().unwrap_or(0);
    let v: Vec<u16> = env!("CARGO_PKG_VERSION").split('.').map(n).collect();
    let at = |i: usize| v.get(i).copied().unwrap_or(0);
    (at(0) & 0xF) << 12 | (at(1) & 0xFF) << 4 | (at(2) & 0xF)
}

/// One request frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request {
    pub seq: u8,
    pub command: Command,
    pub addr: u16,
    /// The value written (0 for a read).
    pub data: u32,
}

impl Request {
    pub fn read(seq: u8, reg: Reg) -> Request {
        Request {
            seq,
            command: Command::Read,
            addr: reg.addr(),
            data: 0,
        }
    }

    pub fn write(seq: u8, reg: Reg, data: u32) -> Request {
        Request {
            seq,
            command: Command::Write,
            addr: reg.addr(),
            data,
        }
    }

    pub fn encode(&self) -> [u8; REQUEST_LEN] {
        let mut f = [0u8; REQUEST_LEN];
        f[0] = REQUEST_SYNC;
        f[1] = self.seq;
        f[2] = self.command as u8;
        f[3..5].copy_from_slice(&self.addr.to_le_bytes());
        f[5..9].copy_from_slice(&self.data.to_le_bytes());
        let c = crc16(&f[..9]);
        f[9..].copy_from_slice(&c.to_be_bytes());
        f
    }

    /// Decodes one request frame (what the board's parser accepts).
    pub fn decode(f: &[u8]) -> Result<Request, LinkError> {
        let f = frame(f, REQUEST_LEN, REQUEST_SYNC, "request")?;
        let command = match f[2] {
            1 => Command::Read,
            2 => Command::Write,
            c => return Err(LinkError::Command(c)),
        };
        Ok(Request {
            seq: f[1],
            command,
            addr: u16::from_le_bytes([f[3], f[4]]),
            data: u32::from_le_bytes([f[5], f[6], f[7], f[8]]),
        })
    }
}

/// Each axis's stream buffer on the board (`ms_board`'s `LB` = 9).
pub const STREAM_BUFFER: u64 = 512;

/// Most bytes in one bulk write.
pub const BULK_MAX: usize = multistep_core::tdm::stream::BULK_MAX as usize;
/// A bulk write's frame bytes besides its data.
pub const BULK_OVERHEAD: usize = multistep_core::tdm::stream::BULK_OVERHEAD as usize;

/// A bulk write: up to [`BULK_MAX`] bytes for one register (an axis's `StreamData`) in one
/// frame of `len` + [`BULK_OVERHEAD`] bytes, answered by one [`Reply`] whose data is the buffer's free
/// bytes after it (status `StreamFull` if it did not fit: nothing is kept).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BulkWrite {
    pub seq: u8,
    pub addr: u16,
    pub data: Vec<u8>,
}

impl BulkWrite {
    /// The frame, or an error for more than [`BULK_MAX`] bytes.
    pub fn encode(&self) -> Result<Vec<u8>, LinkError> {
        let n = self.data.len();
        if n > BULK_MAX {
            return Err(LinkError::Length {
                what: "bulk write's data",
                need: BULK_MAX,
                got: n,
            });
        }
        let mut f = Vec::with_capacity(n + BULK_OVERHEAD);
        f.extend_from_slice(&[REQUEST_SYNC, self.seq, Command::Bulk as u8]);
        f.extend_from_slice(&self.addr.to_le_bytes());
        f.push(n as u8);
        f.extend_from_slice(&self.data);
        let c = crc16(&f);
        f.extend_from_slice(&c.to_be_bytes());
        Ok(f)
    }

    /// Decodes one bulk frame (what the board's parser accepts).
    pub fn decode(f: &[u8]) -> Result<BulkWrite, LinkError> {
        let n = *f.get(5).ok_or(LinkError::Length {
            what: "bulk write",
            need: BULK_OVERHEAD,
            got: f.len(),
        })? as usize;
        let f = frame(f, n + BULK_OVERHEAD, REQUEST_SYNC, "bulk write")?;
        if f[2] != Command::Bulk as u8 {
            return Err(LinkError::Command(f[2]));
        }
        Ok(BulkWrite {
            seq: f[1],
            addr: u16::from_le_bytes([f[3], f[4]]),
            data: f[6..6 + n].to_vec(),
        })
    }
}

/// Checks length, sync byte and CRC.
fn frame<'a>(f: &'a [u8], len: usize, sync: u8, what: &'static str) -> Result<&'a [u8], LinkError> {
    if f.len() != len {
        return Err(LinkError::Length {
            what,
            need: len,
            got: f.len(),
        });
    }
    if f[0] != sync {
        return Err(LinkError::Sync {
            got: f[0],
            want: sync,
        });
    }
    let want = crc16(&f[..len - 2]);
    let got = u16::from_be_bytes([f[len - 2], f[len - 1]]);
    if got != want {
        return Err(LinkError::Crc { got, want });
    }
    Ok(f)
}

/// One reply frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reply {
    pub seq: u8,
    pub status: Status,
    pub data: u32,
}

impl Reply {
    pub fn encode(&self) -> [u8; REPLY_LEN] {
        let mut f = [0u8; REPLY_LEN];
        f[0] = REPLY_SYNC;
        f[1] = self.seq;
        f[2] = self.status as u8;
        f[3..7].copy_from_slice(&self.data.to_le_bytes());
        let c = crc16(&f[..7]);
        f[7..].copy_from_slice(&c.to_be_bytes());
        f
    }

    pub fn decode(f: &[u8]) -> Result<Reply, LinkError> {
        let f = frame(f, REPLY_LEN, REPLY_SYNC, "reply")?;
        Ok(Reply {
            seq: f[1],
            status: Status::from_code(f[2])?,
            data: u32::from_le_bytes([f[3], f[4], f[5], f[6]]),
        })
    }

    /// The reply's data if it answers `req` with `Ok`.
    pub fn answer(&self, req: &Request) -> Result<u32, LinkError> {
        if self.seq != req.seq {
            return Err(LinkError::Sequence {
                got: self.seq,
                want: req.seq,
            });
        }
        match self.status {
            Status::Ok => Ok(self.data),
            status => Err(LinkError::Refused {
                addr: req.addr,
                status,
            }),
        }
    }
}

/// Splits a byte stream from the board into replies: bytes before a sync byte are
/// skipped; a frame that fails its CRC is reported and the search restarts one byte after
/// its sync byte.
#[derive(Clone, Debug, Default)]
pub struct ReplyDecoder {
    buf: Vec<u8>,
}

impl ReplyDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `bytes`; returns every complete reply (or error) found so far.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Result<Reply, LinkError>> {
        self.buf.extend_from_slice(bytes);
        let mut out = Vec::new();
        loop {
            match self.buf.iter().position(|&b| b == REPLY_SYNC) {
                None => {
                    self.buf.clear();
                    break;
                }
                Some(i) => {
                    self.buf.drain(..i);
                }
            }
            if self.buf.len() < REPLY_LEN {
                break;
            }
            match Reply::decode(&self.buf[..REPLY_LEN]) {
                Ok(r) => {
                    self.buf.drain(..REPLY_LEN);
                    out.push(Ok(r));
                }
                Err(e) => {
                    self.buf.drain(..1);
                    out.push(Err(e));
                }
            }
        }
        out
    }
}

/// One register write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RegWrite {
    pub reg: Reg,
    pub data: u32,
}

/// The 17 staging words of a piece (`ms_core.v`): y0, dy (4 words each), k (3, two's
/// complement), dv (3), t0, steps, mode.
pub fn staging_words(p: &PieceRegs) -> [u32; 17] {
    let mut w = [0u32; 17];
    let k = &p.kernel;
    for i in 0..4 {
        w[i] = (k.y0 >> (32 * i)) as u32;
        w[4 + i] = (k.dy >> (32 * i)) as u32;
    }
    for i in 0..3 {
        w[8 + i] = (k.k >> (32 * i)) as u32;
        w[11 + i] = (k.dv >> (32 * i)) as u32;
    }
    w[14] = p.t0 as u32;
    w[15] = p.steps as u32;
    w[16] = mode_code(k.mode);
    w
}

/// The writes that load piece `slot` of `axis`: 17 staging words and the commit.
pub fn piece_writes(w: &Widths, axis: u32, slot: u32, p: &PieceRegs) -> Vec<RegWrite> {
    let mut out: Vec<RegWrite> = staging_words(p)
        .iter()
        .enumerate()
        .map(|(i, &data)| RegWrite {
            reg: Reg::Core(core_addr(w, false, axis, i as u32)),
            data,
        })
        .collect();
    out.push(RegWrite {
        reg: Reg::Core(core_addr(w, true, axis, 0)),
        data: slot,
    });
    out
}

/// The writes that load `m` into `axis` (every piece from slot 0, then the axis control
/// word: DIR and the last slot). The move is checked against the core first; with a
/// fixed pulse width (`pulse_width` > 0) every period must be longer than it.
pub fn move_writes(
    p: &CoreParams,
    axis: u32,
    m: &AxisMove,
    pulse_width: u32,
) -> Result<Vec<RegWrite>, LinkError> {
    if axis >= p.axes {
        return Err(LinkError::Axis { axis, axes: p.axes });
    }
    m.check(p)?;
    if pulse_width > 0 {
        let edges = m.edges();
        let short = edges.windows(2).map(|e| e[1] - e[0]).min();
        if let Some(s) = short.filter(|&s| s <= u64::from(pulse_width)) {
            return Err(LinkError::Move(format!(
                "a period of {s} ticks is not longer than the {pulse_width}-tick STEP pulse"
            )));
        }
    }
    let w = p.widths()?;
    let mut out = Vec::new();
    for (slot, pc) in m.pieces.iter().enumerate() {
        out.extend(piece_writes(&w, axis, slot as u32, pc));
    }
    out.push(RegWrite {
        reg: Reg::Core(core_addr(&w, true, axis, 1)),
        data: (u32::from(m.dir) << 31) | (m.pieces.len() as u32 - 1),
    });
    Ok(out)
}

/// The writes that load a stop ramp (one piece, its t0 counted from the last edge before
/// the Hall edge; `PieceRegs::t0` should be 0) into `slot` of `axis` and select it.
pub fn stop_ramp_writes(
    p: &CoreParams,
    axis: u32,
    slot: u32,
    ramp: &PieceRegs,
) -> Result<Vec<RegWrite>, LinkError> {
    if axis >= p.axes {
        return Err(LinkError::Axis { axis, axes: p.axes });
    }
    if slot >= p.pieces {
        return Err(LinkError::Move(format!(
            "slot {slot} of {} slots",
            p.pieces
        )));
    }
    let probe = AxisMove {
        dir: false,
        pieces: vec![*ramp],
    };
    probe.check(p)?;
    let w = p.widths()?;
    let mut out = piece_writes(&w, axis, slot, ramp);
    out.push(RegWrite {
        reg: Reg::Axis(axis, AxisReg::StopSlot),
        data: slot,
    });
    Ok(out)
}

/// The write that starts `axes` (a mask) as one group.
pub fn start_write(axes: u32) -> RegWrite {
    RegWrite {
        reg: Reg::Board(BoardReg::Start),
        data: axes,
    }
}

/// The write that arms `axes` (a mask) as one group, to start at the next SYNC edge.
pub fn arm_write(axes: u32) -> RegWrite {
    RegWrite {
        reg: Reg::Board(BoardReg::Arm),
        data: axes,
    }
}

/// `Status` bits (`BoardReg::Status`; the cross-board start's: docs/HDL.md, "Cross-board
/// start").
pub mod status_bits {
    /// The e-stop is latched.
    pub const ESTOP: u32 = 1 << 0;
    /// The e-stop input is active.
    pub const ESTOP_INPUT: u32 = 1 << 1;
    /// A group waits for its start.
    pub const PENDING: u32 = 1 << 2;
    /// That group is armed: it waits for the SYNC edge.
    pub const ARMED: u32 = 1 << 3;
    /// The last SYNC edge came before the armed group was ready.
    pub const LATE: u32 = 1 << 4;
    /// The SYNC line, synchronized (1: idle).
    pub const SYNC_LINE: u32 = 1 << 5;
    /// The armed group is ready (prefilled, past its DIR setup).
    pub const READY: u32 = 1 << 6;
    /// An armed group waited past `ArmTimeout` without a SYNC edge and was cut (until the
    /// next `Arm`).
    pub const ARM_EXPIRED: u32 = 1 << 7;
    /// Where the count of frames the board dropped (bad CRC, unknown command) starts.
    pub const BAD_FRAMES_SHIFT: u32 = 16;

    /// The frames the board dropped since its reset (bits 31:16).
    pub fn bad_frames(status: u32) -> u32 {
        status >> BAD_FRAMES_SHIFT
    }
}

/// Each board's clock relative to the first board's at one instant (the SYNC edge): board
/// j's `SyncTick` subtracted from board 0's, in ticks (modulo 2^32, as a signed offset).
pub fn sync_offsets(sync_ticks: &[u32]) -> Vec<i64> {
    let first = sync_ticks.first().copied().unwrap_or(0);
    sync_ticks
        .iter()
        .map(|&t| i64::from(first.wrapping_sub(t) as i32))
        .collect()
}

/// Starts the groups armed on several boards (wired to one SYNC line) at one instant:
/// polls every board's `Status` (at most `polls` reads each, calling `pause` between
/// them) until its armed group is ready, writes `Fire` to board `firer`, and returns every
/// board's `SyncTick`. A board whose group is not armed, or not ready after `polls`
/// reads, is an error before anything fires.
pub fn fire_armed<T: std::io::Read + std::io::Write>(
    links: &mut [HostLink<T>],
    firer: usize,
    polls: u32,
    mut pause: impl FnMut(),
) -> Result<Vec<u32>, LinkError> {
    if firer >= links.len() {
        return Err(LinkError::Move(format!(
            "board {firer} fires, but there are {} boards",
            links.len()
        )));
    }
    for (i, l) in links.iter_mut().enumerate() {
        let mut n = 0;
        loop {
            let s = l.read(Reg::Board(BoardReg::Status))?;
            if s & status_bits::ARMED == 0 {
                return Err(LinkError::Move(format!("board {i}: no group armed")));
            }
            if s & status_bits::READY != 0 {
                break;
            }
            n += 1;
            if n >= polls {
                return Err(LinkError::Move(format!(
                    "board {i}: the armed group is not ready after {polls} reads"
                )));
            }
            pause();
        }
    }
    links[firer].write(Reg::Board(BoardReg::Fire), 1)?;
    links
        .iter_mut()
        .map(|l| l.read(Reg::Board(BoardReg::SyncTick)))
        .collect()
}

/// Numbers the writes as request frames from sequence number `seq` on (wrapping).
pub fn requests(writes: &[RegWrite], seq: u8) -> Vec<Request> {
    writes
        .iter()
        .enumerate()
        .map(|(i, w)| Request::write(seq.wrapping_add(i as u8), w.reg, w.data))
        .collect()
}

/// A planned integer move on one axis as the frames that load it and start it alone.
pub fn move_frames(
    p: &CoreParams,
    axis: u32,
    profile: &multistep_core::int::IntProfile,
    dir: bool,
    pulse_width: u32,
    seq: u8,
) -> Result<Vec<Request>, LinkError> {
    let m = AxisMove::from_profile(profile, dir, p)?;
    let mut w = move_writes(p, axis, &m, pulse_width)?;
    w.push(start_write(1 << axis));
    Ok(requests(&w, seq))
}

/// A move given in plan's units (steps/s, s) as `multistep_core::int`'s integer move on a
/// `clock_hz` clock: trapezoid moves only (phases, segments or limits), every speed a whole
/// number of steps/s and every time a whole number of ticks (to 1e-6), else an error
/// saying which value.
pub fn int_profile(
    mv: &multistep_core::Move<'_>,
    clock_hz: u64,
) -> Result<multistep_core::int::IntProfile, LinkError> {
    use multistep_core::int::{IntClock, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment};
    use multistep_core::{Family, Move, Order};
    let whole = |x: f64, what: &str| -> Result<u64, LinkError> {
        let r = x.round();
        if !x.is_finite() || x < 0.0 || (x - r).abs() > 1e-6 || r >= 2f64.powi(63) {
            return Err(LinkError::Move(format!(
                "{what} {x} is not a whole number (the board's planner is integer)"
            )));
        }
        Ok(r as u64)
    };
    let ticks = |s: f64, what: &str| {
        whole(s * clock_hz as f64, &format!("{what} {s} s is")).map_err(|_| {
            LinkError::Move(format!(
                "{what} {s} s is not a whole number of ticks at {clock_hz} Hz"
            ))
        })
    };
    let clock = IntClock::hz(clock_hz);
    let plan = |r: Result<IntProfile, multistep_core::int::IntError>| {
        r.map_err(|e| LinkError::Move(format!("the integer planner: {e}")))
    };
    match mv {
        Move::Phase(m) => {
            if m.family != Family::Trapezoid {
                return Err(LinkError::Move(format!(
                    "the board computes trapezoids only, not {:?} (stream it: hdl regs --stream)",
                    m.family
                )));
            }
            plan(IntProfile::phase(
                &IntPhaseMove {
                    steps: m.steps,
                    accel_ticks: ticks(m.accel_time, "accel time")?,
                    cruise_ticks: ticks(m.cruise_time, "cruise time")?,
                    decel_ticks: ticks(m.decel_time, "decel time")?,
                    start_speed: whole(m.start_speed, "start speed")?,
                    end_speed: whole(m.end_speed, "end speed")?,
                },
                clock,
            ))
        }
        Move::Segments(segs) => {
            let v: Result<Vec<IntSegment>, LinkError> = segs
                .iter()
                .map(|g| {
                    Ok(IntSegment {
                        v0: whole(g.v0, "segment start speed")?,
                        ticks: ticks(g.duration, "segment time")?,
                        steps: g.steps,
                    })
                })
                .collect();
            plan(IntProfile::segments(&v?, clock))
        }
        Move::Limits(m) => {
            if m.order != Order::Trapezoid || m.jmax.is_some() || m.smax.is_some() {
                return Err(LinkError::Move(
                    "the board computes trapezoids only, no jerk or snap limit (stream it: hdl regs --stream)".into(),
                ));
            }
            plan(IntProfile::limits(
                &IntLimitsMove {
                    steps: m.steps,
                    vmax: whole(m.vmax, "vmax")?,
                    amax: whole(m.amax, "amax")?,
                    start_speed: whole(m.start_speed, "start speed")?,
                    end_speed: whole(m.end_speed, "end speed")?,
                },
                clock,
            ))
        }
    }
}

/// How often [`HostLink`] sends a frame again whose reply was damaged or did not come.
pub const RETRANSMITS: u32 = 2;

/// A random nonzero session token for [`HostLink::claim`].
pub fn session_token() -> u32 {
    use std::hash::{BuildHasher, Hasher};
    // the standard library seeds `RandomState` from the OS's randomness
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos()),
    );
    h.write_u32(std::process::id());
    let v = h.finish();
    ((v ^ (v >> 32)) as u32).max(1)
}

/// The host's side of the link over any byte stream (a serial port, a socket): one
/// request at a time, each answered before the next; sequence numbers are checked. Read
/// timeouts are the stream's own (e.g. `serialport`'s timeout).
///
/// Exactly once: a request whose reply is damaged, refused as a bad CRC or does not come
/// in time is sent again as the same frame (same seq), up to [`RETRANSMITS`] times. The
/// board answers a retransmission of the frame it executed last from that frame's reply
/// (`ms_link.v`), so a write whose reply was lost is never executed twice, and its answer
/// is the one the board gave. An error after the retransmissions leaves the request's
/// outcome unknown ([`LinkError::in_doubt`]).
///
/// Urgent requests: one frame is atomic, but whoever sends many in a row (a stream's
/// code, a poll's reads) checks [`HostLink::urgent`] between them and lets go of the link
/// when it is set, so that an e-stop waits for one frame, not for the whole batch.
#[derive(Debug)]
pub struct HostLink<T> {
    io: T,
    seq: u8,
    decoder: ReplyDecoder,
    /// Frames sent again.
    pub retransmitted: u64,
    /// Set by whoever waits to send something urgent (see above).
    urgent: Option<Arc<AtomicBool>>,
}

impl<T: std::io::Read + std::io::Write> HostLink<T> {
    pub fn new(io: T) -> Self {
        HostLink {
            io,
            seq: 0,
            decoder: ReplyDecoder::new(),
            retransmitted: 0,
            urgent: None,
        }
    }

    /// The link with `flag` as its urgent flag (see [`HostLink::urgent`]).
    pub fn with_urgent(mut self, flag: Option<Arc<AtomicBool>>) -> Self {
        self.urgent = flag;
        self
    }

    /// An urgent request waits for the link: a batch of frames should end here.
    pub fn urgent(&self) -> bool {
        self.urgent
            .as_ref()
            .is_some_and(|f| f.load(Ordering::SeqCst))
    }

    /// Reads the board's session register and writes `token` (nonzero) to it. Returns
    /// what was read: a board that kept its state since this host last claimed it with
    /// token T reads T; 0 after configuration or a reset.
    pub fn claim(&mut self, token: u32) -> Result<u32, LinkError> {
        let before = self.read(Reg::Board(BoardReg::Session))?;
        self.write(Reg::Board(BoardReg::Session), token)?;
        Ok(before)
    }

    /// The stream back.
    pub fn into_inner(self) -> T {
        self.io
    }

    /// Sends `req` (its seq replaced by the link's next) and returns the reply's data, or
    /// the board's refusal, a reply that does not decode, or an I/O error.
    pub fn transact(&mut self, mut req: Request) -> Result<u32, LinkError> {
        req.seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        self.exchange(&req.encode(), req)
    }

    /// Sends a bulk write of `data` to `reg` (an axis's `StreamData`) and returns the
    /// reply's data: the free bytes left in the axis's stream buffer.
    pub fn bulk(&mut self, reg: Reg, data: &[u8]) -> Result<u32, LinkError> {
        let b = BulkWrite {
            seq: self.seq,
            addr: reg.addr(),
            data: data.to_vec(),
        };
        let frame = b.encode()?;
        self.seq = self.seq.wrapping_add(1);
        // the reply is checked against a request of the same seq and address
        self.exchange(&frame, Request::write(b.seq, reg, 0))
    }

    /// Sends `frame` and waits for the reply to `req` (its seq), sending the same frame
    /// again while the reply is damaged or late.
    fn exchange(&mut self, frame: &[u8], req: Request) -> Result<u32, LinkError> {
        let mut tries = 0;
        loop {
            match self.exchange_once(frame, req) {
                Err(e) if e.in_doubt() && tries < RETRANSMITS => {
                    tries += 1;
                    self.retransmitted += 1;
                }
                r => return r,
            }
        }
    }

    fn exchange_once(&mut self, frame: &[u8], req: Request) -> Result<u32, LinkError> {
        self.io.write_all(frame).map_err(io_err)?;
        self.io.flush().map_err(io_err)?;
        let mut buf = [0u8; REPLY_LEN];
        loop {
            let n = self.io.read(&mut buf).map_err(io_err)?;
            if n == 0 {
                return Err(LinkError::Io("the stream closed".into()));
            }
            // A reply with another seq answers an earlier request whose reply never came
            // in time (a host killed mid-request, a timeout, a retransmission): skipped.
            let got: Vec<_> = self
                .decoder
                .push(&buf[..n])
                .into_iter()
                .filter(|r| !matches!(r, Ok(y) if y.seq != req.seq))
                .collect();
            // our reply, even behind the remains of a damaged one
            let found = match got.iter().position(|r| r.is_ok()) {
                Some(i) => got.into_iter().nth(i),
                None => got.into_iter().next(),
            };
            if let Some(r) = found {
                // what is left of a bad frame must not be taken for the next reply
                self.decoder = ReplyDecoder::new();
                return r?.answer(&req);
            }
        }
    }

    pub fn read(&mut self, reg: Reg) -> Result<u32, LinkError> {
        self.transact(Request::read(0, reg))
    }

    pub fn write(&mut self, reg: Reg, data: u32) -> Result<(), LinkError> {
        self.transact(Request::write(0, reg, data)).map(|_| ())
    }

    /// Writes in order; stops at the first refusal.
    pub fn write_all(&mut self, writes: &[RegWrite]) -> Result<(), LinkError> {
        writes.iter().try_for_each(|w| self.write(w.reg, w.data))
    }

    pub fn build_id(&mut self) -> Result<BuildId, LinkError> {
        let mut r = |b: BoardReg| self.read(Reg::Board(b));
        let (id, c, w) = (r(BoardReg::Id)?, r(BoardReg::Config)?, r(BoardReg::Widths)?);
        let (hz, baud) = (r(BoardReg::ClockHz)?, r(BoardReg::Baud)?);
        BuildId::decode(id, c, w, hz, baud)
    }

    pub fn axis_state(&mut self, axis: u32) -> Result<AxisState, LinkError> {
        AxisState::decode(self.read(Reg::Axis(axis, AxisReg::State))?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_position_reads_back_sign_extended_and_writes_back_its_low_bits() {
        assert_eq!(position_count(0xFFFF_FFD6, 0), -42);
        assert_eq!(position_count(0xFFFF_FFD6, 1 << 32), (1 << 32) - 42);
        assert_eq!(position_count(7, -10), -3);
        assert_eq!(position_register(-42), 0xFFFF_FFD6);
        assert_eq!(position_register((1 << 32) + 5), 5);
        assert_eq!(position_count(position_register(-5_000_000), 0), -5_000_000);
    }

    #[test]
    fn crc_is_ccitt_false() {
        // the catalogue's check value
        assert_eq!(crc16(b"123456789"), 0x29B1);
    }

    #[test]
    fn frames_round_trip_and_end_in_a_zero_residue() {
        let r = Request::write(7, Reg::Axis(3, AxisReg::Position), 0xDEAD_BEEF);
        let f = r.encode();
        assert_eq!(f[..5], [0xA5, 7, 2, 0x31, 0x20]);
        assert_eq!(crc16(&f), 0, "the CRC appended high byte first leaves 0");
        assert_eq!(Request::decode(&f), Ok(r));
        let y = Reply {
            seq: 7,
            status: Status::Busy,
            data: 5,
        };
        assert_eq!(Reply::decode(&y.encode()), Ok(y));
        assert_eq!(
            y.answer(&r),
            Err(LinkError::Refused {
                addr: 0x2031,
                status: Status::Busy
            })
        );
    }

    #[test]
    fn every_single_bit_error_is_caught() {
        let f = Reply {
            seq: 1,
            status: Status::Ok,
            data: 0x1234_5678,
        }
        .encode();
        for i in 0..f.len() * 8 {
            let mut g = f;
            g[i / 8] ^= 1 << (i % 8);
            assert!(Reply::decode(&g).is_err(), "bit {i}");
        }
    }

    /// A register file behind the framing, answering like the board (unknown registers
    /// refused), optionally corrupting its replies. As `ms_link.v`, it answers the same
    /// frame as the one it executed last from that frame's reply.
    struct FakeBoard {
        regs: std::collections::HashMap<u16, u32>,
        out: Vec<u8>,
        corrupt: bool,
        /// Replies so far; the one of this index is damaged, of `lose` never sent.
        replies: usize,
        damage: Option<usize>,
        lose: Option<usize>,
        /// The last executed frame and its reply.
        last: Option<(Vec<u8>, Reply)>,
        /// Every write executed.
        executed: Vec<(u16, u32)>,
    }

    impl std::io::Write for FakeBoard {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            let req = Request::decode(b).expect("the host sends whole frames");
            let reply = match &self.last {
                Some((f, r)) if f == b => *r,
                _ => {
                    let (status, data) = match (req.command, self.regs.get(&req.addr)) {
                        (_, None) => (Status::BadAddress, 0),
                        (Command::Read, Some(&v)) => (Status::Ok, v),
                        (Command::Write, Some(_)) => {
                            self.regs.insert(req.addr, req.data);
                            self.executed.push((req.addr, req.data));
                            (Status::Ok, 0)
                        }
                        (Command::Bulk, Some(_)) => (Status::BadCommand, 0),
                    };
                    let r = Reply {
                        seq: req.seq,
                        status,
                        data,
                    };
                    self.last = Some((b.to_vec(), r));
                    r
                }
            };
            let mut f = reply.encode();
            let n = self.replies;
            self.replies += 1;
            if self.corrupt || self.damage == Some(n) {
                f[4] ^= 1;
            }
            if self.lose == Some(n) {
                return Ok(b.len());
            }
            self.out.extend_from_slice(&[0x00, 0x13]); // noise before the reply
            self.out.extend_from_slice(&f);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl std::io::Read for FakeBoard {
        fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
            if self.out.is_empty() {
                // a serial port's read timeout
                return Err(std::io::ErrorKind::TimedOut.into());
            }
            // a few bytes at a time, as a serial port delivers them
            let n = self.out.len().min(b.len()).min(4);
            b[..n].copy_from_slice(&self.out[..n]);
            self.out.drain(..n);
            Ok(n)
        }
    }

    fn fake(corrupt: bool) -> HostLink<FakeBoard> {
        let regs = [
            (0x00, 0x4D53_0010),
            (0x01, 0x0204_0201),
            (0x02, 0x1418_8044),
            (0x03, 50_000_000),
            (0x04, 3_000_000),
            (0x0B, 0),
            (0x2010, 0x109),
        ]
        .into_iter()
        .collect();
        HostLink::new(FakeBoard {
            regs,
            out: Vec::new(),
            corrupt,
            replies: 0,
            damage: None,
            lose: None,
            last: None,
            executed: Vec::new(),
        })
    }

    #[test]
    fn a_write_whose_reply_is_damaged_or_lost_is_executed_once() {
        let start = Reg::Board(BoardReg::Start);
        for (damage, lose) in [(Some(0), None), (None, Some(0)), (Some(0), Some(1))] {
            let mut l = fake(false);
            l.io.regs.insert(start.addr(), 0);
            l.io.damage = damage;
            l.io.lose = lose;
            assert_eq!(l.write(start, 1), Ok(()), "{damage:?} {lose:?}");
            assert_eq!(
                l.io.executed,
                vec![(start.addr(), 1)],
                "{damage:?} {lose:?}"
            );
            // the next write of the same value is a new request: executed
            l.write(start, 1).unwrap();
            assert_eq!(l.io.executed.len(), 2);
        }
        // every reply damaged: an error after the retransmissions, executed once
        let mut l = fake(true);
        l.io.regs.insert(start.addr(), 0);
        let e = l.write(start, 1).unwrap_err();
        assert!(e.in_doubt(), "{e}");
        assert_eq!(
            (l.io.executed.len(), l.retransmitted),
            (1, u64::from(RETRANSMITS))
        );
    }

    #[test]
    fn a_claim_reads_the_session_and_writes_the_token() {
        let mut l = fake(false);
        l.io.regs.insert(0x05, 0);
        assert_eq!(l.claim(0xABCD), Ok(0));
        assert_eq!(l.claim(0x1234), Ok(0xABCD));
        assert_ne!(session_token(), 0);
    }

    #[test]
    fn sync_offsets_are_signed_and_wrap() {
        assert_eq!(sync_offsets(&[1000, 0, 2000]), vec![0, 1000, -1000]);
        assert_eq!(sync_offsets(&[5, u32::MAX - 4]), vec![0, 10]);
        assert!(sync_offsets(&[]).is_empty());
    }

    #[test]
    fn fire_armed_waits_for_ready_then_fires_one_board() {
        let board = |status: u32, tick: u32| {
            let mut l = fake(false);
            l.io.regs.insert(0x06, status);
            l.io.regs.insert(0x14, 0);
            l.io.regs.insert(0x15, tick);
            l
        };
        let armed = status_bits::PENDING | status_bits::ARMED | status_bits::SYNC_LINE;
        let ready = armed | status_bits::READY;
        let mut ls = vec![board(ready, 7000), board(ready, 1000)];
        assert_eq!(fire_armed(&mut ls, 1, 3, || {}), Ok(vec![7000, 1000]));
        assert_eq!(ls[1].io.regs[&0x14], 1, "board 1 fired");
        assert_eq!(ls[0].io.regs[&0x14], 0, "board 0 did not");
        // never ready: polls reads, then an error, nothing fired
        let mut ls = vec![board(ready, 0), board(armed, 0)];
        let mut pauses = 0;
        assert!(matches!(
            fire_armed(&mut ls, 0, 3, || pauses += 1),
            Err(LinkError::Move(m)) if m.contains("board 1") && m.contains("not ready")
        ));
        assert_eq!((pauses, ls[0].io.regs[&0x14]), (2, 0));
        // not armed, and a firer out of range
        let mut ls = vec![board(status_bits::SYNC_LINE, 0)];
        assert!(
            matches!(fire_armed(&mut ls, 0, 3, || {}), Err(LinkError::Move(m)) if m.contains("no group armed"))
        );
        assert!(fire_armed(&mut ls, 1, 3, || {}).is_err());
    }

    #[test]
    fn the_urgent_flag_is_read_through_the_link() {
        let flag = Arc::new(AtomicBool::new(false));
        let l = fake(false).with_urgent(Some(flag.clone()));
        assert!(!l.urgent());
        flag.store(true, Ordering::SeqCst);
        assert!(l.urgent());
        assert!(!fake(false).urgent(), "no flag: never urgent");
    }

    #[test]
    fn host_link_reads_writes_and_reports_refusals() {
        let mut l = fake(false);
        let id = l.build_id().unwrap();
        assert_eq!(
            (id.axes, id.step_bits, id.clock_hz, id.version),
            (2, 20, 50_000_000, 0x10)
        );
        l.write(Reg::Board(BoardReg::PulseWidth), 7).unwrap();
        assert_eq!(l.read(Reg::Board(BoardReg::PulseWidth)), Ok(7));
        let st = l.axis_state(1).unwrap();
        assert!(st.busy && st.run == AxisRun::Running && st.hall);
        assert_eq!(
            l.read(Reg::Board(BoardReg::Session)),
            Err(LinkError::Refused {
                addr: 0x05,
                status: Status::BadAddress
            })
        );
        let mut bad = fake(true);
        assert!(matches!(
            bad.read(Reg::Board(BoardReg::Id)),
            Err(LinkError::Crc { .. })
        ));
        assert_eq!(bad.retransmitted, u64::from(RETRANSMITS));
        let mut closed = HostLink::new(std::io::Cursor::new(Vec::<u8>::new()));
        assert!(matches!(
            closed.read(Reg::Board(BoardReg::Id)),
            Err(LinkError::Io(_))
        ));
    }

    #[test]
    fn a_stale_reply_to_an_earlier_request_is_skipped() {
        // The reply to a request of a host that died (seq 200), then the answer to ours.
        let stale = Reply {
            seq: 200,
            status: Status::Ok,
            data: 1,
        };
        let ours = Reply {
            seq: 0,
            status: Status::Ok,
            data: 42,
        };
        let mut bytes = stale.encode().to_vec();
        bytes.extend_from_slice(&ours.encode());
        struct Canned(std::io::Cursor<Vec<u8>>);
        impl std::io::Read for Canned {
            fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
                self.0.read(b)
            }
        }
        impl std::io::Write for Canned {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                Ok(b.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let mut l = HostLink::new(Canned(std::io::Cursor::new(bytes)));
        assert_eq!(l.read(Reg::Board(BoardReg::Session)), Ok(42));
    }

    proptest! {
        #[test]
        fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
            let _ = Request::decode(&bytes);
            let _ = Reply::decode(&bytes);
            let _ = BulkWrite::decode(&bytes);
            let mut d = ReplyDecoder::new();
            let _ = d.push(&bytes);
            let _ = AxisState::decode(u32::from_le_bytes([
                bytes.first().copied().unwrap_or(0), 0, 0, 0]));
        }

        #[test]
        fn decoder_finds_replies_in_noise(
            noise in proptest::collection::vec(any::<u8>().prop_filter("no sync", |b| *b != REPLY_SYNC), 0..20),
            seq in any::<u8>(), data in any::<u32>(), split in 0usize..30,
        ) {
            let r = Reply { seq, status: Status::Ok, data };
            let mut stream = noise.clone();
            stream.extend_from_slice(&r.encode());
            stream.extend_from_slice(&r.encode());
            let mut d = ReplyDecoder::new();
            let split = split.min(stream.len());
            let mut got = d.push(&stream[..split]);
            got.extend(d.push(&stream[split..]));
            let ok: Vec<Reply> = got.into_iter().filter_map(Result::ok).collect();
            prop_assert_eq!(ok, vec![r, r]);
        }

        #[test]
        fn bulk_writes_round_trip(seq in any::<u8>(), addr in any::<u16>(),
                                  data in proptest::collection::vec(any::<u8>(), 0..=BULK_MAX)) {
            let w = BulkWrite { seq, addr, data };
            let f = w.encode().unwrap();
            prop_assert_eq!(f.len(), w.data.len() + BULK_OVERHEAD);
            prop_assert_eq!(BulkWrite::decode(&f), Ok(w));
        }

        #[test]
        fn requests_round_trip(seq in any::<u8>(), addr in any::<u16>(), data in any::<u32>(), wr in any::<bool>()) {
            let r = Request { seq, command: if wr { Command::Write } else { Command::Read }, addr, data };
            prop_assert_eq!(Request::decode(&r.encode()), Ok(r));
        }
    }
}
