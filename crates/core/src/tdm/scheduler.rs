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
                // one pass in round-robin order: the first eligible axis, else the first
                // to get room (the earliest wake-up, ties in round-robin order)
                let (mut wake, mut first) = (u64::MAX, 0);
                let mut m = *next;
                for _ in 0..k {
                    let r = room[m];
                    if r <= t {
                        *next = if m + 1 == k { 0 } else { m + 1 };
                        return Some((t, m));
                    }
                    if r < wake {
                        wake = r;
                        first = m;
                    }
                    m = if m + 1 == k { 0 } else { m + 1 };
                }
                if wake == u64::MAX {
                    return None;
                }
                *next = if first + 1 == k { 0 } else { first + 1 };
                Some((wake, first))
            }
            Policy::EarliestDeadline => {
                let t = t.max(room.iter().copied().min()?);
                if t == u64::MAX {
                    return None;
                }
                // (need, axis) packed in one key: the smallest is the earliest, then lowest m
                let mut best = u64::MAX;
                for (m, (&r, &d)) in room.iter().zip(need).enumerate() {
                    let key = if r <= t {
                        (d << 6) | m as u64
                    } else {
                        u64::MAX
                    };
                    best = best.min(key);
                }
                Some((t, (best & 63) as usize))
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
