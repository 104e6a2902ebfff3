//! `multistep tdm --sweep`: k_max (the most axes one calculator serves with no underrun)
//! against the maximum step rate, next to seed 000's eq. (12), as a table and an SVG plot.
//!
//! Every axis runs the same seed-000-shaped trapezoid, all started together: the worst
//! phase alignment, since every axis needs its periods at the same ticks.

use super::config::ConfigFile;
use super::{PolicyArg, TdmArgs, TdmFormat};
use anyhow::{bail, Context};
use clap::Args;
use multistep_core::tdm::{k_max, rate_move, Axis, KMax, Policy, TdmConfig, MAX_AXES};
use plotters::prelude::*;
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// The most rates one sweep takes (a plot has no use for more points).
const MAX_POINTS: usize = 1000;

#[derive(Args, Debug)]
pub struct SweepArgs {
    /// Sweep: maximum step rates MIN:MAX:POINTS (steps/s; 1 to 1000 points)
    #[arg(long, value_name = "MIN:MAX:N", default_value = "10000:200000:20")]
    pub rates: String,
    /// Sweep and --k-max: most axes to try (up to 64)
    #[arg(long, value_name = "K", default_value_t = MAX_AXES)]
    pub max_axes: usize,
    /// Sweep: FIFO depths to compare
    #[arg(
        long,
        value_name = "D,..",
        value_delimiter = ',',
        default_value = "1,4"
    )]
    pub fifo_depths: Vec<usize>,
    /// Sweep: accel, cruise and decel time of each axis's trapezoid (s)
    #[arg(long, value_name = "TA:TB:TC", default_value = "0.02:0.01:0.02")]
    pub move_times: String,
    /// Sweep: SVG plot of k_max against the rate
    #[arg(long, value_name = "FILE", default_value = "tdm-sweep.svg")]
    pub plot: PathBuf,
}

#[derive(Serialize, Debug)]
struct Series {
    policy: &'static str,
    fifo_depth: usize,
    k_max: usize,
    /// k_max is the most axes tried; the real bound may be higher.
    capped: bool,
}

#[derive(Serialize, Debug)]
struct Row {
    rate_steps_per_s: f64,
    min_period_ticks: u64,
    k_eq12: u64,
    series: Vec<Series>,
}

#[derive(Serialize, Debug)]
struct SweepOut {
    clock_hz: f64,
    interval_cycles: u64,
    latency_cycles: u64,
    move_times_s: [f64; 3],
    rows: Vec<Row>,
}

fn numbers<const N: usize>(s: &str, what: &str) -> anyhow::Result<[f64; N]> {
    let v: Vec<f64> = s
        .split(':')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{what} '{s}'"))?;
    v.try_into()
        .map_err(|_| anyhow::anyhow!("{what} '{s}' needs {N} numbers separated by ':'"))
}

pub fn run(args: &TdmArgs) -> anyhow::Result<()> {
    let sa = &args.sweep_args;
    let [lo, hi, n] = numbers::<3>(&sa.rates, "--rates")?;
    let times = numbers::<3>(&sa.move_times, "--move-times")?;
    if !(lo > 0.0 && hi >= lo && (1.0..=MAX_POINTS as f64).contains(&n) && n.fract() == 0.0) {
        bail!("--rates MIN:MAX:N needs 0 < MIN <= MAX and a whole N from 1 to {MAX_POINTS}");
    }
    if sa.max_axes == 0 || sa.max_axes > MAX_AXES {
        bail!("--max-axes must be 1 to {MAX_AXES}");
    }
    let file = match &args.config {
        Some(p) => ConfigFile::load(p)?,
        None => ConfigFile::default(),
    };
    let base = file.board(None)?;
    let policies: Vec<Policy> = match args.policy {
        Some(p) => vec![Policy::from(p)],
        None => vec![
            PolicyArg::RoundRobin.into(),
            PolicyArg::EarliestDeadline.into(),
        ],
    };
    let n = n as usize;
    let rate = |i: usize| {
        if n == 1 {
            lo
        } else {
            lo + (hi - lo) * i as f64 / (n - 1) as f64
        }
    };
    // every rate's k_max search, once per FIFO depth and policy
    let runs = (sa.fifo_depths.len() * policies.len()) as u128;
    let mut edges: u128 = 0;
    for i in 0..n {
        let steps = rate_move(rate(i), times[0], times[1], times[2])?.steps();
        edges += runs * super::k_max_edges(&[steps], sa.max_axes);
        super::check_edges(
            edges,
            "lower the rates, shorten --move-times, or give fewer points, --fifo-depths or --max-axes",
        )?;
    }
    let mut rows = Vec::with_capacity(n);
    for i in 0..n {
        let rate = rate(i);
        let mv = rate_move(rate, times[0], times[1], times[2])?;
        let mut storage: Vec<Axis> = (0..sa.max_axes)
            .map(|_| Axis::new(mv.clone(), base.clock_hz))
            .collect::<Result<_, _>>()?;
        let mut row = None::<Row>;
        let mut series = Vec::new();
        for &fifo_depth in &sa.fifo_depths {
            for &policy in &policies {
                let cfg = TdmConfig {
                    fifo_depth,
                    policy,
                    ..base
                };
                let km: KMax = k_max(&cfg, std::slice::from_ref(&mv), &mut storage)?;
                row.get_or_insert(Row {
                    rate_steps_per_s: rate,
                    min_period_ticks: km.min_period_ticks,
                    k_eq12: km.k_eq12,
                    series: Vec::new(),
                });
                series.push(Series {
                    policy: policy.name(),
                    fifo_depth,
                    k_max: km.k_max,
                    capped: km.capped,
                });
            }
        }
        let mut row = row.context("--fifo-depths is empty")?;
        row.series = series;
        rows.push(row);
    }
    let out = SweepOut {
        clock_hz: base.clock_hz,
        interval_cycles: base.latencies.interval(),
        latency_cycles: base.latencies.latency(),
        move_times_s: times,
        rows,
    };
    plot(&out, &sa.plot)?;
    let mut w = std::io::stdout().lock();
    match args.format {
        TdmFormat::Json => writeln!(w, "{}", serde_json::to_string_pretty(&out)?)?,
        TdmFormat::Table => print_table(&mut w, &out)?,
    }
    w.flush()?;
    eprintln!("plot written to {}", sa.plot.display());
    Ok(())
}

fn series_name(s: &Series) -> String {
    format!("{} D={}", s.policy, s.fifo_depth)
}

fn print_table(w: &mut impl Write, out: &SweepOut) -> anyhow::Result<()> {
    writeln!(
        w,
        "clock {} Hz, t_calc {} cycles (latency {}), trapezoid {:?} s, all axes started together",
        out.clock_hz, out.interval_cycles, out.latency_cycles, out.move_times_s
    )?;
    write!(w, "{:>12} {:>8} {:>6}", "rate", "Δt_min", "eq.12")?;
    if let Some(r) = out.rows.first() {
        for s in &r.series {
            write!(w, " {:>22}", series_name(s))?;
        }
    }
    writeln!(w)?;
    for r in &out.rows {
        write!(
            w,
            "{:>12.0} {:>8} {:>6}",
            r.rate_steps_per_s, r.min_period_ticks, r.k_eq12
        )?;
        for s in &r.series {
            let k = if s.capped {
                format!(">={}", s.k_max)
            } else {
                s.k_max.to_string()
            };
            write!(w, " {:>22}", k)?;
        }
        writeln!(w)?;
    }
    Ok(())
}

fn plot(out: &SweepOut, path: &PathBuf) -> anyhow::Result<()> {
    let xmax = out
        .rows
        .iter()
        .map(|r| r.rate_steps_per_s)
        .fold(0.0, f64::max)
        / 1e3;
    let ymax = out
        .rows
        .iter()
        .flat_map(|r| r.series.iter().map(|s| s.k_max as u64).chain([r.k_eq12]))
        .max()
        .unwrap_or(1)
        .min(MAX_AXES as u64 + 4) as f64;
    multistep_sim::plot::ensure_font().map_err(anyhow::Error::msg)?;
    let root = SVGBackend::new(path, (900, 560)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!(
                "axes served by one calculator (t_calc {} cycles, latency {})",
                out.interval_cycles, out.latency_cycles
            ),
            ("sans-serif", 20),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..xmax * 1.02, 0.0..ymax * 1.05 + 1.0)?;
    chart
        .configure_mesh()
        .x_desc("maximum step rate (k steps/s)")
        .y_desc("axes with no underrun")
        .draw()?;
    let eq12: Vec<(f64, f64)> = out
        .rows
        .iter()
        .map(|r| (r.rate_steps_per_s / 1e3, (r.k_eq12 as f64).min(ymax)))
        .collect();
    chart
        .draw_series(LineSeries::new(eq12, BLACK.stroke_width(2)))?
        .label("seed eq. (12): Δt_min / t_calc")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    let count = out.rows.first().map_or(0, |r| r.series.len());
    for i in 0..count {
        let color = Palette99::pick(i).to_rgba();
        let pts: Vec<(f64, f64)> = out
            .rows
            .iter()
            .map(|r| (r.rate_steps_per_s / 1e3, r.series[i].k_max as f64))
            .collect();
        let name = series_name(&out.rows[0].series[i]);
        chart
            .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}
