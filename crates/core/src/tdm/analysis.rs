//! How many axes one calculator serves: simulation against seed 000's rule of thumb.
//!
//! Seed eq. (12): `k = Δt_min / t_calc`. For axes that all run at the fastest rate at once
//! it is the throughput bound: each needs one period per Δt_min and each costs t_calc.
//! It is also what round-robin guarantees with any FIFO depth and any phases: a freed
//! slot is refilled within k computations (the one running, then at most one per other
//! axis). The simulation ([`k_max`]) departs from it when
//! - the calculator is pipelined: a period arrives one latency after it starts, so with
//!   depth 1 the last of k coinciding periods is ready `(k−1)·t_calc + latency` after the
//!   edge; a second FIFO slot hides that;
//! - axes run at different rates: the load is `Σ_m t_calc / Δt_min,m` ([`KMax::k_load`]);
//!   earliest-deadline reaches that bound where round-robin stays at eq. (12), because it
//!   serves an urgent axis first instead of after k−1 others;
//! - the top rate lasts only a moment: a deep FIFO holds periods computed during the
//!   slower stretches around it.
//!
//! Synchronous groups start together, so their edges coincide: the worst phase alignment.

use super::board::{Axis, Board, Report, TdmConfig};
use super::TdmError;
use crate::edges::EdgeGenerator;
use crate::profile::{Family, PhaseMove, Profile};

/// Result of a search for the largest k.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KMax {
    /// Largest k such that every k' ≤ k runs with no underrun (0: not even one axis).
    pub k_max: usize,
    /// True when k_max is the most axes tried (the true bound may be higher).
    pub capped: bool,
    /// The first run with underruns, if any.
    pub first_failure: Option<Report>,
    /// Seed eq. (12) with Δt_min over the whole move set.
    pub k_eq12: u64,
    /// Largest k whose summed load `Σ t_calc / Δt_min,m` stays ≤ 1.
    pub k_load: usize,
    pub min_period_ticks: u64,
    /// t_calc: cycles between computation starts.
    pub interval_cycles: u64,
}

/// Shortest period (ticks) of a move at a clock.
pub fn min_period_ticks(profile: &Profile, clock_hz: f64) -> Result<u64, TdmError> {
    Ok(EdgeGenerator::new(profile, clock_hz)?
        .periods()
        .min()
        .unwrap_or(0))
}

/// Seed 000 eq. (12): `k = Δt_min / t_calc`, rounded down.
pub fn k_eq12(min_period_ticks: u64, interval_cycles: u64) -> u64 {
    min_period_ticks.checked_div(interval_cycles).unwrap_or(0)
}

/// Runs k = 1, 2, … axes (axis i runs `moves[i % moves.len()]`, all started together) until
/// the first run with an underrun or `storage` is full; `storage` supplies the axes.
pub fn k_max(cfg: &TdmConfig, moves: &[Profile], storage: &mut [Axis]) -> Result<KMax, TdmError> {
    if moves.is_empty() || storage.is_empty() {
        return Err(TdmError::NoAxes);
    }
    let c = cfg.latencies.interval();
    let mut min_period = u64::MAX;
    let mut k_load = 0;
    let mut load = 0.0;
    for i in 0..storage.len() {
        let p = min_period_ticks(&moves[i % moves.len()], cfg.clock_hz)?;
        min_period = min_period.min(p);
        load += c as f64 / p as f64;
        if load <= 1.0 {
            k_load = i + 1;
        }
    }
    let mut out = KMax {
        k_max: 0,
        capped: false,
        first_failure: None,
        k_eq12: k_eq12(min_period, c),
        k_load,
        min_period_ticks: min_period,
        interval_cycles: c,
    };
    for k in 1..=storage.len() {
        for (i, slot) in storage[..k].iter_mut().enumerate() {
            *slot = Axis::new(moves[i % moves.len()].clone(), cfg.clock_hz)?;
        }
        let r = Board::new(*cfg, &mut storage[..k])?.run(|_| {});
        if r.underruns > 0 {
            out.first_failure = Some(r);
            return Ok(out);
        }
        out.k_max = k;
    }
    out.capped = true;
    Ok(out)
}

/// A seed-000-shaped trapezoid (accel, cruise, decel times) whose cruise speed is
/// `rate` steps/s (rounded to whole steps).
pub fn rate_move(
    rate: f64,
    accel_time: f64,
    cruise_time: f64,
    decel_time: f64,
) -> Result<Profile, TdmError> {
    let span = 0.5 * accel_time + cruise_time + 0.5 * decel_time;
    let steps = libm::round(rate * span).max(1.0) as u64;
    Ok(Profile::phase(&PhaseMove {
        steps,
        accel_time,
        cruise_time,
        decel_time,
        start_speed: 0.0,
        end_speed: 0.0,
        family: Family::Trapezoid,
    })?)
}
