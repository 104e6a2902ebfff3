//! Which axis the calculator serves next.
//!
//! An axis is eligible at tick `t` when steps remain to compute and its FIFO has room
//! (`room[m] <= t`; a finished axis has `room[m] = u64::MAX`). Both policies only choose among eligible axes; when none is eligible
//! the calculator idles until the earliest room tick.

use super::TdmError;
use core::num::NonZeroU64;

/// Most axes one board holds: one bit each in the eligible mask.
pub const MAX_AXES: usize = 64;
/// The eligible mask, one bit per axis.
type AxisMask = u64;
/// Low bits of a queue key that hold the axis index; the tick is above them.
const AXIS_BITS: u32 = usize::BITS - (MAX_AXES - 1).leading_zeros();
const AXIS_FIELD: u64 = (1 << AXIS_BITS) - 1;
/// Ticks the scheduler's keys hold (one bit spare, so `(t << AXIS_BITS) | AXIS_FIELD`
/// never reaches the `u64::MAX` end marker).
pub const TICK_LIMIT: u64 = 1 << (u64::BITS - 1 - AXIS_BITS);
const _: () = assert!(MAX_AXES <= AxisMask::BITS as usize && MAX_AXES <= 1 << AXIS_BITS);

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

/// Which axes have room: a bit mask of those eligible now and, sorted by the tick their
/// FIFO gets room, the others. Axes with no period left to compute are in neither.
///
/// The waiting axes form a sorted run in a ring: releasing takes from its front, and a
/// served axis is inserted from the front when its key is below the fifth waiting one,
/// else from the back, shifting the keys on that side by one. A served axis's FIFO is
/// full again, so its room tick is usually among the latest (measured on the bench
/// loads: 2.3 axes from the back on average with 16 axes, 10 with 64), which makes
/// insertion cheaper than a heap's or a tournament tree's O(log k) sifts; a fast axis
/// among slow ones goes in at the front. The worst case (a key just after the first
/// few) shifts almost every waiting axis.
// `repr(C)`, scalars first: in this order the engine's loop keeps them in registers
// (in Rust's order it stored and reloaded two of them per period: 6 instructions)
#[derive(Clone, Debug)]
#[repr(C)]
pub struct Queue {
    head: usize,
    tail: usize,
    /// Bit m: axis m has room and periods left.
    eligible: AxisMask,
    /// `(room tick << AXIS_BITS) | m`, ascending from `head` to before `tail` (indices mod
    /// RING). `ring[tail]` is `u64::MAX`, so the front of an empty run reads MAX and a
    /// scan from the front stops there. Every other slot holds a released key or 0: no
    /// larger than any key still to come (room ticks after the current tick go in, those
    /// at or before it come out), so a scan from the back stops at `head − 1`.
    ring: [u64; RING],
}

/// At most 64 waiting keys and the MAX after them, with room to spare.
const RING: usize = 2 * MAX_AXES;
/// Keys from the front before which an insertion goes in from the front.
const NEAR_FRONT: usize = 4;

impl Default for Queue {
    fn default() -> Self {
        let mut ring = [0; RING];
        ring[0] = u64::MAX;
        Queue {
            eligible: 0,
            ring,
            head: 0,
            tail: 0,
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
        let key = (room << AXIS_BITS) | m as u64;
        // a scan from either end finds the place (it stops at the other end's marker),
        // so this choice only sets the cost; with fewer than five waiting the slot read
        // is past the run
        if key >= self.ring[(self.head + NEAR_FRONT) % RING] {
            self.insert_from_back(key);
        } else {
            self.insert_from_front(key);
        }
    }

    // Indices count mod 2^64, a multiple of RING, so `i % RING` wraps correctly.

    /// The later keys move up one slot, the first over the MAX, which is put after them
    /// first (the new tail then stays in a register: the loop reloaded the old one twice).
    #[inline]
    fn insert_from_back(&mut self, key: u64) {
        // j: the free slot, kept reduced mod RING
        let mut j = self.tail % RING;
        let tail = (j + 1) % RING;
        self.ring[tail] = u64::MAX;
        loop {
            let i = j.wrapping_sub(1) % RING;
            let before = self.ring[i];
            if before <= key {
                break;
            }
            self.ring[j] = before;
            j = i;
        }
        self.ring[j] = key;
        self.tail = tail;
    }

    /// The earlier keys move down one slot, into the one before `head`.
    #[inline]
    fn insert_from_front(&mut self, key: u64) {
        let mut j = self.head.wrapping_sub(1);
        loop {
            let after = self.ring[j.wrapping_add(1) % RING];
            if after >= key {
                break;
            }
            self.ring[j % RING] = after;
            j = j.wrapping_add(1);
        }
        self.ring[j % RING] = key;
        self.head = self.head.wrapping_sub(1) % RING;
    }

    /// Moves every axis with room at `t` into the eligible mask.
    #[inline]
    fn release(&mut self, t: u64) {
        // ticks stay below TICK_LIMIT (checked by the board), so the MAX at the tail
        // never passes
        let last = (t << AXIS_BITS) | AXIS_FIELD;
        loop {
            let key = self.ring[self.head % RING];
            if key > last {
                break;
            }
            self.eligible |= 1 << (key & AXIS_FIELD);
            self.head = (self.head + 1) % RING;
        }
    }

    /// The next computation at or after tick `t`: `(start tick, axis)`, or `None` when no
    /// axis has periods left. When none has room at `t` the calculator idles until the
    /// earliest room tick. `need[m]`: tick axis m's next period is needed; `last`: the
    /// axis served last (`usize::MAX` before the first), round-robin goes on after it.
    /// The chosen axis leaves the queue; [`insert`](Self::insert) it again with its new
    /// room tick.
    #[inline]
    pub fn pick(
        &mut self,
        policy: Policy,
        t: u64,
        need: &[u64; MAX_AXES],
        last: usize,
    ) -> Option<(u64, usize)> {
        self.pick_from::<true>(policy, t, need, last)
    }

    /// [`pick`](Self::pick); with `MAY_END` false the caller knows an axis is left (the
    /// queue is not empty), and the idle case skips the test for the end.
    #[inline]
    pub fn pick_from<const MAY_END: bool>(
        &mut self,
        policy: Policy,
        t: u64,
        need: &[u64; MAX_AXES],
        last: usize,
    ) -> Option<(u64, usize)> {
        let mut t = t;
        if self.eligible == 0 {
            // nobody has room yet: idle until the earliest room tick, if it is later
            let first = self.ring[self.head % RING];
            if MAY_END && first == u64::MAX {
                return None;
            }
            debug_assert_ne!(first, u64::MAX, "an axis is left");
            t = t.max(first >> AXIS_BITS);
            let after = self.ring[(self.head + 1) % RING];
            if after >> AXIS_BITS > t {
                // it alone has room at t (the usual case below full load): every policy
                // takes it, and the mask stays empty
                self.head = (self.head + 1) % RING;
                return Some((t, (first & AXIS_FIELD) as usize));
            }
        }
        self.release(t);
        let mask = self.eligible;
        let m = if mask & (mask - 1) == 0 {
            mask.trailing_zeros() as u64
        } else {
            Self::choose(policy, mask, need, last)
        };
        self.eligible = mask & !(1 << m);
        Some((t, m as usize))
    }

    /// The policy's choice among the axes of `mask` (at least two); `last` served last.
    #[inline]
    fn choose(policy: Policy, mask: AxisMask, need: &[u64; MAX_AXES], last: usize) -> u64 {
        match policy {
            Policy::RoundRobin => {
                // the pointer: after the last axis it reads k, which counts as 0 (bits
                // k…63 of the mask are clear), so no wrap is needed
                let next = last.wrapping_add(1);
                // the first eligible axis at or after the pointer, wrapping around: rotated
                // right by the pointer, axes before it sit above every axis after it
                // (bits k…63 are clear), so no branch is needed; a pointer of 64 rotates
                // by 0 and the sum wraps to the axis itself
                (next as u64 + mask.rotate_right(next as u32).trailing_zeros() as u64)
                    % AxisMask::BITS as u64
            }
            Policy::EarliestDeadline => {
                // axes in increasing order, a later one only if strictly earlier: ties go
                // to the lowest m (a nonzero mask's lowest bit is below 64: no bounds check)
                let (mut bits, mut best, mut earliest) = (mask, 0, u64::MAX);
                while let Some(b) = NonZeroU64::new(bits) {
                    let m = b.trailing_zeros() as u64;
                    let due = need[m as usize];
                    if due < earliest {
                        (best, earliest) = (m, due);
                    }
                    bits &= bits - 1;
                }
                best
            }
        }
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

    /// `need` for the first axes, 0 for the others.
    fn deadlines(first: &[u64]) -> [u64; MAX_AXES] {
        let mut need = [0; MAX_AXES];
        need[..first.len()].copy_from_slice(first);
        need
    }

    #[test]
    fn round_robin_goes_on_from_the_axis_after_the_last_served() {
        let need = deadlines(&[9, 1, 5, 7]);
        let rr = Policy::RoundRobin;
        let mut q = queue(&[0, 50, u64::MAX, 0], 10);
        // axis 0 served last; axis 1 has no room until 50, axis 2 is done: axis 3
        assert_eq!(q.pick(rr, 10, &need, 0), Some((10, 3)));
        assert_eq!(q.pick(rr, 10, &need, 3), Some((10, 0)));
        // nobody left with room at 10: idle until 50
        assert_eq!(q.pick(rr, 10, &need, 0), Some((50, 1)));
        assert_eq!(q.pick(rr, 60, &need, 1), None);
        // several get room at the same tick: the first in round-robin order from 2
        let mut q = queue(&[70, 50, 90, 50], 10);
        assert_eq!(q.pick(rr, 10, &need, 1), Some((50, 3)));
        assert_eq!(q.pick(rr, 50, &need, 3), Some((50, 1)));
        q.insert(3, 60, 50);
        assert_eq!(q.pick(rr, 50, &need, 1), Some((60, 3)));
        assert_eq!(q.pick(rr, 60, &need, 3), Some((70, 0)));
    }

    #[test]
    fn earliest_deadline_serves_the_axis_that_runs_dry_first() {
        let need = deadlines(&[9, 1, 5, 5]);
        let edf = Policy::EarliestDeadline;
        let last = usize::MAX;
        let mut q = queue(&[0, 50, 0, 0], 10);
        assert_eq!(
            q.pick(edf, 10, &need, last),
            Some((10, 2)),
            "1 has no room, 2 ties 3"
        );
        assert_eq!(q.pick(edf, 50, &need, last), Some((50, 1)));
        let mut q = queue(&[70, 50, 90, 50], 10);
        assert_eq!(q.pick(edf, 10, &need, last), Some((50, 1)));
        assert_eq!(q.pick(edf, 50, &need, last), Some((50, 3)));
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
        let need = [0u64; MAX_AXES];
        let (mut got, mut now) = (std::vec::Vec::new(), 0);
        while let Some((t, m)) = q.pick(Policy::EarliestDeadline, now, &need, 0) {
            got.push((t, m));
            now = t;
        }
        let mut want: std::vec::Vec<(u64, usize)> = ticks.iter().copied().zip(0..).collect();
        want.sort();
        assert_eq!(got, want);
    }

    /// Picks against a scan of every axis, over many laps of the ring, for both policies
    /// and 64 axes: room ticks at, just after and far after the decision tick, some axes
    /// finishing.
    #[test]
    fn picks_match_a_scan_of_every_axis() {
        const K: usize = 64;
        for policy in [Policy::RoundRobin, Policy::EarliestDeadline] {
            let mut seed = 0x9e37_79b9_7f4a_7c15u64;
            let mut rand = |n: u64| {
                seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                (seed >> 33) % n
            };
            let mut q = Queue::default();
            let mut room = [0u64; K];
            let mut need = [0u64; MAX_AXES];
            let mut left = [0u64; K];
            for m in 0..K {
                room[m] = rand(3000);
                need[m] = rand(3000);
                left[m] = 1 + rand(400);
                q.insert(m, room[m], 0);
            }
            let (mut t, mut last, mut want_next) = (0u64, usize::MAX, 0usize);
            loop {
                // the scan: idle until the earliest room tick, then choose by the policy
                let active = (0..K).filter(|&m| left[m] > 0);
                let Some(earliest) = active.clone().map(|m| room[m]).min() else {
                    assert_eq!(q.pick(policy, t, &need, last), None);
                    break;
                };
                let now = t.max(earliest);
                let ok = |m: &usize| left[*m] > 0 && room[*m] <= now;
                let want = match policy {
                    Policy::RoundRobin => (0..K).map(|i| (want_next + i) % K).find(ok),
                    Policy::EarliestDeadline => (0..K).filter(ok).min_by_key(|&m| (need[m], m)),
                }
                .unwrap();
                want_next = (want + 1) % K;
                assert_eq!(q.pick(policy, t, &need, last), Some((now, want)));
                last = want;
                t = now + 1 + rand(40);
                need[want] += rand(5000);
                left[want] -= 1;
                if left[want] > 0 {
                    room[want] = match rand(4) {
                        0 => t - rand(2),
                        1 => t + 1 + rand(60),
                        _ => t + rand(6000),
                    };
                    q.insert(want, room[want], t);
                }
            }
        }
    }
}
