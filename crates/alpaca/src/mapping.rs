//! How an axis's microsteps read as a device's values, shared by every front end (Alpaca,
//! INDI): a rotator's angles with sync offset and reverse, and a filter wheel's slots.

/// An angle in [0, 360): the same direction, `-0` and rounding up to 360 folded to 0.
pub fn norm_deg(x: f64) -> f64 {
    let r = x.rem_euclid(360.0) + 0.0;
    if r >= 360.0 {
        0.0
    } else {
        r
    }
}

/// One turn of a rotator axis (period = 360 × steps_per_unit: the unit is a degree).
/// Angles are kept in microsteps, sync offset included, so what is read back is exactly
/// a step's angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Turn {
    pub period: i64,
    pub steps_per_degree: f64,
}

impl Turn {
    pub fn new(period: Option<u64>, steps_per_unit: f64) -> Turn {
        Turn {
            period: period.map_or(1, |p| i64::try_from(p).unwrap_or(i64::MAX).max(1)),
            steps_per_degree: steps_per_unit,
        }
    }
    /// `deg` (any angle) as microsteps in [0, period).
    pub fn steps(&self, deg: f64) -> i64 {
        ((deg * self.steps_per_degree).round() as i64).rem_euclid(self.period)
    }
    /// Microsteps (any) as degrees in [0, 360).
    pub fn deg(&self, steps: i64) -> f64 {
        norm_deg(steps.rem_euclid(self.period) as f64 / self.steps_per_degree)
    }
    /// The mechanical angle (steps in [0, period)) of axis position `pos`: reversed, the
    /// angles run the other way.
    pub fn mechanical(&self, pos: i64, reverse: bool) -> i64 {
        let sense = if reverse { -1 } else { 1 };
        (sense * pos).rem_euclid(self.period)
    }
    /// The sky angle (steps): mechanical plus the sync offset.
    pub fn sky(&self, pos: i64, reverse: bool, sync_offset: i64) -> i64 {
        (self.mechanical(pos, reverse) + sync_offset).rem_euclid(self.period)
    }
    /// The axis position (in [0, period)) whose mechanical angle is `mech` steps.
    pub fn axis_target(&self, mech: i64, reverse: bool) -> i64 {
        self.mechanical(mech, reverse)
    }
}

/// The slot a wheel at `pos` stands on: the first whose position is `pos` (modulo the
/// period on a periodic wheel). `slots[i]` is None for a slot whose position is unknown
/// (a named position never saved), which cannot be where the wheel is.
pub fn slot_at(slots: &[Option<i64>], period: Option<u64>, pos: i64) -> Option<usize> {
    let same = |a: i64| match period.and_then(|p| i64::try_from(p).ok()) {
        Some(p) if p > 0 => (a - pos).rem_euclid(p) == 0,
        _ => a == pos,
    };
    slots.iter().position(|s| s.is_some_and(same))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_turn_reads_steps_as_degrees_both_ways() {
        let t = Turn::new(Some(14400), 40.0);
        assert_eq!(t.steps(350.0), 14000);
        assert_eq!(t.steps(-10.0), 14000);
        assert_eq!(t.deg(400), 10.0);
        assert_eq!(t.mechanical(400, true), 14000);
        assert_eq!(t.sky(400, false, 14000), 0);
        assert_eq!(t.axis_target(400, true), 14000);
        assert_eq!(norm_deg(-0.0).to_bits(), 0.0f64.to_bits());
    }

    #[test]
    fn a_slot_is_found_modulo_the_period() {
        let s = [Some(0), None, Some(1280)];
        assert_eq!(slot_at(&s, Some(6400), 7680), Some(2));
        assert_eq!(slot_at(&s, None, 7680), None);
        assert_eq!(slot_at(&s, Some(6400), 5), None);
    }
}
