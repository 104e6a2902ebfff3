//! `multistep demo`: seed 000's two-axis experiment end to end — plan both moves, run them
//! through the TDM engine (one shared calculator, FIFO depth 1), drive two simulated 20 mm
//! motors with the edges the engine emitted, and report timing faults and following error.

use crate::output::ReportFormat;
use crate::tdm::config::ConfigFile;
use anyhow::Context;
use clap::Args;
use multistep_core::tdm::{Axis, Board, StepPulse};
use multistep_sim::plot::{plot_trace, ErrorUnit};
use multistep_sim::{simulate_edges, Motor, SimConfig};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// Seed 000's run, shipped with the binary so the demo needs no files.
const SEED000: &str = include_str!("../../../examples/seed000-two-axis.toml");

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Folder for the speed and following-error plots
    #[arg(long, value_name = "DIR", default_value = "out/demo")]
    pub out: PathBuf,
    /// A TDM config to run instead of seed 000's two axes
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Motor model for every axis (library name or TOML file)
    #[arg(long, value_name = "NAME|FILE", default_value = "20mm")]
    pub motor: String,
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    pub format: ReportFormat,
}

#[derive(Serialize, Debug)]
struct DemoAxis {
    axis: String,
    steps: u64,
    duration_s: f64,
    underruns: u64,
    min_slack_ticks: i64,
    peak_following_error_steps: f64,
    lost_steps: i64,
    plot: String,
}

#[derive(Serialize, Debug)]
struct DemoReport {
    motor: String,
    clock_hz: f64,
    fifo_depth: usize,
    calculator_utilization: f64,
    start_skew_ticks: u64,
    axes: Vec<DemoAxis>,
}

pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    let file = match &args.config {
        Some(p) => ConfigFile::load(p)?,
        None => ConfigFile::parse(SEED000)?,
    };
    let cfg = file.board(None)?;
    let names = file.axis_names();
    let mut axes = file
        .profiles()?
        .into_iter()
        .map(|p| Axis::new(p, cfg.clock_hz))
        .collect::<Result<Vec<_>, _>>()?;

    // 1. the TDM engine: every rising edge of every axis, as the pulse units emit them
    let mut rises: Vec<Vec<u64>> = vec![Vec::new(); axes.len()];
    let board = Board::new(cfg, &mut axes)?;
    let start = board.start_tick();
    let report = board.run(|p: StepPulse| rises[p.axis].push(p.rise - start));

    // 2. the motors, driven by exactly those edges
    let motor = Motor::load(&args.motor)?;
    let mut sim_cfg = SimConfig::for_motor(&motor);
    sim_cfg.trace_interval = Some(50e-6);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    // the table and the plots give the following error in the driver's microsteps
    let per_step_deg = motor
        .microstep_angle(sim_cfg.driver.microsteps)
        .to_degrees();
    let mut out_axes = Vec::new();
    let mut plots = Vec::new();
    for (k, edges) in rises.iter().enumerate() {
        let r = simulate_edges(&motor, &sim_cfg, edges.iter().copied(), cfg.clock_hz, 1.0)?;
        let plot = args.out.join(format!("axis{k}-{}.svg", names[k]));
        let title = format!(
            "axis {} ({}): {} microsteps through the TDM engine, {} motor",
            k, names[k], r.steps, motor.name
        );
        let st = axes[k].stats();
        out_axes.push(DemoAxis {
            axis: names[k].clone(),
            steps: st.steps,
            duration_s: edges.last().copied().unwrap_or(0) as f64 / cfg.clock_hz,
            underruns: st.underruns,
            min_slack_ticks: st.min_slack_ticks,
            peak_following_error_steps: r.peak_following_error_deg / per_step_deg,
            lost_steps: r.lost_steps,
            plot: plot.display().to_string(),
        });
        plots.push((plot, title, r.trace));
    }
    let rep = DemoReport {
        motor: motor.name.clone(),
        clock_hz: cfg.clock_hz,
        fifo_depth: cfg.fifo_depth,
        calculator_utilization: report.calculator_utilization(),
        start_skew_ticks: report.start_skew_ticks,
        axes: out_axes,
    };
    let mut o = std::io::stdout().lock();
    match args.format {
        ReportFormat::Json => writeln!(o, "{}", serde_json::to_string_pretty(&rep)?)?,
        ReportFormat::Table => {
            writeln!(
                o,
                "seed 000 two-axis run: TDM engine (FIFO depth {}, calculator busy {:.1} %, start skew {} ticks) → {} motors",
                rep.fifo_depth,
                100.0 * rep.calculator_utilization,
                rep.start_skew_ticks,
                rep.motor
            )?;
            writeln!(
                o,
                "{:<6} {:>7} {:>10} {:>9} {:>11} {:>16} {:>6}",
                "axis", "steps", "duration", "underruns", "min slack", "peak error", "lost"
            )?;
            for a in &rep.axes {
                writeln!(
                    o,
                    "{:<6} {:>7} {:>8.4} s {:>9} {:>5} ticks {:>8.2} μsteps {:>6}",
                    a.axis,
                    a.steps,
                    a.duration_s,
                    a.underruns,
                    a.min_slack_ticks,
                    a.peak_following_error_steps,
                    a.lost_steps
                )?;
            }
            writeln!(o, "plots: {}", args.out.display())?;
        }
    }
    o.flush()?;
    drop(o);
    // The table comes first: a plot that cannot be drawn does not hide the results.
    let unit = ErrorUnit::Microsteps { deg: per_step_deg };
    for (plot, title, trace) in &plots {
        plot_trace(&plot.to_string_lossy(), title, trace, unit)?;
    }
    Ok(())
}
