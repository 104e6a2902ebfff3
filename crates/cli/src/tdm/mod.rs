//! `multistep tdm`: run a multi-axis config through the TDM engine, or sweep how many axes
//! one calculator serves.

pub(crate) mod config;
mod sweep;

use crate::plan::{itoa_buf, write_row};
use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use config::ConfigFile;
use multistep_core::tdm::{k_eq12, k_max, Axis, Board, Policy, Report, StepPulse, TdmConfig};
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PolicyArg {
    RoundRobin,
    EarliestDeadline,
}

impl From<PolicyArg> for Policy {
    fn from(p: PolicyArg) -> Policy {
        match p {
            PolicyArg::RoundRobin => Policy::RoundRobin,
            PolicyArg::EarliestDeadline => Policy::EarliestDeadline,
        }
    }
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TdmFormat {
    Table,
    Json,
}

#[derive(Args, Debug)]
pub struct TdmArgs {
    /// Board and axes (TOML): clock, fifo_depth, *_cycles, [[axis]] tables
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Scheduling policy (overrides the config's)
    #[arg(long, value_enum)]
    pub policy: Option<PolicyArg>,
    /// Write each axis's edges as axis0.csv, axis1.csv, … (plan's CSV; ticks from the start)
    #[arg(long, value_name = "DIR")]
    pub edges_dir: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t = TdmFormat::Table)]
    pub format: TdmFormat,
    /// Sweep: the largest underrun-free number of axes against the maximum step rate
    #[arg(long)]
    pub sweep: bool,
    /// Analysis: the most axes that run the config's moves with no underrun (axis i runs
    /// move i mod n, all started together), up to --max-axes; next to seed eq. (12)
    #[arg(long)]
    pub k_max: bool,
    #[command(flatten)]
    pub sweep_args: sweep::SweepArgs,
}

#[derive(Serialize, Debug)]
struct AxisSummary {
    index: usize,
    name: Option<String>,
    steps: u64,
    underruns: u64,
    late_ticks: u64,
    min_slack_ticks: Option<i64>,
    min_period_ticks: u64,
    last_edge_tick: u64,
    merged_pulses: u64,
}

#[derive(Serialize, Debug)]
struct RunSummary {
    policy: &'static str,
    clock_hz: f64,
    fifo_depth: usize,
    /// Cycles between computation starts (t_calc of seed eq. (12)).
    interval_cycles: u64,
    /// Cycles from a computation's start to its FIFO write.
    latency_cycles: u64,
    start_tick: u64,
    end_tick: u64,
    edges: u64,
    underruns: u64,
    max_late_ticks: u64,
    /// Least (needed − ready) over all periods after the first; null with no such period.
    min_slack_ticks: Option<i64>,
    calculator_utilization: f64,
    start_skew_ticks: u64,
    merged_pulses: u64,
    /// Seed eq. (12) for this set: shortest period over all axes / cycles per period.
    k_eq12: u64,
    /// Σ over axes of cycles / shortest period: the calculator's load at the peak rates.
    peak_load: f64,
    axes: Vec<AxisSummary>,
}

/// The most step edges one `tdm` command may compute: about a minute at the engine's
/// ~7 ns per edge (1e8 edges take 0.74 s).
pub(crate) const MAX_EDGES: u128 = 5_000_000_000;

/// Refuses a command that would compute more than [`MAX_EDGES`] edges; `reduce` says how
/// to ask for less.
pub(crate) fn check_edges(edges: u128, reduce: &str) -> anyhow::Result<()> {
    if edges > MAX_EDGES {
        bail!(
            "this would compute up to {edges} step edges, more than the {MAX_EDGES} allowed \
             (about a minute of work): {reduce}"
        );
    }
    Ok(())
}

/// Edges of a `--k-max` search at most: it runs 1, 2, … `n` axes (axis i runs move i mod
/// the number of moves), so axis i runs in `n − i` of them.
pub(crate) fn k_max_edges(steps: &[u64], n: usize) -> u128 {
    (0..n)
        .map(|i| steps[i % steps.len()] as u128 * (n - i) as u128)
        .sum()
}

pub fn run(args: &TdmArgs) -> anyhow::Result<()> {
    check_mode(args)?;
    if args.sweep {
        return sweep::run(args);
    }
    let path = args
        .config
        .as_ref()
        .context("tdm needs --config FILE.toml (or --sweep)")?;
    let file = ConfigFile::load(path)?;
    let cfg = file.board(args.policy.map(Policy::from))?;
    if args.k_max {
        return print_k_max(args, &cfg, &file.profiles()?);
    }
    let profiles = file.profiles()?;
    check_edges(
        profiles.iter().map(|p| p.steps() as u128).sum(),
        "give the axes fewer steps",
    )?;
    let mut axes = profiles
        .into_iter()
        .map(|p| Axis::new(p, cfg.clock_hz))
        .collect::<Result<Vec<_>, _>>()?;
    let (report, min_periods) = run_board(cfg, &mut axes, args.edges_dir.as_deref())?;
    let s = summarize(&cfg, &report, &axes, &min_periods, &file);
    let mut out = std::io::stdout().lock();
    match args.format {
        TdmFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?,
        TdmFormat::Table => print_table(&mut out, &s)?,
    }
    if s.underruns > 0 {
        eprintln!(
            "warning: {} underruns (timing faults); the last edge is up to {} ticks late",
            s.underruns, s.max_late_ticks
        );
    }
    Ok(())
}

/// Runs the board; writes per-axis CSVs when asked; returns each axis's shortest period.
fn run_board(
    cfg: TdmConfig,
    axes: &mut [Axis],
    edges_dir: Option<&Path>,
) -> anyhow::Result<(Report, Vec<u64>)> {
    let k = axes.len();
    let board = Board::new(cfg, axes)?;
    let start = board.start_tick();
    let mut writers = match edges_dir {
        Some(dir) => {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            (0..k)
                .map(|m| {
                    let path = dir.join(format!("axis{m}.csv"));
                    let mut w = BufWriter::with_capacity(1 << 16, File::create(&path)?);
                    writeln!(w, "step,edge_tick,period_ticks")?;
                    Ok(w)
                })
                .collect::<std::io::Result<Vec<_>>>()?
        }
        None => Vec::new(),
    };
    let mut last = vec![start; k];
    let mut min_period = vec![u64::MAX; k];
    let mut err: Option<std::io::Error> = None;
    let mut buf = itoa_buf();
    let report = board.run(|p: StepPulse| {
        let period = p.rise - last[p.axis];
        last[p.axis] = p.rise;
        min_period[p.axis] = min_period[p.axis].min(period);
        if let (Some(w), None) = (writers.get_mut(p.axis), &err) {
            if let Err(e) = write_row(w, &mut buf, p.step, p.rise - start, period) {
                err = Some(e);
            }
        }
    });
    if let Some(e) = err {
        return Err(e).context("writing edges");
    }
    for mut w in writers {
        w.flush()?;
    }
    Ok((report, min_period))
}

fn summarize(
    cfg: &TdmConfig,
    r: &Report,
    axes: &[Axis],
    min_periods: &[u64],
    file: &ConfigFile,
) -> RunSummary {
    let c = r.interval_cycles;
    let slack = |s: i64| (s != i64::MAX).then_some(s);
    let dmin = min_periods.iter().copied().min().unwrap_or(0);
    RunSummary {
        policy: cfg.policy.name(),
        clock_hz: cfg.clock_hz,
        fifo_depth: cfg.fifo_depth,
        interval_cycles: c,
        latency_cycles: r.latency_cycles,
        start_tick: r.start_tick,
        end_tick: r.end_tick,
        edges: r.edges,
        underruns: r.underruns,
        max_late_ticks: r.max_late_ticks,
        min_slack_ticks: slack(r.min_slack_ticks),
        calculator_utilization: r.calculator_utilization(),
        start_skew_ticks: r.start_skew_ticks,
        merged_pulses: r.merged_pulses,
        k_eq12: k_eq12(dmin, c),
        peak_load: min_periods
            .iter()
            .map(|&p| c as f64 / p.max(1) as f64)
            .sum(),
        axes: axes
            .iter()
            .enumerate()
            .map(|(m, a)| {
                let st = a.stats();
                AxisSummary {
                    index: m,
                    name: file.axis.get(m).and_then(|e| e.name.clone()),
                    steps: st.steps,
                    underruns: st.underruns,
                    late_ticks: st.late_ticks,
                    min_slack_ticks: slack(st.min_slack_ticks),
                    min_period_ticks: min_periods[m],
                    last_edge_tick: st.last_rise - r.start_tick,
                    merged_pulses: st.merged_pulses,
                }
            })
            .collect(),
    }
}

fn print_table(out: &mut impl Write, s: &RunSummary) -> anyhow::Result<()> {
    let opt = |v: Option<i64>| v.map_or("-".to_string(), |v| v.to_string());
    writeln!(out, "policy          {}", s.policy)?;
    writeln!(out, "clock           {} Hz", s.clock_hz)?;
    writeln!(out, "fifo depth      {}", s.fifo_depth)?;
    writeln!(
        out,
        "calculator      a period every {} cycles, each ready {} cycles after its start",
        s.interval_cycles, s.latency_cycles
    )?;
    writeln!(out, "axes            {}", s.axes.len())?;
    writeln!(
        out,
        "start           tick {} (skew {} ticks)",
        s.start_tick, s.start_skew_ticks
    )?;
    writeln!(out, "end             tick {}", s.end_tick)?;
    writeln!(out, "edges           {}", s.edges)?;
    writeln!(out, "underruns       {}", s.underruns)?;
    writeln!(out, "max late        {} ticks", s.max_late_ticks)?;
    writeln!(out, "min slack       {} ticks", opt(s.min_slack_ticks))?;
    writeln!(
        out,
        "utilization     {:.2} %",
        100.0 * s.calculator_utilization
    )?;
    writeln!(
        out,
        "peak load       {:.3} (Σ t_calc / Δt_min per axis)",
        s.peak_load
    )?;
    writeln!(out, "eq. (12) k      {}", s.k_eq12)?;
    writeln!(out)?;
    writeln!(
        out,
        "{:>4}  {:<16} {:>9} {:>10} {:>9} {:>10} {:>10} {:>14}",
        "axis", "name", "steps", "min period", "underruns", "late", "min slack", "last edge"
    )?;
    for a in &s.axes {
        writeln!(
            out,
            "{:>4}  {:<16} {:>9} {:>10} {:>9} {:>10} {:>10} {:>14}",
            a.index,
            a.name.as_deref().unwrap_or("-"),
            a.steps,
            a.min_period_ticks,
            a.underruns,
            a.late_ticks,
            opt(a.min_slack_ticks),
            a.last_edge_tick
        )?;
    }
    Ok(())
}

#[derive(Serialize, Debug)]
struct KMaxSummary {
    policy: &'static str,
    fifo_depth: usize,
    interval_cycles: u64,
    latency_cycles: u64,
    moves: usize,
    k_max: usize,
    /// k_max is the most axes tried; the real bound may be higher.
    capped: bool,
    k_eq12: u64,
    /// Most axes whose summed load Σ t_calc / Δt_min stays ≤ 1.
    k_load: usize,
    min_period_ticks: u64,
    /// Underruns of the first failing run (k_max + 1 axes).
    first_failure_underruns: Option<u64>,
}

fn print_k_max(
    args: &TdmArgs,
    cfg: &TdmConfig,
    moves: &[multistep_core::Profile],
) -> anyhow::Result<()> {
    let n = args.sweep_args.max_axes;
    if n == 0 || n > multistep_core::tdm::MAX_AXES {
        bail!("--max-axes must be 1 to {}", multistep_core::tdm::MAX_AXES);
    }
    let steps: Vec<u64> = moves.iter().map(|p| p.steps()).collect();
    check_edges(
        k_max_edges(&steps, n),
        "give the axes fewer steps or lower --max-axes",
    )?;
    let mut storage = (0..n)
        .map(|i| Axis::new(moves[i % moves.len()].clone(), cfg.clock_hz))
        .collect::<Result<Vec<_>, _>>()?;
    let km = k_max(cfg, moves, &mut storage)?;
    let s = KMaxSummary {
        policy: cfg.policy.name(),
        fifo_depth: cfg.fifo_depth,
        interval_cycles: cfg.latencies.interval(),
        latency_cycles: cfg.latencies.latency(),
        moves: moves.len(),
        k_max: km.k_max,
        capped: km.capped,
        k_eq12: km.k_eq12,
        k_load: km.k_load,
        min_period_ticks: km.min_period_ticks,
        first_failure_underruns: km.first_failure.map(|r| r.underruns),
    };
    let mut out = std::io::stdout().lock();
    match args.format {
        TdmFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?,
        TdmFormat::Table => {
            let cap = if s.capped { " (the most tried)" } else { "" };
            writeln!(
                out,
                "policy {}, fifo depth {}, t_calc {} cycles (latency {}), {} moves",
                s.policy, s.fifo_depth, s.interval_cycles, s.latency_cycles, s.moves
            )?;
            writeln!(out, "k_max (simulated)      {}{cap}", s.k_max)?;
            writeln!(
                out,
                "eq. (12) k             {} (Δt_min {} ticks)",
                s.k_eq12, s.min_period_ticks
            )?;
            writeln!(
                out,
                "load bound k           {} (Σ t_calc / Δt_min ≤ 1)",
                s.k_load
            )?;
            if let Some(u) = s.first_failure_underruns {
                writeln!(out, "with {} axes           {} underruns", s.k_max + 1, u)?;
            }
        }
    }
    Ok(())
}

/// Rejects flags that only make sense in another mode.
fn check_mode(args: &TdmArgs) -> anyhow::Result<()> {
    if (args.sweep || args.k_max) && args.edges_dir.is_some() {
        bail!("--edges-dir writes a single run's edges; it does not go with --sweep or --k-max");
    }
    if args.sweep && args.k_max {
        bail!("--sweep and --k-max are two different analyses; give one");
    }
    Ok(())
}
