//! The register map as types (`rtl/board/ms_regs.v`): board and axis registers, the
//! values they hold (levels, an axis's state, the build id, the status bits) and the
//! position registers as counts.

use crate::{CoreParams, FitError, LinkError, Widths};

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
    /// means the board lost its state ([`crate::HostLink::claim`]).
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
    /// R: the free-running clock count (never reset; wraps at 2^32): the host stamps its
    /// reads with its own clock and fits the board's crystal against it.
    Ticks = 0x1A,
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
    /// Bulk writes only ([`crate::BulkWrite`]): bytes of the streamed schedule (or of the chain
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

/// The flags of `AxisReg::State` after its 3-bit run code, in bit order from bit 3.
const STATE_FLAGS: u32 = 10;

impl AxisState {
    /// An idle axis, every flag clear.
    pub const IDLE: AxisState = AxisState {
        run: AxisRun::Idle,
        busy: false,
        underrun: false,
        stopped: false,
        estopped: false,
        hall_flag: false,
        hall: false,
        limit: false,
        dir: false,
        stream_armed: false,
        stream_fault: false,
    };

    fn flags(&self) -> [bool; STATE_FLAGS as usize] {
        [
            self.busy,
            self.underrun,
            self.stopped,
            self.estopped,
            self.hall_flag,
            self.hall,
            self.limit,
            self.dir,
            self.stream_armed,
            self.stream_fault,
        ]
    }

    /// The register's value (what the board's `ms_regs.v` reports; [`AxisState::decode`]
    /// inverts it).
    pub fn encode(&self) -> u32 {
        let flags = self.flags();
        let on = flags.iter().enumerate().filter(|(_, &b)| b);
        on.fold(self.run as u32, |v, (i, _)| v | 1 << (3 + i))
    }

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
    /// The per-step recurrence's digit bits, if the core has it (`Config` byte 0: bit 7,
    /// the digit in bits 6–3, the radix bits in 2–0).
    pub recurrence: Option<u32>,
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
            radix_bits: b(config, 0) & 7,
            recurrence: (b(config, 0) & 0x80 != 0).then_some((b(config, 0) >> 3) & 15),
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
            recurrence: w.recur,
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

/// Each axis's stream buffer on the board (`ms_board`'s `LB` = 9).
pub const STREAM_BUFFER: u64 = 512;

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_axis_state_round_trips() {
        for v in 0..1u32 << (3 + STATE_FLAGS) {
            match AxisState::decode(v) {
                Ok(s) => assert_eq!(s.encode(), v, "{v:#x}"),
                Err(_) => assert!(v & 7 > 4, "{v:#x}"),
            }
        }
        let s = AxisState {
            run: AxisRun::Running,
            busy: true,
            dir: true,
            ..AxisState::IDLE
        };
        assert_eq!(s.encode(), 1 | 1 << 3 | 1 << 10);
    }

    #[test]
    fn a_position_reads_back_sign_extended_and_writes_back_its_low_bits() {
        assert_eq!(position_count(0xFFFF_FFD6, 0), -42);
        assert_eq!(position_count(0xFFFF_FFD6, 1 << 32), (1 << 32) - 42);
        assert_eq!(position_count(7, -10), -3);
        assert_eq!(position_register(-42), 0xFFFF_FFD6);
        assert_eq!(position_register((1 << 32) + 5), 5);
        assert_eq!(position_count(position_register(-5_000_000), 0), -5_000_000);
    }
}
