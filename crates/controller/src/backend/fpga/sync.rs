//! The cross-board start on the FPGA board (docs/HDL.md "Cross-board start"): a group
//! loaded as for `Start` but armed (`Arm`), started by a fall of the shared SYNC line
//! (`Fire` on any board), and the count each board latched at that fall (`SyncTick`).
//! A build without the SYNC logic refuses these registers (bad address).

use super::{FpgaBackend, Launch};
use crate::backend::{no_sync, SyncState};
use crate::error::CtlError;
use multistep_link::{self as link, status_bits, BoardReg, LinkError, Reg, Status};

impl FpgaBackend {
    /// The write that lets a loaded group go: `Arm` while arming, else `Start`.
    pub(super) fn go_write(&self, mask: u32) -> link::RegWrite {
        if self.arming {
            link::arm_write(mask)
        } else {
            link::start_write(mask)
        }
    }

    /// The board's own bound on the group armed next (`ArmTimeout`, docs/HDL.md), in its
    /// clocks: the host's arm lifetime times [`super::session::BOARD_ARM_MARGIN`], at most
    /// 2^32 − 1 (86 s at 50 MHz), at least 1.
    pub(super) fn arm_timeout_write(&self) -> link::RegWrite {
        let s = self.arm_lifetime.as_secs_f64() * super::session::BOARD_ARM_MARGIN;
        link::RegWrite {
            reg: Reg::Board(BoardReg::ArmTimeout),
            data: (s * self.params.clock_hz).clamp(1.0, f64::from(u32::MAX)) as u32,
        }
    }

    /// Loads `moves` as a start does and arms them. Until the SYNC fall the board reports
    /// the group pending, so the axes count as moving.
    pub(super) fn arm_moves(
        &mut self,
        moves: Vec<Launch>,
        now: u64,
    ) -> Result<(u64, Vec<u64>), CtlError> {
        use crate::backend::BoardBackend;
        self.arming = true;
        let r = self.start(moves, None, &Default::default(), now);
        self.arming = false;
        r
    }

    fn sync_err(&mut self, e: LinkError) -> CtlError {
        match e {
            LinkError::Refused {
                status: Status::BadAddress,
                ..
            } => no_sync(&self.name),
            e => self.failed(e),
        }
    }

    pub(super) fn fire_sync(&mut self) -> Result<(), CtlError> {
        let r = self.link()?.write(Reg::Board(BoardReg::Fire), 1);
        r.map_err(|e| self.sync_err(e))
    }

    pub(super) fn read_sync(&mut self) -> Result<SyncState, CtlError> {
        let l = self.link()?;
        let r = l
            .read(Reg::Board(BoardReg::Status))
            .and_then(|s| Ok((s, l.read(Reg::Board(BoardReg::SyncTick))?)));
        let (s, tick) = r.map_err(|e| self.sync_err(e))?;
        Ok(SyncState {
            armed: s & status_bits::ARMED != 0,
            ready: s & status_bits::READY != 0,
            late: s & status_bits::LATE != 0,
            line: s & status_bits::SYNC_LINE != 0,
            tick,
        })
    }
}
