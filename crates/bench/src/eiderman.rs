//! A. Eiderman, "Real-time stepper motor linear ramping just by addition and
//! multiplication" (2004), written from the paper: the period in timer ticks follows
//! `p ← p·(1 + m·p²)` with `m = −α/f²` while accelerating and `m = +α/f²` while
//! decelerating, from the first period `p1 = f/√(v0² + 2α)`; at constant speed
//! `p = f/vmax`. Each period is rounded to a whole tick; edges are the running sum.

use crate::moves::BenchMove;

#[derive(Clone, Debug)]
pub struct Eiderman {
    steps: u64,
    ramp: u64,
    i: u64,
    p: f64,
    m: f64,
    p_min: f64,
    p_ramp_end: f64,
}

impl Eiderman {
    pub fn new(mv: &BenchMove, clock_hz: u64) -> Self {
        let f = clock_hz as f64;
        let a = mv.amax as f64;
        Eiderman {
            steps: mv.steps,
            ramp: mv.ramp_steps(),
            i: 0,
            p: f / (2.0 * a).sqrt(),
            m: a / (f * f),
            p_min: f / mv.vmax as f64,
            p_ramp_end: 0.0,
        }
    }
}

impl Iterator for Eiderman {
    type Item = f64;
    fn next(&mut self) -> Option<f64> {
        if self.i == self.steps {
            return None;
        }
        self.i += 1;
        let i = self.i;
        let decel_from = self.steps - self.ramp;
        if i == 1 {
            // p1
        } else if i <= self.ramp {
            self.p = (self.p * (1.0 - self.m * self.p * self.p)).max(self.p_min);
            self.p_ramp_end = self.p;
        } else if i <= decel_from {
            self.p = self.p_min;
        } else if i == decel_from + 1 {
            self.p = self.p_ramp_end.max(self.p_min);
        } else {
            self.p *= 1.0 + self.m * self.p * self.p;
        }
        Some(self.p)
    }
}

pub fn edges(m: &BenchMove, clock_hz: u64) -> impl Iterator<Item = u64> {
    crate::tick_sum(Eiderman::new(m, clock_hz))
}
