//! Which axis the calculator serves next.
//!
//! An axis is eligible at tick `t` when steps remain to compute and its FIFO has room
//! (`room[m] <= t`). Both policies only choose among eligible axes; when none is eligible
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

    /// Picks the axis to serve at tick `t`. `room[m]`: first tick axis m's FIFO has room;
    /// `need[m]`: tick its next period is needed; `left[m]`: periods still to compute;
    /// `next`: the round-robin pointer, moved past the chosen axis.
    #[inline]
    pub fn pick(&self, t: u64, room: &[u64], need: &[u64], left: &[u64], next: &mut usize) -> Option<usize> {
        let k = room.len();
        match self {
            Policy::RoundRobin => {
                let mut m = *next;
                for _ in 0..k {
                    if left[m] > 0 && room[m] <= t {
                        *next = if m + 1 == k { 0 } else { m + 1 };
                        return Some(m);
                    }
                    m = if m + 1 == k { 0 } else { m + 1 };
                }
                None
            }
            Policy::EarliestDeadline => {
                let mut best = None;
                let mut best_need = u64::MAX;
                for m in 0..k {
                    if left[m] > 0 && room[m] <= t && (best.is_none() || need[m] < best_need) {
                        best = Some(m);
                        best_need = need[m];
                    }
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

    #[test]
    fn round_robin_goes_on_from_the_axis_after_the_last_served() {
        let room = [0, 50, 0, 0];
        let need = [9, 1, 5, 7];
        let left = [1, 1, 0, 1];
        let mut next = 1;
        // axis 1 has no room until 50, axis 2 is done: axis 3
        assert_eq!(Policy::RoundRobin.pick(10, &room, &need, &left, &mut next), Some(3));
        assert_eq!(next, 0);
        assert_eq!(Policy::RoundRobin.pick(10, &room, &need, &left, &mut next), Some(0));
        assert_eq!(Policy::RoundRobin.pick(60, &room, &need, &left, &mut next), Some(1));
        assert_eq!(Policy::RoundRobin.pick(10, &room, &need, &[0, 0, 0, 0], &mut next), None);
    }

    #[test]
    fn earliest_deadline_serves_the_axis_that_runs_dry_first() {
        let room = [0, 50, 0, 0];
        let need = [9, 1, 5, 5];
        let left = [1, 1, 1, 1];
        let mut next = 0;
        let edf = Policy::EarliestDeadline;
        assert_eq!(edf.pick(10, &room, &need, &left, &mut next), Some(2), "1 has no room, 2 ties 3");
        assert_eq!(edf.pick(50, &room, &need, &left, &mut next), Some(1));
        assert_eq!(Policy::parse("earliest-deadline"), Ok(edf));
        assert_eq!(Policy::parse("fifo"), Err(TdmError::UnknownPolicy));
    }
}
