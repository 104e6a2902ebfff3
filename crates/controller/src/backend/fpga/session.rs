//! The board's session across a restart of the host, and armed groups that outlive theirs.
//!
//! The host keeps what it wrote to the board's `Session` register, with what of each
//! axis's motion lives only in the host ([`LinkSession`]), in the store. A restarted host
//! that reads its stored token back adopts the board: a computed move runs on to its end,
//! a streamed one is halted (its code came from the host that died). Any other readback
//! means the board was reset or lost power while the host was down: every axis is
//! untrusted until homed.
//!
//! A group armed for the SYNC line lives no longer than its group: it is disarmed when it
//! is not fired within [`ARM_LIFETIME`], when the link comes back after a failure and
//! when a restarted host finds it (the group's `ctl` has given up on it by then). The
//! board bounds it too (`ArmTimeout`, written with every `Arm`, sync.rs), for a host that
//! dies: a share it cut is told as the fault `arm_expired` when the host next reads it.

use super::{FpgaBackend, Running};
use crate::backend::PinEvent;
use crate::store::{Fold, LinkSession};
use multistep_link::{status_bits, AxisReg, BoardReg, LinkError, Reg};
use std::time::{Duration, Instant};

/// Keeps the link session (in the store), at start-up and whenever it changes.
pub type SessionKeeper = Box<dyn FnMut(&LinkSession) -> Result<(), String> + Send>;

/// The longest a share of a cross-board group stays armed: `ctl group` fires within its
/// 10 s wait for every board to be ready, so an older share belongs to a group that failed.
pub const ARM_LIFETIME: Duration = Duration::from_secs(30);

/// How much longer than the host's [`ARM_LIFETIME`] the board keeps a share armed
/// (`ArmTimeout`): the host normally disarms first and says why; the board's bound is for a
/// host that died or stalled.
pub(super) const BOARD_ARM_MARGIN: f64 = 1.5;
/// How often the streams are topped up while a durable write runs beside (the poll's).
const FEED_DURING_WRITE: Duration = Duration::from_millis(1);

/// The fault of an axis whose share the board cut after its `ArmTimeout`.
fn arm_expired_why(lifetime: Duration) -> String {
    format!(
        "arm_expired: the board cut the axis's share of a cross-board group armed over {} s \
         without a SYNC edge (the host did not fire or disarm it); it never started",
        lifetime.as_secs_f64() * BOARD_ARM_MARGIN
    )
}

/// The end tick of a motion adopted from the host before a restart: not known.
pub(super) const UNKNOWN_END: u64 = u64::MAX;

impl FpgaBackend {
    /// The session as it is now, `streamed` (of them `rolled`) and `armed` axes added (a
    /// start about to go).
    fn session_record(&self, streamed: u32, rolled: u32, armed: u32) -> LinkSession {
        let mut r = LinkSession {
            token: self.session,
            // a running axis's wraps are kept once it rests (`Running::wraps`)
            offsets: self
                .axes
                .iter()
                .map(|a| a.offset - a.running.as_ref().map_or(0, |r| r.wraps))
                .collect(),
            streamed: streamed | rolled,
            rolled,
            armed: self.armed | armed,
            folding: self.folding,
        };
        for (i, a) in self.axes.iter().enumerate() {
            if a.running.is_some() && a.feed.is_some() {
                r.streamed |= 1 << i;
            }
            // pieces still to load
            let roll = a.running.as_ref().and_then(|r| r.roll.as_ref());
            if roll.is_some_and(|r| !r.loaded()) {
                r.streamed |= 1 << i;
                r.rolled |= 1 << i;
            }
        }
        r
    }

    /// Keeps the session when it changed; `streamed` and `armed`: axes of a start about to
    /// go, kept before it goes (a host killed right after still knows what they run).
    pub(super) fn keep_session_with(&mut self, streamed: u32, rolled: u32, armed: u32) {
        // A board claimed anew (its counts lost) is kept only once the loss is told, and
        // so stored by the board: a host killed between the two would find its own token
        // at the next start and trust counts the board lost.
        if self
            .events
            .iter()
            .any(|(_, e)| matches!(e, PinEvent::Lost { .. }))
        {
            return;
        }
        let r = self.session_record(streamed, rolled, armed);
        if self.kept.as_ref() == Some(&r) {
            return;
        }
        let Some(mut keep) = self.keep.take() else {
            return;
        };
        let mut kept = Ok(());
        self.fed_during(&mut || kept = keep(&r));
        self.keep = Some(keep);
        if let Err(e) = kept {
            // said once: tried again at the next change, not at every poll
            eprintln!(
                "warning: board link {}: the session is not stored ({e}); a restart \
                 may not adopt the board",
                self.name
            );
        }
        self.kept = Some(r);
    }

    /// A running axis's count shifted by `delta` in the host's reading (its `offset`): the
    /// board's counter is not writable while it runs.
    pub(super) fn shift_reading(&mut self, axis: usize, delta: i64) {
        let ax = &mut self.axes[axis];
        ax.offset += delta;
        ax.count += delta;
        if let Some(f) = ax.feed.as_mut() {
            f.count0 += delta;
        }
    }

    /// Runs `write` (a durable write: an fsync, up to 170 ms measured with a disk-writing
    /// job beside it) on a thread of its own while this one, holding the board, keeps
    /// every stream fed: the streams' lead is 50 ms ([`super::stream::TRACK_LEAD_S`]).
    pub(super) fn fed_during(&mut self, write: &mut (dyn FnMut() + Send)) {
        let feeding = self
            .axes
            .iter()
            .any(|a| a.running.is_some() && a.feed.is_some());
        if self.writing || self.link.is_none() || !feeding {
            return write();
        }
        self.writing = true;
        let done = std::thread::scope(|s| {
            let w = s.spawn(write);
            while !w.is_finished() {
                if self.link.is_some() {
                    if let Err(e) = self.keep_fed() {
                        self.failed(e);
                    }
                }
                std::thread::sleep(FEED_DURING_WRITE);
            }
            w.join()
        });
        self.writing = false;
        if let Err(panic) = done {
            std::panic::resume_unwind(panic);
        }
    }

    /// Reads the count of every axis a stream feeds and tops its stream up to the lead
    /// from there, and loads the pieces due of a move loaded while it runs (the board is
    /// read in full at the next poll).
    fn keep_fed(&mut self) -> Result<(), LinkError> {
        for i in 0..self.axes.len() {
            let ax = &self.axes[i];
            let rolls = ax.running.as_ref().is_some_and(|r| r.roll.is_some());
            if rolls {
                self.read_count(i)?;
                self.feed_roll(i)?;
                continue;
            }
            if ax.running.is_none() || ax.feed.as_ref().is_none_or(|f| f.lost.is_some()) {
                continue;
            }
            self.read_count(i)?;
        }
        self.feed_streams()
    }

    pub(super) fn keep_session_now(&mut self) {
        self.keep_session_with(0, 0, 0);
    }

    /// Connecting with the session a host stored before: adopts the board when it still
    /// holds that token, else claims it anew and untrusts every axis.
    pub(super) fn resume(&mut self, before: &LinkSession) -> Result<(), LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let read = l.read(Reg::Board(BoardReg::Session))?;
        if read != 0 && read == before.token {
            self.session = read;
            self.adopted = true;
            return self.adopt(before);
        }
        let token = multistep_link::session_token();
        l.write(Reg::Board(BoardReg::Session), token)?;
        self.session = token;
        for i in 0..self.axes.len() {
            let why = format!(
                "the board was reset or lost power while the host was down (its session \
                 register reads {read:#010x}, not the stored {:#010x}); untrusted until homed",
                before.token
            );
            self.events.push_back((i, PinEvent::Lost { why }));
        }
        Ok(())
    }

    /// The board as the host left it: a running computed move runs on (its count is the
    /// board's counter plus the kept offset), a streamed one halts at once (the count
    /// exact), an armed group is disarmed.
    fn adopt(&mut self, before: &LinkSession) -> Result<(), LinkError> {
        let mask = self.mask();
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let status = l.read(Reg::Board(BoardReg::Status))?;
        let busy = l.read(Reg::Board(BoardReg::Busy))?;
        let armed = if status & status_bits::ARMED != 0 {
            // the kept mask, or every busy axis when it was not kept
            match before.armed & busy & mask {
                0 => busy & mask,
                m => m,
            }
        } else {
            0
        };
        // the board cut the group armed before the restart itself (`ArmTimeout`)
        let expired = if status & (status_bits::ARM_EXPIRED | status_bits::ARMED)
            == status_bits::ARM_EXPIRED
        {
            before.armed & mask
        } else {
            0
        };
        let halt = armed | (before.streamed & busy & mask);
        if halt != 0 {
            l.write(Reg::Board(BoardReg::Stop), halt)?;
        }
        for i in 0..self.axes.len() {
            let a = i as u32;
            let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
            let st = l.axis_state(a)?;
            let register = l.read(Reg::Axis(a, AxisReg::Position))?;
            let offset = match before.folding {
                // the host died folding this axis's offset in: done if the register moved
                Some(f) if f.axis == i && register != f.register => 0,
                _ => before.offsets.get(i).copied().unwrap_or(0),
            };
            let count = super::readback::count(register, offset);
            let ax = &mut self.axes[i];
            ax.count = count;
            ax.offset = offset;
            if armed >> i & 1 == 1 {
                let why = "disarmed: the host restarted while the axis's share of a \
                           cross-board group was armed; it never started"
                    .to_string();
                self.events.push_back((i, PinEvent::Late { why }));
            } else if expired >> i & 1 == 1 {
                let why = arm_expired_why(self.arm_lifetime);
                self.events.push_back((i, PinEvent::Late { why }));
            } else if before.streamed >> i & 1 == 1 && busy >> i & 1 == 1 {
                let why = "host_restarted: the host restarted while it fed the motion (a \
                           stream, or the pieces of a move loaded while it ran), so the rest \
                           of it was lost; the axis was halted at once (the count is exact)"
                    .to_string();
                self.events.push_back((i, PinEvent::Late { why }));
            } else if before.rolled >> i & 1 == 1 && !st.busy {
                let why = "host_restarted: the host restarted while it loaded the move's \
                           pieces as it ran, so the board ended it after the pieces it held, \
                           short of its target (the count is exact)"
                    .to_string();
                self.events.push_back((i, PinEvent::Late { why }));
            } else if st.busy {
                ax.running = Some(Running {
                    dir: if st.dir { 1 } else { -1 },
                    stop_on_sensor: None,
                    stopping: false,
                    end_tick: UNKNOWN_END,
                    ramp_steps: 0,
                    wraps: 0,
                    roll: None,
                });
                continue;
            }
            if ax.offset != 0 {
                // at rest: folded into the board's counter once the session can be kept
                self.fold_due |= 1 << i;
            }
        }
        if armed != 0 {
            eprintln!(
                "warning: board link {}: a cross-board group armed before the restart was \
                 disarmed (axes {armed:#b})",
                self.name
            );
        }
        Ok(())
    }

    /// Disarms the armed group (`Stop` of its axes: a stop cancels it), and says why on
    /// each of its axes, which end there.
    pub(super) fn disarm(&mut self, why: &str) -> Result<(), LinkError> {
        let armed = self.armed;
        let all = self.mask();
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let status = l.read(Reg::Board(BoardReg::Status))?;
        if status & status_bits::ARMED == 0 && self.armed_at.is_none() {
            return Ok(());
        }
        if status & status_bits::ARMED == 0 && status & status_bits::ARM_EXPIRED != 0 {
            self.tell_arm_expired(armed & all);
        } else if status & status_bits::ARMED != 0 {
            let busy = l.read(Reg::Board(BoardReg::Busy))?;
            let mask = match armed & busy {
                0 => busy & all,
                m => m,
            };
            l.write(Reg::Board(BoardReg::Stop), mask)?;
            eprintln!(
                "warning: board link {}: the armed group was disarmed: {why}",
                self.name
            );
            let why = format!("disarmed: {why}; the axis's share of the group never started");
            self.end_share(mask, &why);
        }
        self.armed = 0;
        self.armed_at = None;
        self.keep_session_now();
        Ok(())
    }

    /// Disarms a group armed longer than [`ARM_LIFETIME`]; forgets one that went.
    pub(super) fn expire_armed(&mut self) -> Result<(), LinkError> {
        let Some(at) = self.armed_at else {
            return Ok(());
        };
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let status = l.read(Reg::Board(BoardReg::Status))?;
        if status & status_bits::ARMED == 0 {
            // fired, stopped, reset or cut by the board: nothing waits any more
            if status & status_bits::ARM_EXPIRED != 0 {
                self.tell_arm_expired(self.armed & self.mask());
            }
            self.armed = 0;
            self.armed_at = None;
            return Ok(());
        }
        if at.elapsed() >= self.arm_lifetime {
            let why = format!(
                "it was not fired within {} s",
                self.arm_lifetime.as_secs_f64()
            );
            return self.disarm(&why);
        }
        Ok(())
    }

    /// The link answers again after a failure: whatever group is armed on the board has
    /// been given up by its `ctl` (its link failed), so it is disarmed.
    pub(super) fn after_reconnect(&mut self) {
        if let Err(e) = self.disarm("the board's link failed while it was armed") {
            self.failed(e);
        }
    }

    /// After each poll's read: the deferred set-up, an armed group's lifetime, the kept
    /// session.
    pub(super) fn after_read(&mut self) {
        if self.link.is_none() {
            return;
        }
        // a deferred setup, or a reset board's claim the link cut short: done again until
        // it is through
        if self.setup_due || self.reclaim {
            match self.setup() {
                Ok(()) => self.setup_due = false,
                Err(e) => {
                    self.failed(e);
                }
            }
        }
        if let Err(e) = self.expire_armed() {
            self.failed(e);
        }
        if let Err(e) = self.halt_starved_adoptions() {
            self.failed(e);
        }
        for i in 0..self.axes.len() {
            let ready = self.keep.is_some() || !self.adopted;
            if ready && self.fold_due >> i & 1 == 1 && self.axes[i].running.is_none() {
                if let Err(e) = self.fold_offset(i) {
                    self.failed(e);
                    return;
                }
            }
        }
        self.keep_session_now();
    }

    /// An idle axis's offset folded into the board's `Position` register, so the register
    /// holds the count. Crash-safe: the fold is kept in the session before the register is
    /// written and cleared after, so a host killed between the two reads which one the
    /// board holds (`adopt`). An adopted board's waits until the session can be kept
    /// (the store is connected after the board); a backend with no store folds at once.
    pub(super) fn fold_offset(&mut self, i: usize) -> Result<(), LinkError> {
        let ax = &self.axes[i];
        if ax.offset == 0 {
            self.fold_due &= !(1 << i);
            return Ok(());
        }
        if self.keep.is_none() && self.adopted {
            self.fold_due |= 1 << i;
            return Ok(());
        }
        let (count, offset) = (ax.count, ax.offset);
        self.folding = Some(Fold {
            axis: i,
            register: super::readback::register(count - offset),
            offset,
        });
        self.keep_session_now();
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        l.write(
            Reg::Axis(i as u32, AxisReg::Position),
            super::readback::register(count),
        )?;
        self.axes[i].offset = 0;
        self.folding = None;
        self.fold_due &= !(1 << i);
        self.keep_session_now();
        Ok(())
    }

    /// An adopted motion that underruns is a stream no host feeds (its kept mask was
    /// lost): halted at once, so it is never busy forever.
    fn halt_starved_adoptions(&mut self) -> Result<(), LinkError> {
        for i in 0..self.axes.len() {
            let adopted = self.axes[i]
                .running
                .as_ref()
                .is_some_and(|r| r.end_tick == UNKNOWN_END);
            if !adopted {
                continue;
            }
            let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
            if !l.axis_state(i as u32)?.underrun {
                continue;
            }
            l.write(Reg::Board(BoardReg::Stop), 1 << i)?;
            self.read_count(i)?;
            let ax = &mut self.axes[i];
            ax.running = None;
            self.fold_offset(i)?;
            let ax = &mut self.axes[i];
            ax.speed = 0.0;
            self.events.push_back((i, PinEvent::End { end: self.now }));
            let why = "host_restarted: the adopted motion ran out of steps to make (a stream \
                       of the host before the restart); the axis was halted at once (the \
                       count is exact)"
                .to_string();
            self.events.push_back((i, PinEvent::Late { why }));
        }
        Ok(())
    }

    /// The board cut the group armed on `mask` (its `ArmTimeout`): each axis ends there
    /// with the fault `arm_expired`.
    fn tell_arm_expired(&mut self, mask: u32) {
        eprintln!(
            "warning: board link {}: the board cut the armed group (axes {mask:#b}) after its \
             ArmTimeout",
            self.name
        );
        self.end_share(mask, &arm_expired_why(self.arm_lifetime));
    }

    /// The axes of `mask`, whose share of a group never started, end there with `why`.
    fn end_share(&mut self, mask: u32, why: &str) {
        for i in 0..self.axes.len() {
            if mask >> i & 1 == 0 {
                continue;
            }
            let ax = &mut self.axes[i];
            ax.feed = None;
            ax.speed = 0.0;
            if ax.running.take().is_some() {
                self.events.push_back((i, PinEvent::End { end: self.now }));
            }
            let why = why.to_string();
            self.events.push_back((i, PinEvent::Late { why }));
        }
    }

    /// A group was armed now on `mask`.
    pub(super) fn armed_now(&mut self, mask: u32) {
        self.armed = mask;
        self.armed_at = Some(Instant::now());
    }
}

#[cfg(test)]
mod tests;
