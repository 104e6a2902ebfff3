//! D. Austin, "Generate stepper-motor speed profiles in real time" (Embedded Systems
//! Programming, Jan. 2005; the algorithm AccelStepper uses), written from the paper.
//!
//! Inter-step delays in timer ticks: `c0 = 0.676·f·√(2/α)` (eq. 15 with the paper's
//! first-step correction), then `c_n = c_{n−1} − 2c_{n−1}/(4n + 1)` (eq. 13) while
//! accelerating; at constant speed `c = f/vmax`; decelerating runs the same recurrence
//! with negative n from `−(n_acc − 1)` up to −1 (eq. 13 with n < 0), which retraces the
//! accel delays backwards. Each delay is rounded to a whole tick, as a timer compare
//! register holds it, and edges are the running sum.

use crate::moves::BenchMove;

/// The delay sequence of one trapezoid move (N delays).
#[derive(Clone, Debug)]
pub struct Austin {
    steps: u64,
    ramp: u64,
    i: u64,
    c: f64,
    c_min: f64,
    c_ramp_end: f64,
}

impl Austin {
    pub fn new(m: &BenchMove, clock_hz: u64) -> Self {
        let f = clock_hz as f64;
        Austin {
            steps: m.steps,
            ramp: m.ramp_steps(),
            i: 0,
            c: 0.676 * f * (2.0 / m.amax as f64).sqrt(),
            c_min: f / m.vmax as f64,
            c_ramp_end: 0.0,
        }
    }
}

impl Iterator for Austin {
    type Item = f64;
    fn next(&mut self) -> Option<f64> {
        if self.i == self.steps {
            return None;
        }
        self.i += 1;
        let i = self.i;
        let decel_from = self.steps - self.ramp;
        if i == 1 {
            // c0
        } else if i <= self.ramp {
            let n = (i - 1) as f64;
            self.c = (self.c - 2.0 * self.c / (4.0 * n + 1.0)).max(self.c_min);
            self.c_ramp_end = self.c;
        } else if i <= decel_from {
            self.c = self.c_min;
        } else if i == decel_from + 1 {
            // the first decel delay mirrors the last accel delay
            self.c = self.c_ramp_end.max(self.c_min);
        } else {
            let n = -((self.steps - i + 1) as f64);
            self.c -= 2.0 * self.c / (4.0 * n + 1.0);
        }
        Some(self.c)
    }
}

/// Edges: the running sum of delays rounded to whole ticks.
pub fn edges(m: &BenchMove, clock_hz: u64) -> impl Iterator<Item = u64> {
    crate::tick_sum(Austin::new(m, clock_hz))
}
