//! Which axis the calculator serves next.
//!
//! An axis is eligible at tick `t` when steps remain to compute and its FIFO has room
//! (`room[m] <= t`; a finished axis has `room[m] = u64::MAX`). Both policies only choose among eligible axes; when none is eligible
//! the calculator idles until the earliest room tick.

use super::board::MAX_AXES;
use super::TdmError;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Policy {
    /// Seed 000 (Fig. 7): compute for axis m if its FIFO has room and steps remain, else go
    /// to m+1; after serving m, go on with m+1.
    #[default]
    RoundRobin,
    /// Serve the eligible axis whose FIFO runs dry first (earliest tick its next period is
    /// needed); ties go to the lowest axis number.
    EarliestDeadline,
}

impl Policy {
    pub fn name(&self) -> &'static str {
        match self {
            Policy::RoundRobin => "round-robin",
            Policy::EarliestDeadline => "earliest-deadline",
        }
    }

    pub fn parse(s: &str) -> Result<Policy, TdmError> {
        match s {
            "round-robin" => Ok(Policy::RoundRobin),
            "earliest-deadline" => Ok(Policy::EarliestDeadline),
            _ => Err(TdmError::UnknownPolicy),
        }
    }
}

/// Which axes have room: a bit mask of those eligible now and a min-heap of the others by
/// the tick their FIFO gets room, so a decision costs O(log k), not a scan of every axis.
/// Axes with no period left to compute are in neither.
#[derive(Clone, Debug)]
pub struct Queue {
    /// Bit m: axis m has room and periods left.
    eligible: u64,
    /// `(room tick << 6) | m`, a 4-ary min-heap; free slots hold `u64::MAX`, so a node's
    /// four children can be compared without checking which exist.
    heap: [u64; HEAP_SLOTS],
    len: usize,
}

/// Children of node i < 64 are 4i+1 … 4i+4 ≤ 256.
const HEAP_SLOTS: usize = 4 * MAX_AXES + 5;

impl Default for Queue {
    fn default() -> Self {
        Queue {
            eligible: 0,
            heap: [u64::MAX; HEAP_SLOTS],
            len: 0,
        }
    }
}

impl Queue {
    /// Axis m (< 64) has room from tick `room` on; `t` is the current decision tick.
    #[inline]
    pub fn insert(&mut self, m: usize, room: u64, t: u64) {
        if room <= t {
            self.eligible |= 1 << m;
            return;
        }
        let key = (room << 6) | m as u64;
        let mut i = self.len & (MAX_AXES - 1);
        self.len += 1;
        while i > 0 {
            let parent = (i - 1) / 4;
            if self.heap[parent] <= key {
                break;
            }
            self.heap[i] = self.heap[parent];
            i = parent;
        }
        self.heap[i] = key;
    }

    /// Removes the smallest key (the heap is not empty).
    #[inline]
    fn pop(&mut self) -> u64 {
        let top = self.heap[0];
        self.len -= 1;
        let last = self.heap[self.len];
        self.heap[self.len] = u64::MAX;
        if self.len == 0 {
            return top;
        }
        let mut i = 0usize;
        loop {
            let base = 4 * (i & (MAX_AXES - 1)) + 1;
            let (a, b) = (self.heap[base], self.heap[base + 1]);
            let (c, d) = (self.heap[base + 2], self.heap[base + 3]);
            let (ab, ia) = if b < a { (b, base + 1) } else { (a, base) };
            let (cd, ic) = if d < c { (d, base + 3) } else { (c, base + 2) };
            let (min, child) = if cd < ab { (cd, ic) } else { (ab, ia) };
            if min >= last {
                break;
            }
            self.heap[i] = min;
            i = child;
        }
        self.heap[i] = last;
        top
    }

    /// Moves every axis with room at `t` into the eligible mask.
    #[inline]
    fn release(&mut self, t: u64) {
        // ticks stay below 2^57 (checked by the board), so an empty heap's MAX never passes
        while self.heap[0] <= (t << 6) | 63 {
            let key = self.pop();
            self.eligible |= 1 << (key & 63);
        }
    }

    /// The next computation at or after tick `t`: `(start tick, axis)`, or `None` when no
    /// axis has periods left. When none has room at `t` the calculator idles until the
    /// earliest room tick. `need[m]`: tick axis m's next period is needed; `next`: the
    /// round-robin pointer, moved past the chosen axis. The chosen axis leaves the queue;
    /// [`insert`](Self::insert) it again with its new room tick.
    #[inline]
    pub fn pick(
        &mut self,
        policy: Policy,
        t: u64,
        need: &[u64],
        next: &mut usize,
    ) -> Option<(u64, usize)> {
        let mut t = t;
        self.release(t);
        if self.eligible == 0 {
            if self.heap[0] == u64::MAX {
                return None;
            }
            t = self.heap[0] >> 6;
            self.release(t);
        }
        let mask = self.eligible;
        let m = match policy {
            Policy::RoundRobin => {
                // the first eligible axis at or after the pointer, wrapping around
                let later = mask >> *next;
                if later != 0 {
                    *next + later.trailing_zeros() as usize
                } else {
                    mask.trailing_zeros() as usize
                }
            }
            Policy::EarliestDeadline => {
                // (need, axis) packed in one key: the smallest is the earliest, then lowest m
                let (mut bits, mut best) = (mask, u64::MAX);
                while bits != 0 {
                    let m = bits.trailing_zeros() as u64;
                    best = best.min((need[m as usize] << 6) | m);
                    bits &= bits - 1;
                }
                (best & 63) as usize
            }
        };
        *next = if m + 1 == need.len() { 0 } else { m + 1 };
        self.eligible &= !(1 << m);
        Some((t, m))
    }
}

impl core::str::FromStr for Policy {
    type Err = TdmError;
    fn from_str(s: &str) -> Result<Policy, TdmError> {
        Policy::parse(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A queue holding `room` (u64::MAX: done) as of tick `t`.
    fn queue(room: &[u64], t: u64) -> Queue {
        let mut q = Queue::default();
        for (m, &r) in room.iter().enumerate() {
            if r != u64::MAX {
                q.insert(m, r, t);
            }
        }
        q
    }

    #[test]
    fn round_robin_goes_on_from_the_axis_after_the_last_served() {
        let need = [9, 1, 5, 7];
        let rr = Policy::RoundRobin;
        let mut q = queue(&[0, 50, u64::MAX, 0], 10);
        let mut next = 1;
        // axis 1 has no room until 50, axis 2 is done: axis 3
        assert_eq!(q.pick(rr, 10, &need, &mut next), Some((10, 3)));
        assert_eq!(next, 0);
        assert_eq!(q.pick(rr, 10, &need, &mut next), Some((10, 0)));
        // nobody left with room at 10: idle until 50
        assert_eq!(q.pick(rr, 10, &need, &mut next), Some((50, 1)));
        assert_eq!(next, 2);
        assert_eq!(q.pick(rr, 60, &need, &mut next), None);
        // several get room at the same tick: the first in round-robin order from 2
        let mut q = queue(&[70, 50, 90, 50], 10);
        let mut next = 2;
        assert_eq!(q.pick(rr, 10, &need, &mut next), Some((50, 3)));
        assert_eq!(q.pick(rr, 50, &need, &mut next), Some((50, 1)));
        q.insert(3, 60, 50);
        assert_eq!(q.pick(rr, 50, &need, &mut next), Some((60, 3)));
        assert_eq!(q.pick(rr, 60, &need, &mut next), Some((70, 0)));
    }

    #[test]
    fn earliest_deadline_serves_the_axis_that_runs_dry_first() {
        let need = [9, 1, 5, 5];
        let edf = Policy::EarliestDeadline;
        let mut next = 0;
        let mut q = queue(&[0, 50, 0, 0], 10);
        assert_eq!(
            q.pick(edf, 10, &need, &mut next),
            Some((10, 2)),
            "1 has no room, 2 ties 3"
        );
        assert_eq!(q.pick(edf, 50, &need, &mut next), Some((50, 1)));
        let mut q = queue(&[70, 50, 90, 50], 10);
        assert_eq!(q.pick(edf, 10, &need, &mut next), Some((50, 1)));
        assert_eq!(q.pick(edf, 50, &need, &mut next), Some((50, 3)));
        assert_eq!(Policy::parse("earliest-deadline"), Ok(edf));
        assert_eq!(Policy::parse("fifo"), Err(TdmError::UnknownPolicy));
    }

    #[test]
    fn heap_releases_in_tick_order() {
        let mut q = Queue::default();
        let ticks = [500u64, 20, 20, 999, 3, 77, 64, 1000, 2, 31];
        for (m, &r) in ticks.iter().enumerate() {
            q.insert(m, r, 1);
        }
        let need = [0u64; 10];
        let mut next = 0;
        let (mut got, mut now) = (std::vec::Vec::new(), 0);
        while let Some((t, m)) = q.pick(Policy::EarliestDeadline, now, &need, &mut next) {
            got.push((t, m));
            now = t;
        }
        let mut want: std::vec::Vec<(u64, usize)> = ticks.iter().copied().zip(0..).collect();
        want.sort();
        assert_eq!(got, want);
    }
}
