//! The `ramp-maker` crate's trapezoidal profile (Eiderman's update with the 1.5·q² term),
//! run as its users run it: velocity in steps/s, acceleration in steps/s², delays in
//! seconds, each turned into a whole-tick timer period.
//!
//! It runs in f64: the crate's default number type, U32.32 fixed point, overflows in
//! `v²/(2a)` above 65 535 steps/s, and then never decelerates (seen on `long-ramp-400k`).

use crate::moves::BenchMove;
use ramp_maker::{MotionProfile, Trapezoidal};

/// Delays in ticks (f64, before rounding); at most N of them.
pub fn delays(m: &BenchMove, clock_hz: u64) -> impl Iterator<Item = f64> {
    let mut p = Trapezoidal::<f64>::new(m.amax as f64);
    p.enter_position_mode(m.vmax as f64, m.steps as u32);
    let f = clock_hz as f64;
    core::iter::from_fn(move || p.next_delay())
        .take(m.steps as usize)
        .map(move |d| d * f)
}

pub fn edges(m: &BenchMove, clock_hz: u64) -> impl Iterator<Item = u64> {
    crate::tick_sum(delays(m, clock_hz))
}
