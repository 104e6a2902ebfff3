//! A per-axis FIFO of periods with a fixed maximum depth (no allocation).
//!
//! The engine knows, when a period is computed, the tick at which the pulse unit will load
//! it (it leaves the FIFO then). That tick is all occupancy depends on, so each entry is
//! kept as its leave tick.

use super::TdmError;

/// Deepest FIFO a board supports (the ULX3S-85F build's chained axes have 128).
pub const MAX_FIFO_DEPTH: usize = 128;
// `% MAX_FIFO_DEPTH` below is a mask (it only spares bounds checks)
const _: () = assert!(MAX_FIFO_DEPTH.is_power_of_two());

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fifo {
    /// Pushes so far (mod 2^64): push n goes to slot n % MAX_FIFO_DEPTH, so the oldest
    /// the FIFO may still hold, `depth` pushes back, is in slot
    /// `(pushes − depth) % MAX_FIFO_DEPTH` (with fewer than `depth` pushes that slot was never written: a slot after every
    /// push so far, as `depth ≤ MAX_FIFO_DEPTH`). No wrap test per push.
    pushes: usize,
    depth: usize,
    /// `MAX_FIFO_DEPTH − depth`: the room slot is `(pushes + back) % MAX_FIFO_DEPTH` (an add, which
    /// needs no copy of the count, where a subtract does).
    back: usize,
    /// Leave tick of each of the last MAX_FIFO_DEPTH pushes; a slot never written reads 0.
    leave: [u64; MAX_FIFO_DEPTH],
}

impl Fifo {
    pub fn new(depth: usize) -> Result<Fifo, TdmError> {
        if depth == 0 || depth > MAX_FIFO_DEPTH {
            return Err(TdmError::FifoDepth {
                depth,
                max: MAX_FIFO_DEPTH,
            });
        }
        Ok(Fifo {
            pushes: 0,
            depth,
            back: MAX_FIFO_DEPTH - depth,
            leave: [0; MAX_FIFO_DEPTH],
        })
    }

    pub fn depth(&self) -> usize {
        self.depth
    }

    /// First tick at which there is room for one more period: 0 while fewer than `depth`
    /// periods were ever pushed, else the leave tick of the oldest of the last `depth`.
    #[inline]
    pub fn room_tick(&self) -> u64 {
        self.leave[self.pushes.wrapping_sub(self.depth) % MAX_FIFO_DEPTH]
    }

    /// Pushes a period that leaves at tick `leave`. The caller has checked
    /// [`room_tick`](Self::room_tick), so the oldest entry it forgets has already left.
    #[inline]
    pub fn push(&mut self, leave: u64) {
        self.leave[self.pushes % MAX_FIFO_DEPTH] = leave;
        self.pushes = self.pushes.wrapping_add(1);
    }

    /// [`push`](Self::push), then [`room_tick`](Self::room_tick): the engine asks for the
    /// room right after each push, and one call keeps the count in a register.
    #[inline]
    pub fn push_then_room(&mut self, leave: u64) -> u64 {
        let n = self.pushes;
        self.leave[n % MAX_FIFO_DEPTH] = leave;
        let n = n.wrapping_add(1);
        self.pushes = n;
        self.leave[n.wrapping_sub(self.depth) % MAX_FIFO_DEPTH]
    }

    /// [`push_then_room`](Self::push_then_room) as push number `n` (0-based), for a
    /// caller that counts its pushes already (the board's pulse unit counts its periods):
    /// this FIFO's own count is left alone, so use either these `_nth` forms or the
    /// counting ones on one FIFO, not both.
    #[inline]
    pub fn push_nth_then_room(&mut self, n: u64, leave: u64) -> u64 {
        self.push_nth(n, leave);
        self.room_after(n + 1)
    }

    /// [`push`](Self::push) as push number `n` (0-based), counted by the caller.
    #[inline]
    pub fn push_nth(&mut self, n: u64, leave: u64) {
        self.leave[n as usize % MAX_FIFO_DEPTH] = leave;
    }

    /// [`room_tick`](Self::room_tick) after `pushes` pushes counted by the caller.
    #[inline]
    pub fn room_after(&self, pushes: u64) -> u64 {
        self.leave[(pushes as usize).wrapping_add(self.back) % MAX_FIFO_DEPTH]
    }

    /// Leave tick of push number `n` (0-based, counted by the caller), while it is among
    /// the last MAX_FIFO_DEPTH.
    #[inline]
    pub fn leave_of(&self, n: u64) -> u64 {
        self.leave[n as usize % MAX_FIFO_DEPTH]
    }

    /// Periods in the FIFO at tick `t`, of those pushed at or before `t` (by the counting
    /// forms: the `_nth` ones leave the count alone).
    pub fn occupancy_at(&self, t: u64) -> usize {
        // the last `depth` pushes; slots never written read 0, never after t
        (1..=self.depth)
            .filter(|&i| self.leave[self.pushes.wrapping_sub(i) % MAX_FIFO_DEPTH] > t)
            .count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_depth_zero_and_too_deep() {
        assert!(matches!(Fifo::new(0), Err(TdmError::FifoDepth { .. })));
        assert!(Fifo::new(MAX_FIFO_DEPTH + 1).is_err());
        assert!(Fifo::new(MAX_FIFO_DEPTH).is_ok());
    }

    #[test]
    fn room_opens_when_the_oldest_of_the_last_depth_entries_leaves() {
        let mut f = Fifo::new(3).unwrap();
        for (n, leave) in [100u64, 200, 300].into_iter().enumerate() {
            assert_eq!(f.room_tick(), 0, "room while only {n} were pushed");
            f.push(leave);
        }
        assert_eq!(f.room_tick(), 100);
        assert_eq!(f.occupancy_at(99), 3);
        assert_eq!(f.occupancy_at(100), 2);
        f.push(400);
        assert_eq!(f.room_tick(), 200);
        f.push(500);
        f.push(600);
        assert_eq!(f.room_tick(), 400);
        assert_eq!(f.occupancy_at(450), 2);
    }

    /// Room and occupancy against a queue of leave ticks, for depths on both sides of
    /// half the slot count, over several laps of the slots.
    #[test]
    fn matches_a_queue_of_leave_ticks() {
        for depth in [1, 2, 3, 31, 32, 33, 63, MAX_FIFO_DEPTH] {
            let mut f = Fifo::new(depth).unwrap();
            let mut counted = Fifo::new(depth).unwrap();
            let mut q = std::collections::VecDeque::new();
            for n in 0..5 * MAX_FIFO_DEPTH as u64 {
                let room = if q.len() < depth { 0 } else { q[0] };
                assert_eq!(f.room_tick(), room, "depth {depth}, push {n}");
                let leave = 10 * n + n % 7 + 1;
                if q.len() == depth {
                    q.pop_front();
                }
                q.push_back(leave);
                if n % 2 == 0 {
                    f.push(leave);
                } else {
                    let room = f.push_then_room(leave);
                    assert_eq!(room, f.room_tick());
                }
                // the same pushes counted by the caller
                let room = counted.push_nth_then_room(n, leave);
                assert_eq!((room, counted.room_after(n + 1)), (f.room_tick(), room));
                let t = leave.saturating_sub(15);
                let held = q.iter().filter(|&&l| l > t).count();
                assert_eq!(f.occupancy_at(t), held, "depth {depth}, push {n}");
            }
        }
    }
}
