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

/// A rotator's allowed travel, in the axis's own degrees (position / steps_per_unit,
/// whatever the device's Reverse says): from `min_deg` up to `max_deg`. The cable wrap is
/// the rest of the turn, which no move crosses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Travel {
    pub min_deg: f64,
    pub max_deg: f64,
}

/// Why a travel or a target is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TravelError {
    #[error("travel {0}..{1}: min_deg must lie in [-360, 360] and max_deg above it, at most 360 further")]
    Range(f64, f64),
    #[error(
        "{target:.2}° (axis degrees) is outside the rotator's travel {min}..{max} (cable wrap)"
    )]
    Outside { target: f64, min: f64, max: f64 },
}

impl Travel {
    /// Checked: `min_deg` in [-360, 360], `max_deg - min_deg` in (0, 360].
    pub fn new(min_deg: f64, max_deg: f64) -> Result<Travel, TravelError> {
        let span = max_deg - min_deg;
        if (-360.0..=360.0).contains(&min_deg) && span > 0.0 && span <= 360.0 {
            Ok(Travel { min_deg, max_deg })
        } else {
            Err(TravelError::Range(min_deg, max_deg))
        }
    }
}

/// The relative moves (axis steps, made one after another) that take a rotator axis from
/// position `from` to `target` (both any steps: read modulo the turn). Each is shorter
/// than half a turn, or exactly half a turn forwards, so the controller's shortest-way
/// rule for periodic axes (seed 002 §2.1; ties go forwards) keeps its sense.
///
/// Free travel: the short way; exactly half a turn goes forwards (positive steps).
/// With a travel: a target outside is refused, and the way taken never crosses the
/// middle of the wrap — from inside the travel it stays inside, the long way round when
/// the short way would cross the wrap.
pub fn rotator_path(
    turn: &Turn,
    travel: Option<Travel>,
    from: i64,
    target: i64,
) -> Result<Vec<i64>, TravelError> {
    let p = turn.period;
    let Some(tr) = travel else {
        let d = (target - from).rem_euclid(p);
        let d = if 2 * d > p { d - p } else { d };
        return Ok(if d == 0 { vec![] } else { vec![d] });
    };
    let lo = (tr.min_deg * turn.steps_per_degree).round() as i64;
    let hi = (tr.max_deg * turn.steps_per_degree).round() as i64;
    // Unrolled onto [w - p, w), w the middle of the wrap: the travel is [lo, hi].
    let base = hi + (p - (hi - lo) + 1).div_euclid(2) - p;
    let unroll = |x: i64| base + (x - base).rem_euclid(p);
    let (a, b) = (unroll(from), unroll(target));
    if b < lo || b > hi {
        return Err(TravelError::Outside {
            target: turn.deg(target),
            min: tr.min_deg,
            max: tr.max_deg,
        });
    }
    Ok(legs(b - a, p))
}

/// `delta` steps as moves each shorter than half of `period`.
fn legs(delta: i64, period: i64) -> Vec<i64> {
    let most = ((period - 1) / 2).max(1);
    let n = ((delta.abs() + most - 1) / most).max(1);
    (0..n)
        .map(|i| delta * (i + 1) / n - delta * i / n)
        .filter(|&d| d != 0)
        .collect()
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

    #[test]
    fn half_a_turn_free_goes_forwards_both_ways() {
        let t = Turn::new(Some(14400), 40.0);
        assert_eq!(rotator_path(&t, None, 0, 7200), Ok(vec![7200]));
        assert_eq!(rotator_path(&t, None, 7200, 0), Ok(vec![7200]));
        assert_eq!(rotator_path(&t, None, 100, 14000), Ok(vec![-500]));
        assert_eq!(rotator_path(&t, None, 5, 5), Ok(vec![]));
    }

    #[test]
    fn a_travel_takes_the_long_way_and_refuses_the_wrap() {
        let t = Turn::new(Some(14400), 40.0);
        let tr = Some(Travel::new(-90.0, 180.0).unwrap());
        // 170° to 260° (= -100°): outside
        let e = rotator_path(&t, tr, 6800, 10400).unwrap_err();
        assert!(e.to_string().contains("-90..180"), "{e}");
        // 170° to 280° (= -80°): the short way crosses the wrap at 225°, so down 250°
        let l = rotator_path(&t, tr, 6800, 11200).unwrap();
        assert_eq!(l.iter().sum::<i64>(), -10000);
        assert!(l.iter().all(|d| 2 * d.abs() < 14400), "{l:?}");
        assert!(Travel::new(0.0, 360.5).is_err());
        assert!(Travel::new(10.0, 10.0).is_err());
        assert!(Travel::new(-400.0, -100.0).is_err());
        assert!(Travel::new(0.0, f64::NAN).is_err());
    }

    proptest::proptest! {
        #[test]
        fn a_path_from_inside_never_leaves_the_travel(
            spd in 1u32..50,
            lo in -360.0f64..360.0,
            span in 0.5f64..360.0,
            at in 0.0f64..1.0,
            to in 0.0f64..360.0,
        ) {
            let spd = spd as f64;
            let t = Turn::new(Some((360.0 * spd) as u64), spd);
            let tr = Travel::new(lo, lo + span).unwrap();
            let (lo_s, hi_s) = ((lo * spd).round() as i64, ((lo + span) * spd).round() as i64);
            let from = lo_s + ((hi_s - lo_s) as f64 * at).round() as i64;
            let target = t.steps(to);
            match rotator_path(&t, Some(tr), from, target) {
                Ok(l) => {
                    let mut x = from;
                    for d in &l {
                        proptest::prop_assert!(2 * d.abs() < t.period);
                        x += d;
                        proptest::prop_assert!(lo_s <= x && x <= hi_s, "{x} outside {lo_s}..{hi_s}");
                    }
                    proptest::prop_assert_eq!((x - target).rem_euclid(t.period), 0);
                }
                Err(_) => {
                    // refused only when no position of the travel is the target
                    let inside = (lo_s..=hi_s).any(|x| (x - target).rem_euclid(t.period) == 0);
                    proptest::prop_assert!(!inside);
                }
            }
        }
    }
}
