//! The trapezoid skeleton both delay recurrences (Austin, Eiderman) step through: the first
//! delay, the accel recurrence clamped at the cruise delay, the cruise delay, then the decel
//! recurrence started from the mirror of the last accel delay. Only the per-step update
//! differs between the two papers.

use crate::moves::BenchMove;

/// One paper's per-step delay update.
pub trait Recurrence {
    /// The delay after `d` on accel step `n` (n = 1, 2, … counted from the first delay).
    fn accel(&self, d: f64, n: u64) -> f64;
    /// The delay after `d` on decel, `left` steps before the end (including this one).
    fn decel(&self, d: f64, left: u64) -> f64;
}

/// The delay sequence (timer ticks, unrounded) of one trapezoid move: N delays.
#[derive(Clone, Debug)]
pub struct RampDelays<R> {
    rec: R,
    steps: u64,
    ramp: u64,
    i: u64,
    d: f64,
    d_min: f64,
    d_ramp_end: f64,
}

impl<R: Recurrence> RampDelays<R> {
    /// `first`: the first delay; `d_min`: the cruise delay f/vmax.
    pub fn start(rec: R, m: &BenchMove, first: f64, d_min: f64) -> Self {
        RampDelays {
            rec,
            steps: m.steps,
            ramp: m.ramp_steps(),
            i: 0,
            d: first,
            d_min,
            d_ramp_end: 0.0,
        }
    }
}

impl<R: Recurrence> Iterator for RampDelays<R> {
    type Item = f64;
    fn next(&mut self) -> Option<f64> {
        if self.i == self.steps {
            return None;
        }
        self.i += 1;
        let i = self.i;
        let decel_from = self.steps - self.ramp;
        if i == 1 {
            // the first delay as given
        } else if i <= self.ramp {
            self.d = self.rec.accel(self.d, i - 1).max(self.d_min);
            self.d_ramp_end = self.d;
        } else if i <= decel_from {
            self.d = self.d_min;
        } else if i == decel_from + 1 {
            // the first decel delay mirrors the last accel delay
            self.d = self.d_ramp_end.max(self.d_min);
        } else {
            self.d = self.rec.decel(self.d, self.steps - i + 1);
        }
        Some(self.d)
    }
}
