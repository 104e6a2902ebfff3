//! A per-axis FIFO of periods with a fixed maximum depth (no allocation).
//!
//! The engine knows, when a period is computed, the tick at which the pulse unit will load
//! it (it leaves the FIFO then). That tick is all occupancy depends on, so each entry is
//! kept as its leave tick.

use super::TdmError;

/// Deepest FIFO a board supports.
pub const MAX_FIFO_DEPTH: usize = 64;

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Fifo {
    leave: [u64; MAX_FIFO_DEPTH],
    head: usize,
    len: usize,
    depth: usize,
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
            leave: [0; MAX_FIFO_DEPTH],
            head: 0,
            len: 0,
            depth,
        })
    }

    pub fn depth(&self) -> usize {
        self.depth
    }

    /// First tick at which there is room for one more period: 0 while fewer than `depth`
    /// periods were ever pushed, else the leave tick of the oldest of the last `depth`.
    #[inline]
    pub fn room_tick(&self) -> u64 {
        if self.len < self.depth {
            0
        } else {
            self.leave[self.head]
        }
    }

    /// Pushes a period that leaves at tick `leave`. The caller has checked
    /// [`room_tick`](Self::room_tick), so the oldest entry it forgets has already left.
    #[inline]
    pub fn push(&mut self, leave: u64) {
        if self.len < self.depth {
            let mut i = self.head + self.len;
            if i >= self.depth {
                i -= self.depth;
            }
            self.leave[i] = leave;
            self.len += 1;
        } else {
            self.leave[self.head] = leave;
            self.head += 1;
            if self.head == self.depth {
                self.head = 0;
            }
        }
    }

    /// Periods in the FIFO at tick `t`, of those pushed at or before `t`.
    pub fn occupancy_at(&self, t: u64) -> usize {
        (0..self.len)
            .filter(|&j| self.leave[(self.head + j) % self.depth] > t)
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
}
