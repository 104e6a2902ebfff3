//! Which axis the calculator serves next.
//!
//! An axis is eligible at tick `t` when steps remain to compute and its FIFO has room
//! (`room[m] <= t`; a finished axis has `room[m] = u64::MAX`). Both policies only choose among eligible axes; when none is eligible
//! the calculator idles until the earliest room tick.

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

    /// The next computation at or after tick `t`: `(start tick, axis)`, or `None` when every
    /// axis is done. `room[m]`: first tick axis m's FIFO has room (`u64::MAX` once all its
    /// periods are computed); `need[m]`: tick its next period is needed; `next`: the
    /// round-robin pointer, moved past the chosen axis. When no axis is eligible at `t`
    /// the calculator idles until the earliest room tick. At most 64 axes.
    #[inline]
    pub fn pick(
        &self,
        t: u64,
        room: &[u64],
        need: &[u64],
        next: &mut usize,
    ) -> Option<(u64, usize)> {
        let k = room.len();
        match self {
            Policy::RoundRobin => {
                // eligible axes as a bit mask, branch-free; when none, idle until the
                // earliest room tick and take those eligible then
                let (mut mask, wake) = eligible(t, room);
                let mut t = t;
                if mask == 0 {
                    if wake == u64::MAX {
                        return None;
                    }
                    t = wake;
                    mask = eligible(t, room).0;
                }
                // the first eligible axis at or after the pointer, wrapping around
                let later = mask >> *next;
                let m = if later != 0 {
                    *next + later.trailing_zeros() as usize
                } else {
                    mask.trailing_zeros() as usize
                };
                *next = if m + 1 == k { 0 } else { m + 1 };
                Some((t, m))
            }
            Policy::EarliestDeadline => {
                let (mut best, wake) = earliest(t, room, need);
                let mut t = t;
                if best == u64::MAX {
                    if wake == u64::MAX {
                        return None;
                    }
                    t = wake;
                    best = earliest(t, room, need).0;
                }
                Some((t, (best & 63) as usize))
            }
        }
    }
}

/// Bit m set iff axis m has room at `t`; and the earliest room tick of all axes.
#[inline(always)]
fn eligible(t: u64, room: &[u64]) -> (u64, u64) {
    let (mut mask, mut wake) = (0u64, u64::MAX);
    for (m, &r) in room.iter().enumerate() {
        mask |= ((r <= t) as u64) << m;
        wake = wake.min(r);
    }
    (mask, wake)
}

/// Smallest `(need << 6) | m` over axes with room at `t` (the earliest deadline, then the
/// lowest axis), `u64::MAX` if none; and the earliest room tick of all axes.
#[inline(always)]
fn earliest(t: u64, room: &[u64], need: &[u64]) -> (u64, u64) {
    let (mut best, mut wake) = (u64::MAX, u64::MAX);
    for (m, (&r, &d)) in room.iter().zip(need).enumerate() {
        let key = if r <= t { (d << 6) | m as u64 } else { u64::MAX };
        best = best.min(key);
        wake = wake.min(r);
    }
    (best, wake)
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

    #[test]
    fn round_robin_goes_on_from_the_axis_after_the_last_served() {
        let room = [0, 50, u64::MAX, 0];
        let need = [9, 1, 5, 7];
        let rr = Policy::RoundRobin;
        let mut next = 1;
        // axis 1 has no room until 50, axis 2 is done: axis 3
        assert_eq!(rr.pick(10, &room, &need, &mut next), Some((10, 3)));
        assert_eq!(next, 0);
        assert_eq!(rr.pick(10, &room, &need, &mut next), Some((10, 0)));
        assert_eq!(rr.pick(60, &room, &need, &mut next), Some((60, 1)));
        assert_eq!(next, 2);
        assert_eq!(
            rr.pick(60, &room, &need, &mut next),
            Some((60, 3)),
            "2 is done"
        );
        // nobody has room at 10: idle until 50, the first in round-robin order from 2
        let mut next = 2;
        assert_eq!(
            rr.pick(10, &[70, 50, 90, 50], &need, &mut next),
            Some((50, 3))
        );
        assert_eq!(rr.pick(10, &[u64::MAX; 4], &need, &mut next), None);
    }

    #[test]
    fn earliest_deadline_serves_the_axis_that_runs_dry_first() {
        let room = [0, 50, 0, 0];
        let need = [9, 1, 5, 5];
        let mut next = 0;
        let edf = Policy::EarliestDeadline;
        assert_eq!(
            edf.pick(10, &room, &need, &mut next),
            Some((10, 2)),
            "1 has no room, 2 ties 3"
        );
        assert_eq!(edf.pick(50, &room, &need, &mut next), Some((50, 1)));
        assert_eq!(
            edf.pick(10, &[70, 50, 90, 50], &need, &mut next),
            Some((50, 1))
        );
        assert_eq!(edf.pick(50, &[u64::MAX; 4], &need, &mut next), None);
        assert_eq!(Policy::parse("earliest-deadline"), Ok(edf));
        assert_eq!(Policy::parse("fifo"), Err(TdmError::UnknownPolicy));
    }
}
