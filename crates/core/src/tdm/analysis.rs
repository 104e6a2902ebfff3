//! How many axes one calculator serves: simulation against seed 000's rule of thumb.
//!
//! Seed eq. (12): `k = Δt_min / t_calc`. It is a throughput bound for axes that all run at
//! the fastest rate at once: every axis needs one period per Δt_min and each costs t_calc.
//! The simulation ([`k_max`]) differs from it in three ways:
//! - axes at different rates: a slow axis needs few periods, so the real load is
//!   `Σ_m t_calc / Δt_min,m` ([`KMax::k_load`]), and mixed sets fit more axes than eq. (12);
//! - the policy: round-robin serves axes in a fixed order whatever their deadline, so with a
//!   shallow FIFO an urgent axis can wait behind k−1 others that were not urgent;
//! - FIFO depth and phase: with depth D a burst of coinciding deadlines (a synchronous group
//!   starts together, so their edges line up) can be absorbed by periods computed ahead; with
//!   D = 1 nothing is ahead, and all k periods of a common edge must fit into one period.

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
    pub cycles_per_period: u64,
}

/// Shortest period (ticks) of a move at a clock.
pub fn min_period_ticks(profile: &Profile, clock_hz: f64) -> Result<u64, TdmError> {
    Ok(EdgeGenerator::new(profile.clone(), clock_hz)?
        .periods()
        .min()
        .unwrap_or(0))
}

/// Seed 000 eq. (12): `k = Δt_min / t_calc`, rounded down.
pub fn k_eq12(min_period_ticks: u64, cycles_per_period: u64) -> u64 {
    min_period_ticks.checked_div(cycles_per_period).unwrap_or(0)
}

/// Runs k = 1, 2, … axes (axis i runs `moves[i % moves.len()]`, all started together) until
/// the first run with an underrun or `storage` is full; `storage` supplies the axes.
pub fn k_max(cfg: &TdmConfig, moves: &[Profile], storage: &mut [Axis]) -> Result<KMax, TdmError> {
    if moves.is_empty() || storage.is_empty() {
        return Err(TdmError::NoAxes);
    }
    let c = cfg.latencies.cycles_per_period();
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
        cycles_per_period: c,
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
