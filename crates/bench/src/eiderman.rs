//! A. Eiderman, "Real-time stepper motor linear ramping just by addition and
//! multiplication" (2004), written from the paper: the period in timer ticks follows
//! `p ← p·(1 + m·p²)` with `m = −α/f²` while accelerating and `m = +α/f²` while
//! decelerating, from the first period `p1 = f/√(v0² + 2α)`; at constant speed
//! `p = f/vmax`. Each period is rounded to a whole tick; edges are the running sum.

use crate::moves::BenchMove;
use crate::ramp::{RampDelays, Recurrence};

/// `p·(1 ∓ m·p²)` with `m = α/f²`.
#[derive(Clone, Copy, Debug)]
pub struct EidermanStep {
    m: f64,
}

impl Recurrence for EidermanStep {
    fn accel(&self, p: f64, _n: u64) -> f64 {
        p * (1.0 - self.m * p * p)
    }
    fn decel(&self, p: f64, _left: u64) -> f64 {
        p * (1.0 + self.m * p * p)
    }
}

/// The period sequence of one trapezoid move (N periods).
pub type Eiderman = RampDelays<EidermanStep>;

impl Eiderman {
    pub fn new(mv: &BenchMove, clock_hz: u64) -> Self {
        let f = clock_hz as f64;
        let a = mv.amax as f64;
        let step = EidermanStep { m: a / (f * f) };
        RampDelays::start(step, mv, f / (2.0 * a).sqrt(), f / mv.vmax as f64)
    }
}

pub fn edges(m: &BenchMove, clock_hz: u64) -> impl Iterator<Item = u64> {
    crate::tick_sum(Eiderman::new(m, clock_hz))
}
