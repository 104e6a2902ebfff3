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
use crate::ramp::{RampDelays, Recurrence};

/// Eq. (13): `c − 2c/(4n + 1)`, with n < 0 on decel.
#[derive(Clone, Copy, Debug)]
pub struct AustinStep;

impl Recurrence for AustinStep {
    fn accel(&self, c: f64, n: u64) -> f64 {
        c - 2.0 * c / (4.0 * n as f64 + 1.0)
    }
    fn decel(&self, c: f64, left: u64) -> f64 {
        c - 2.0 * c / (1.0 - 4.0 * left as f64)
    }
}

/// The delay sequence of one trapezoid move (N delays).
pub type Austin = RampDelays<AustinStep>;

impl Austin {
    pub fn new(m: &BenchMove, clock_hz: u64) -> Self {
        let f = clock_hz as f64;
        let c0 = 0.676 * f * (2.0 / m.amax as f64).sqrt();
        RampDelays::start(AustinStep, m, c0, f / m.vmax as f64)
    }
}

/// Edges: the running sum of delays rounded to whole ticks.
pub fn edges(m: &BenchMove, clock_hz: u64) -> impl Iterator<Item = u64> {
    crate::tick_sum(Austin::new(m, clock_hz))
}
