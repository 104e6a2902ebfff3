//! `multistep experiment`: the seeds' experiments reproduced on the simulator.

use crate::output::ReportFormat;
use clap::{Args, Subcommand};
use multistep_sim::experiments::{self, CurveLimits, CurveLimitsSetup, TwoAxis};
use std::io::Write;

#[derive(Args, Debug)]
pub struct ExperimentArgs {
    #[command(subcommand)]
    pub which: Which,
}

#[derive(Subcommand, Debug)]
pub enum Which {
    /// Seed 001: largest angle in 100 ms and shortest time for 360°, per curve family
    CurveLimits(CurveLimitsArgs),
    /// Seed 000: two 20 mm motors, 50 ms trapezoid, 2400 and 1800 microsteps
    TwoAxis(TwoAxisArgs),
}

#[derive(Args, Debug)]
pub struct CurveLimitsArgs {
    /// Damping ratio ζ of the rotor oscillation (default: the 57mm motor file's)
    #[arg(long, value_name = "Z")]
    pub damping_ratio: Option<f64>,
    /// RK4 time step (s)
    #[arg(long, value_name = "S", default_value_t = multistep_sim::DEFAULT_DT)]
    pub dt: f64,
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    pub format: ReportFormat,
}

#[derive(Args, Debug)]
pub struct TwoAxisArgs {
    /// RK4 time step (s)
    #[arg(long, value_name = "S", default_value_t = multistep_sim::DEFAULT_DT)]
    pub dt: f64,
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    pub format: ReportFormat,
}

pub fn run(a: &ExperimentArgs) -> anyhow::Result<()> {
    match &a.which {
        Which::CurveLimits(c) => curve_limits(c),
        Which::TwoAxis(t) => two_axis(t),
    }
}

fn curve_limits(a: &CurveLimitsArgs) -> anyhow::Result<()> {
    let mut setup = CurveLimitsSetup::seed001()?;
    if let Some(z) = a.damping_ratio {
        setup.motor.damping_ratio = z;
    }
    setup.cfg.dt = a.dt;
    let r = experiments::curve_limits(&setup)?;
    let mut out = std::io::stdout().lock();
    match a.format {
        ReportFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&r)?)?,
        ReportFormat::Table => print_curve_limits(&mut out, &r, &setup)?,
    }
    Ok(())
}

fn deviation(ours: f64, paper: Option<f64>) -> String {
    match paper {
        Some(p) => format!("{:>8.0} {:>+7.1}%", p, 100.0 * (ours - p) / p),
        None => format!("{:>8} {:>8}", "—", ""),
    }
}

fn print_curve_limits(
    out: &mut impl Write,
    r: &CurveLimits,
    s: &CurveLimitsSetup,
) -> std::io::Result<()> {
    writeln!(
        out,
        "seed 001 curve limits: {} motor, {} V, {} microsteps, dt = {:e} s",
        r.motor, r.supply_voltage, r.microsteps, r.dt_s
    )?;
    writeln!(
        out,
        "calibrated: load inertia {:.4e} kg·m² (trapezoid {}° in {} ms is the limit); damping ratio ζ = {:.3} (chosen, not fitted), rotor oscillation {:.1} Hz",
        r.load_inertia, r.calibration_angle_deg, s.period_s * 1e3, r.damping_ratio, r.natural_frequency_hz
    )?;
    let tables = [
        (
            "(a) largest angle without loss in 100 ms (40/20/40 ms)",
            "°",
            &r.max_angle_deg,
            &r.paper_max_angle_deg,
            &r.cells_max_angle,
        ),
        (
            "(b) shortest time for 360° (phases 40:20:40 of the time)",
            "ms",
            &r.min_time_360_ms,
            &r.paper_min_time_360_ms,
            &r.cells_min_time,
        ),
    ];
    for (title, unit, values, paper, cells) in tables {
        writeln!(out)?;
        writeln!(out, "{title}")?;
        writeln!(
            out,
            "{:<12} {:>8} {:>8} {:>8}  {:>16}  {:>10}  first loss just past the limit",
            "family",
            format!("ours {unit}"),
            format!("paper {unit}"),
            "dev",
            "error at limit °",
            "peak °/s"
        )?;
        for fam in &s.families {
            let Some(v) = values.get(fam) else { continue };
            let c = &cells[fam];
            let loss = match (c.loss_past_limit_ms, c.loss_phase) {
                (Some(t), Some(ph)) => format!("{t:.1} ms ({ph})"),
                _ => "—".to_string(),
            };
            let note = if fam == "trapezoid" && unit == "°" {
                " [calibration cell]"
            } else {
                ""
            };
            writeln!(
                out,
                "{:<12} {:>8.1} {}  {:>+7.2} … {:>+5.2}  {:>10.0}  {}{}",
                fam,
                v,
                deviation(*v, paper.get(fam).copied()),
                c.error_min_deg,
                c.error_max_deg,
                c.peak_speed_deg_s,
                loss,
                note
            )?;
        }
    }
    writeln!(out)?;
    writeln!(out, "{} simulations", r.simulations)?;
    Ok(())
}

fn two_axis(a: &TwoAxisArgs) -> anyhow::Result<()> {
    let r: TwoAxis = experiments::two_axis(a.dt)?;
    let mut out = std::io::stdout().lock();
    match a.format {
        ReportFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&r)?)?,
        ReportFormat::Table => {
            writeln!(out, "seed 000 two-axis run: {} motors, {} microsteps, {} V, load {:.2e} kg·m², ζ = {:.3}", r.motor, r.microsteps, r.supply_voltage, r.load_inertia, r.damping_ratio)?;
            writeln!(
                out,
                "trapezoid {}/{}/{} ms from rest; paper: following error within ±{} microsteps",
                r.accel_ms, r.cruise_ms, r.decel_ms, r.paper_bound_steps
            )?;
            writeln!(
                out,
                "{:>6} {:>22} {:>22} {:>12}",
                "steps", "peak error (µsteps)", "range (µsteps)", "lost steps"
            )?;
            for ax in &r.axes {
                writeln!(
                    out,
                    "{:>6} {:>22.2} {:>10.2} … {:>+7.2} {:>12}",
                    ax.steps,
                    ax.peak_following_error_steps,
                    ax.min_following_error_steps,
                    ax.max_following_error_steps,
                    ax.lost_steps
                )?;
            }
        }
    }
    Ok(())
}
