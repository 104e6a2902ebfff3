//! Closed forms of constant-acceleration kinematics the controller needs outside a plan:
//! how far a stop from a speed runs, and how much a move's time must stretch for its
//! peaks to fit the limits.

use crate::real::fm;

/// |x| without std.
fn abs(x: f64) -> f64 {
    if x < 0.0 {
        -x
    } else {
        x
    }
}

/// Steps a stop from `v` (steps/s) runs at deceleration `amax`: v²/2a (constant
/// acceleration, Newton's equations of motion). With a jerk limit the deceleration ramps
/// in and out, adding v·a/2j (the jerk-limited S-curve of seed 000's limits-mode ramps;
/// exact when the ramp reaches `amax`, an upper bound when it does not).
pub fn stop_distance(v: f64, amax: f64, jmax: Option<f64>) -> f64 {
    let v = abs(v);
    let d = v * v / (2.0 * amax);
    match jmax {
        Some(j) => d + v * amax / (2.0 * j),
        None => d,
    }
}

/// The factor s ≥ 0 by which a move's time must stretch so that its peak speed `v` and
/// peak acceleration `a` (at s = 1) stay within `vmax` and `amax`: a profile run s times
/// slower has speeds 1/s and accelerations 1/s² as large (time scaling of a trajectory).
pub fn time_scale(v: f64, a: f64, vmax: f64, amax: f64) -> f64 {
    (abs(v) / vmax).max(fm::sqrt(abs(a) / amax))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stop_runs_v_squared_over_two_a_plus_the_jerk_ramps() {
        assert_eq!(stop_distance(4000.0, 20_000.0, None), 400.0);
        assert_eq!(stop_distance(-4000.0, 20_000.0, None), 400.0);
        // + v·a/2j = 4000·20000/(2·1e6) = 40
        assert_eq!(stop_distance(4000.0, 20_000.0, Some(1e6)), 440.0);
        assert_eq!(stop_distance(0.0, 1.0, Some(1.0)), 0.0);
    }

    #[test]
    fn the_time_scale_brings_the_tighter_peak_to_its_limit() {
        assert_eq!(time_scale(200.0, 100.0, 100.0, 100.0), 2.0);
        assert_eq!(time_scale(50.0, 400.0, 100.0, 100.0), 2.0);
        assert_eq!(time_scale(50.0, 25.0, 100.0, 100.0), 0.5);
    }
}
