//! `multistep bench`: every implementation on the same moves (multistep-bench library).

use crate::output::ReportFormat;
use anyhow::{anyhow, bail, Result};
use clap::Args;
use multistep_bench::compare::{drive, drive_family, Fold, Skip};
use multistep_bench::icount;
use multistep_bench::{run, run_families, Case, FamilyCase, Impl, Options, FAMILY_MOVES, MOVES};
use std::io::Write;

#[path = "bench_planning.rs"]
mod planning;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Time each case briefly (the whole run takes a few seconds)
    #[arg(long)]
    pub quick: bool,
    /// Output format
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    pub format: ReportFormat,
    /// Fractional bits of the seed 000 replica's fixed-point registers
    #[arg(long, value_name = "BITS", default_value_t = 32, value_parser = clap::value_parser!(u32).range(8..=56))]
    pub seed000_bits: u32,
    /// Also count instructions per edge with valgrind's callgrind (each case runs twice
    /// more under valgrind: whole run minus planning only)
    #[arg(long)]
    pub instructions: bool,
    /// Run one move by one implementation and exit (what --instructions counts)
    #[arg(long, value_name = "MOVE", hide = true)]
    pub run_one: Option<String>,
    #[arg(
        long = "impl",
        value_name = "IMPL",
        hide = true,
        default_value = "multistep-float"
    )]
    pub imp: String,
    /// With --run-one: plan and stop (the fixed cost subtracted from a count)
    #[arg(long, hide = true)]
    pub plan_only: bool,
    /// Plan one move against Ruckig instead (natively and through Python; with
    /// --instructions, counted by callgrind too)
    #[arg(long)]
    pub planning: bool,
    /// Python interpreter with the multistep and ruckig packages, for --planning
    #[arg(long, value_name = "PATH", default_value = "python3")]
    pub python: String,
    /// Plan one planning case --reps times and exit (what --planning --instructions counts)
    #[arg(long, value_name = "CASE", hide = true)]
    pub plan_one: Option<String>,
    #[arg(long, value_name = "N", hide = true, default_value_t = 1)]
    pub reps: u64,
}

fn options(a: &BenchArgs) -> Options {
    let mut opts = if a.quick {
        Options::quick()
    } else {
        Options::full()
    };
    opts.seed000_frac_bits = a.seed000_bits;
    opts
}

/// One (move, impl) run, edges folded into a number that is printed.
fn run_one(a: &BenchArgs, name: &str) -> Result<()> {
    let opts = options(a);
    let (mut fold, mut skip) = (Fold::default(), Skip);
    if let Some(m) = MOVES.iter().find(|m| m.name == name) {
        let imp = Impl::ALL
            .into_iter()
            .find(|i| i.name() == a.imp)
            .ok_or_else(|| anyhow!("unknown implementation {}", a.imp))?;
        if a.plan_only {
            drive(imp, m, &opts, &mut skip);
        } else {
            drive(imp, m, &opts, &mut fold);
        }
    } else if let Some(m) = FAMILY_MOVES.iter().find(|m| m.name == name) {
        if a.plan_only {
            drive_family(m, &mut skip);
        } else {
            drive_family(m, &mut fold);
        }
    } else {
        bail!("unknown bench move {name}");
    }
    println!("{}", fold.0);
    Ok(())
}

/// Instructions per edge of `mv` by `imp`, by running this program under callgrind.
fn count(mv: &str, imp: &str, steps: u64, bits: u32) -> Result<Option<f64>> {
    let exe = std::env::current_exe()?;
    let bits = bits.to_string();
    let run = [
        "bench",
        "--run-one",
        mv,
        "--impl",
        imp,
        "--seed000-bits",
        &bits,
    ];
    let mut plan = run.to_vec();
    plan.push("--plan-only");
    Ok(icount::per_edge(&exe, &run, &plan, steps))
}

pub fn run_bench(a: &BenchArgs) -> Result<()> {
    if let Some(name) = &a.run_one {
        return run_one(a, name);
    }
    if let Some(name) = &a.plan_one {
        return planning::plan_one(name, a.reps);
    }
    if a.instructions && !icount::valgrind_present() {
        bail!("--instructions needs valgrind (apt-get install valgrind)");
    }
    if a.planning {
        let rows = planning::rows(&a.python, a.instructions, a.quick)?;
        let mut out = std::io::stdout().lock();
        match a.format {
            ReportFormat::Json => {
                serde_json::to_writer_pretty(&mut out, &serde_json::json!({ "planning": rows }))?;
                writeln!(out)?;
            }
            ReportFormat::Table => planning::table(&mut out, &rows)?,
        }
        return Ok(());
    }
    let opts = options(a);
    let mut cases = run(&MOVES, &opts);
    let mut families = run_families(&FAMILY_MOVES, &opts);
    if a.instructions {
        for c in &mut cases {
            c.instructions_per_edge = count(c.mv, c.imp, c.steps, a.seed000_bits)?;
        }
        for c in &mut families {
            c.instructions_per_edge = count(c.mv, c.imp, c.steps, a.seed000_bits)?;
        }
    }
    let mut out = std::io::stdout().lock();
    match a.format {
        ReportFormat::Json => {
            let v = serde_json::json!({ "cases": cases, "families": families });
            serde_json::to_writer_pretty(&mut out, &v)?;
            writeln!(out)?;
        }
        ReportFormat::Table => table(&mut out, &cases, &families)?,
    }
    Ok(())
}

fn instr(x: Option<f64>) -> String {
    x.map_or_else(|| "-".into(), |v| format!("{v:.1}"))
}

fn table(out: &mut impl Write, cases: &[Case], families: &[FamilyCase]) -> Result<()> {
    writeln!(
        out,
        "{:<18} {:<16} {:>9} {:>11} {:>9} {:>15} {:>12} {:>16}",
        "move",
        "impl",
        "steps",
        "edges/s",
        "instr/edge",
        "max |err| tick",
        "drift tick",
        "max period err %"
    )?;
    for c in cases {
        writeln!(
            out,
            "{:<18} {:<16} {:>9} {:>11.3e} {:>9} {:>15} {:>12} {:>16.4}",
            c.mv,
            c.imp,
            c.steps,
            c.edges_per_s,
            instr(c.instructions_per_edge),
            c.max_edge_error_ticks,
            c.drift_ticks,
            c.max_period_error_pct
        )?;
    }
    writeln!(out)?;
    writeln!(
        out,
        "{:<18} {:<16} {:>9} {:>11} {:>9} {:>15}",
        "family move", "impl", "steps", "edges/s", "instr/edge", "settled edges"
    )?;
    for c in families {
        writeln!(
            out,
            "{:<18} {:<16} {:>9} {:>11.3e} {:>9} {:>15}",
            c.mv,
            c.imp,
            c.steps,
            c.edges_per_s,
            instr(c.instructions_per_edge),
            c.settled_edges
        )?;
    }
    Ok(())
}
