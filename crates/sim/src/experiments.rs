//! The seeds' experiments, reproduced: seed 001's curve limits (largest angle in 100 ms, shortest
//! time for 360°) and seed 000's two-axis hardware run.

use crate::{simulate_profile, Motor, SimConfig, SimError, SimResult};
use multistep_core::{MoveParams, MoveSpec, PlanError, Profile, DEFAULT_CLOCK_HZ};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Seed 001 Table 1: largest angle without lost steps in 100 ms (40 ms accel, 40 ms decel).
pub const PAPER_MAX_ANGLE_DEG: [(&str, f64); 3] = [
    ("trapezoid", 810.0),
    ("exponential", 630.0),
    ("parabolic", 990.0),
];
/// Seed 001 Table 2: shortest time for 360° with the phases in proportion 40:20:40.
pub const PAPER_MIN_TIME_360_MS: [(&str, f64); 3] = [
    ("trapezoid", 48.0),
    ("exponential", 54.0),
    ("parabolic", 42.0),
];
/// The families compared: seed 001's three, then sine and both S-curves.
pub const FAMILIES: [&str; 6] = [
    "trapezoid",
    "exponential",
    "parabolic",
    "sine",
    "scurve",
    "scurve4",
];

/// A phase-mode move (DESIGN.md §2): `steps` of `family` in accel, cruise and decel times.
pub fn phase_move(family: &str, steps: u64, [ta, tb, tc]: [f64; 3]) -> Result<Profile, PlanError> {
    MoveSpec {
        profile: Some(family),
        steps: Some(steps),
        params: MoveParams {
            accel_time: Some(ta),
            cruise_time: Some(tb),
            decel_time: Some(tc),
            ..MoveParams::default()
        },
        ..Default::default()
    }
    .plan()
}

/// Settings of the curve-limits experiment (seed 001 §3).
#[derive(Clone, Debug)]
pub struct CurveLimitsSetup {
    pub motor: Motor,
    pub cfg: SimConfig,
    pub clock_hz: f64,
    /// Total move time of Table 1 and its phase fractions (accel, cruise, decel).
    pub period_s: f64,
    pub fractions: [f64; 3],
    /// Bisection resolution: angle (°) and time (s).
    pub angle_tol_deg: f64,
    pub time_tol_s: f64,
    /// Calibration cell: trapezoid at this angle is the largest without loss.
    pub calibration_angle_deg: f64,
    pub families: Vec<String>,
    /// Simulations run so far (all threads).
    pub simulations: Arc<AtomicU64>,
}

impl CurveLimitsSetup {
    /// Seed 001's setup on the 57 mm motor at 24 V and 256 microsteps.
    pub fn seed001() -> Result<CurveLimitsSetup, SimError> {
        let motor = Motor::load("57mm")?;
        let mut cfg = SimConfig::for_motor(&motor);
        cfg.driver.supply_voltage = 24.0;
        cfg.driver.microsteps = 256;
        Ok(CurveLimitsSetup {
            motor,
            cfg,
            clock_hz: DEFAULT_CLOCK_HZ,
            period_s: 0.1,
            fractions: [0.4, 0.2, 0.4],
            angle_tol_deg: 1.0,
            time_tol_s: 0.5e-3,
            calibration_angle_deg: 810.0,
            families: FAMILIES.iter().map(|s| s.to_string()).collect(),
            simulations: Arc::new(AtomicU64::new(0)),
        })
    }

    /// Accel, cruise and decel times of a move lasting `period_s`.
    fn phases(&self, period_s: f64) -> [f64; 3] {
        self.fractions.map(|f| f * period_s)
    }

    fn steps_for(&self, angle_deg: f64) -> u64 {
        (angle_deg / 1.8 * self.cfg.driver.microsteps as f64).round() as u64
    }

    /// Simulates `family` over `angle_deg` in `period_s` with the setup's phase fractions.
    pub fn run(
        &self,
        motor: &Motor,
        family: &str,
        angle_deg: f64,
        period_s: f64,
        stop_at_loss: bool,
    ) -> Result<SimResult, SimError> {
        let profile = phase_move(family, self.steps_for(angle_deg), self.phases(period_s))?;
        let mut cfg = self.cfg.clone();
        cfg.stop_at_first_loss = stop_at_loss;
        self.simulations.fetch_add(1, Ordering::Relaxed);
        simulate_profile(motor, &cfg, profile, self.clock_hz, 1.0)
    }

    fn passes(&self, m: &Motor, family: &str, angle: f64, period: f64) -> Result<bool, SimError> {
        Ok(!self.run(m, family, angle, period, true)?.lost)
    }

    /// Largest angle (multiple of the tolerance) that `family` moves without loss in the period.
    pub fn max_angle(&self, m: &Motor, family: &str) -> Result<f64, SimError> {
        let tol = self.angle_tol_deg;
        let (mut lo, mut hi) = (0.0, 360.0);
        while self.passes(m, family, hi, self.period_s)? {
            lo = hi;
            hi *= 2.0;
            if hi > 1e5 {
                return Ok(f64::INFINITY);
            }
        }
        while hi - lo > tol {
            let mid = ((lo + hi) / 2.0 / tol).round() * tol;
            let mid = if mid <= lo || mid >= hi {
                (lo + hi) / 2.0
            } else {
                mid
            };
            if self.passes(m, family, mid, self.period_s)? {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(lo)
    }

    /// Shortest period (to the tolerance) in which `family` moves 360° without loss.
    pub fn min_time_360(&self, m: &Motor, family: &str) -> Result<f64, SimError> {
        let tol = self.time_tol_s;
        let (mut lo, mut hi) = (self.period_s / 2.0, self.period_s);
        while !self.passes(m, family, 360.0, hi)? {
            lo = hi;
            hi *= 2.0;
            if hi > 10.0 {
                return Ok(f64::INFINITY);
            }
        }
        while self.passes(m, family, 360.0, lo)? {
            hi = lo;
            lo /= 2.0;
            if lo < 1e-4 {
                return Ok(hi);
            }
        }
        while hi - lo > tol {
            let mid = 0.5 * (lo + hi);
            if self.passes(m, family, 360.0, mid)? {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Ok(hi)
    }

    /// The one calibrated parameter: the largest load inertia for which the trapezoid still
    /// moves the calibration angle in the period without loss (bisection to 0.2 %).
    pub fn calibrate_load_inertia(&self) -> Result<f64, SimError> {
        let with = |jl: f64| {
            let mut m = self.motor.clone();
            m.load_inertia = jl;
            m
        };
        let ok = |jl: f64| {
            self.passes(
                &with(jl),
                "trapezoid",
                self.calibration_angle_deg,
                self.period_s,
            )
        };
        if !ok(0.0)? {
            return Err(SimError::BadSetting {
                field: "calibration_angle",
                value: self.calibration_angle_deg,
                why: "the unloaded motor already loses steps there: no load inertia can match it"
                    .into(),
            });
        }
        let (mut lo, mut hi) = (0.0, self.motor.rotor_inertia);
        while ok(hi)? {
            lo = hi;
            hi *= 2.0;
            if hi > 1e3 * self.motor.rotor_inertia {
                return Ok(hi);
            }
        }
        while hi - lo > 2e-3 * hi {
            let mid = 0.5 * (lo + hi);
            if ok(mid)? {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Ok(lo)
    }
}

/// One cell of a table: the limit found, how the rotor behaves at it, and where the move just
/// past it first loses a step (the mechanism that sets the limit).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Cell {
    /// Degrees (table a) or milliseconds (table b).
    pub value: f64,
    /// Following-error range at the limit (°), as in seed 001's tables.
    pub error_min_deg: f64,
    pub error_max_deg: f64,
    /// Commanded peak speed (°/s) and the acceleration at the end of the accel phase (°/s²).
    pub peak_speed_deg_s: f64,
    pub accel_at_peak_speed_deg_s2: f64,
    /// First loss of the move one resolution step past the limit (ms from the start), and the
    /// phase it falls in: accel, cruise, decel or settle.
    pub loss_past_limit_ms: Option<f64>,
    pub loss_phase: Option<&'static str>,
}

/// Result of `experiment curve-limits`.
#[derive(Clone, Debug, Serialize)]
pub struct CurveLimits {
    pub motor: String,
    pub supply_voltage: f64,
    pub microsteps: u32,
    pub dt_s: f64,
    /// The one calibrated parameter (kg·m²), on trapezoid @ the calibration angle.
    pub load_inertia: f64,
    pub calibration_angle_deg: f64,
    pub damping_ratio: f64,
    pub natural_frequency_hz: f64,
    pub max_angle_deg: BTreeMap<String, f64>,
    pub min_time_360_ms: BTreeMap<String, f64>,
    pub paper_max_angle_deg: BTreeMap<String, f64>,
    pub paper_min_time_360_ms: BTreeMap<String, f64>,
    pub cells_max_angle: BTreeMap<String, Cell>,
    pub cells_min_time: BTreeMap<String, Cell>,
    /// Simulations the whole experiment ran (calibration included).
    pub simulations: u64,
}

#[derive(Clone, Copy, PartialEq)]
enum Table {
    MaxAngle,
    MinTime,
}

impl CurveLimitsSetup {
    /// Describes the cell at (`angle`, `period`) and the failing move `past` (angle, period).
    fn cell(
        &self,
        m: &Motor,
        fam: &str,
        value: f64,
        at: (f64, f64),
        past: (f64, f64),
    ) -> Result<Cell, SimError> {
        let r = self.run(m, fam, at.0, at.1, false)?;
        let fail = self.run(m, fam, past.0, past.1, true)?;
        let [fa, fb, fc] = self.fractions;
        let p = past.1;
        let loss_phase = fail.first_loss_s.map(|t| {
            if t < fa * p {
                "accel"
            } else if t < (fa + fb) * p {
                "cruise"
            } else if t < (fa + fb + fc) * p {
                "decel"
            } else {
                "settle"
            }
        });
        let profile = phase_move(fam, self.steps_for(at.0), self.phases(at.1))?;
        let deg_per_step = 1.8 / self.cfg.driver.microsteps as f64;
        // Just before the end of the accel phase: the acceleration at the peak speed.
        let t_top = fa * at.1 * (1.0 - 1e-9);
        Ok(Cell {
            value,
            error_min_deg: r.min_following_error_deg,
            error_max_deg: r.max_following_error_deg,
            peak_speed_deg_s: profile.peak_speed() * deg_per_step,
            accel_at_peak_speed_deg_s2: profile.acceleration(t_top) * deg_per_step,
            loss_past_limit_ms: fail.first_loss_s.map(|t| t * 1e3),
            loss_phase,
        })
    }
}

/// Runs the whole experiment: calibration, then every (family, table) cell in parallel.
pub fn curve_limits(setup: &CurveLimitsSetup) -> Result<CurveLimits, SimError> {
    let cells: Vec<(String, Table)> = setup
        .families
        .iter()
        .flat_map(|f| [(f.clone(), Table::MaxAngle), (f.clone(), Table::MinTime)])
        .collect();
    let bar = crate::progress::progress(cells.len() as u64 + 1);
    bar.set_message("calibrating load inertia");
    let jl = setup.calibrate_load_inertia()?;
    bar.inc(1);
    let mut motor = setup.motor.clone();
    motor.load_inertia = jl;
    bar.set_message("curve limits");
    let results: Vec<(String, Table, Cell)> = cells
        .par_iter()
        .map(|(fam, table)| {
            let cell = match table {
                Table::MaxAngle => {
                    let a = setup.max_angle(&motor, fam)?;
                    let p = setup.period_s;
                    setup.cell(&motor, fam, a, (a, p), (a + setup.angle_tol_deg, p))?
                }
                Table::MinTime => {
                    let t = setup.min_time_360(&motor, fam)?;
                    let past = (t - setup.time_tol_s).max(t / 2.0);
                    setup.cell(&motor, fam, t * 1e3, (360.0, t), (360.0, past))?
                }
            };
            bar.inc(1);
            Ok((fam.clone(), *table, cell))
        })
        .collect::<Result<_, SimError>>()?;
    bar.finish_and_clear();
    let named = |t: &[(&str, f64)]| t.iter().map(|(k, v)| (k.to_string(), *v)).collect();
    let mut out = CurveLimits {
        motor: motor.name.clone(),
        supply_voltage: setup.cfg.driver.supply_voltage,
        microsteps: setup.cfg.driver.microsteps,
        dt_s: setup.cfg.dt,
        load_inertia: jl,
        calibration_angle_deg: setup.calibration_angle_deg,
        damping_ratio: motor.effective_damping_ratio(setup.cfg.driver.current),
        natural_frequency_hz: motor.natural_frequency(setup.cfg.driver.current)
            / std::f64::consts::TAU,
        max_angle_deg: BTreeMap::new(),
        min_time_360_ms: BTreeMap::new(),
        paper_max_angle_deg: named(&PAPER_MAX_ANGLE_DEG),
        paper_min_time_360_ms: named(&PAPER_MIN_TIME_360_MS),
        cells_max_angle: BTreeMap::new(),
        cells_min_time: BTreeMap::new(),
        simulations: 0,
    };
    for (fam, table, cell) in results {
        let (values, cells) = match table {
            Table::MaxAngle => (&mut out.max_angle_deg, &mut out.cells_max_angle),
            Table::MinTime => (&mut out.min_time_360_ms, &mut out.cells_min_time),
        };
        values.insert(fam.clone(), cell.value);
        cells.insert(fam, cell);
    }
    out.simulations = setup.simulations.load(Ordering::Relaxed);
    Ok(out)
}

/// One axis of the two-axis run.
#[derive(Clone, Debug, Serialize)]
pub struct AxisResult {
    pub steps: u64,
    pub peak_following_error_steps: f64,
    pub lost_steps: i64,
    pub min_following_error_steps: f64,
    pub max_following_error_steps: f64,
    pub final_error_steps: f64,
}

/// Result of `experiment two-axis`.
#[derive(Clone, Debug, Serialize)]
pub struct TwoAxis {
    pub motor: String,
    pub microsteps: u32,
    pub supply_voltage: f64,
    pub load_inertia: f64,
    pub damping_ratio: f64,
    pub accel_ms: f64,
    pub cruise_ms: f64,
    pub decel_ms: f64,
    /// Seed 000: following error within ±8 microsteps.
    pub paper_bound_steps: f64,
    pub axes: Vec<AxisResult>,
}

/// Seed 000's hardware run: two 20 mm motors, 16 microsteps, a 50 ms trapezoid (20/10/20 ms)
/// from rest, 2400 and 1800 microsteps, started on the same tick.
pub fn two_axis(dt: f64) -> Result<TwoAxis, SimError> {
    let motor = Motor::load("20mm")?;
    let mut cfg = SimConfig::for_motor(&motor);
    cfg.dt = dt;
    let (ta, tb, tc) = (0.020, 0.010, 0.020);
    let axes = [2400u64, 1800]
        .par_iter()
        .map(|&n| {
            let profile = phase_move("trapezoid", n, [ta, tb, tc])?;
            let r = simulate_profile(&motor, &cfg, profile, DEFAULT_CLOCK_HZ, 1.0)?;
            let per = 1.8 / cfg.driver.microsteps as f64;
            Ok(AxisResult {
                steps: r.steps,
                peak_following_error_steps: r.peak_following_error_steps,
                lost_steps: r.lost_steps,
                min_following_error_steps: r.min_following_error_deg / per,
                max_following_error_steps: r.max_following_error_deg / per,
                final_error_steps: r.final_error_deg / per,
            })
        })
        .collect::<Result<Vec<_>, SimError>>()?;
    Ok(TwoAxis {
        motor: motor.name.clone(),
        microsteps: cfg.driver.microsteps,
        supply_voltage: cfg.driver.supply_voltage,
        load_inertia: motor.load_inertia,
        damping_ratio: motor.effective_damping_ratio(cfg.driver.current),
        accel_ms: ta * 1e3,
        cruise_ms: tb * 1e3,
        decel_ms: tc * 1e3,
        paper_bound_steps: 8.0,
        axes,
    })
}
