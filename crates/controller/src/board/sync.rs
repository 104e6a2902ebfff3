//! Groups across boards (docs/HDL.md "Cross-board start"): a group armed on each board
//! starts when one of them pulls the shared SYNC line low.

use super::{Board, PendingGroup};
use crate::backend::SyncState;
use crate::error::CtlError;

impl Board {
    /// [`Board::start_group_move`], but the group waits for the SYNC line's fall: its axes
    /// count as moving from now on (the board reports them pending, then busy).
    pub fn arm_group_move(
        &mut self,
        pending: PendingGroup,
        now: u64,
    ) -> Result<Vec<i64>, CtlError> {
        self.check_sync()?;
        self.arming = true;
        let r = self.start_group_move(pending, None, now);
        self.arming = false;
        r
    }

    /// Refuses at once on a board without a SYNC line (before planning: an arm there is
    /// refused for that, not for what its axes do).
    pub fn check_sync(&mut self) -> Result<(), CtlError> {
        self.pins.sync_line().map(|_| ())
    }

    /// Pulls the SYNC line low: every board on it starts its armed group.
    pub fn fire(&mut self, now: u64) -> Result<(), CtlError> {
        self.advance(now);
        if self.estopped {
            return Err(CtlError::EStopped);
        }
        self.pins.sync_line()?.fire()
    }

    /// The SYNC line's state and the count latched at its last fall.
    pub fn sync_state(&mut self, now: u64) -> Result<SyncState, CtlError> {
        self.advance(now);
        self.pins.sync_line()?.sync_state()
    }
}
