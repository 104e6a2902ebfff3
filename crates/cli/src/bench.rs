//! `multistep bench`: every implementation on the same moves (multistep-bench library).

use crate::output::Format;
use anyhow::{bail, Result};
use clap::Args;
use multistep_bench::{run, Case, Options, MOVES};
use std::io::Write;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Time each case briefly (the whole run takes a few seconds)
    #[arg(long)]
    pub quick: bool,
    /// Output format: table or json
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
    /// Fractional bits of the seed 000 replica's fixed-point registers
    #[arg(long, value_name = "BITS", default_value_t = 32, value_parser = clap::value_parser!(u32).range(8..=56))]
    pub seed000_bits: u32,
}

pub fn run_bench(a: &BenchArgs) -> Result<()> {
    if a.format == Format::Csv {
        bail!("bench prints --format table or json");
    }
    let mut opts = if a.quick {
        Options::quick()
    } else {
        Options::full()
    };
    opts.seed000_frac_bits = a.seed000_bits;
    let cases = run(&MOVES, &opts);
    let mut out = std::io::stdout().lock();
    match a.format {
        Format::Json => {
            serde_json::to_writer_pretty(&mut out, &serde_json::json!({ "cases": cases }))?;
            writeln!(out)?;
        }
        // csv was refused above
        Format::Table | Format::Csv => table(&mut out, &cases)?,
    }
    Ok(())
}

fn table(out: &mut impl Write, cases: &[Case]) -> Result<()> {
    writeln!(
        out,
        "{:<16} {:<16} {:>9} {:>14} {:>15} {:>12} {:>16}",
        "move", "impl", "steps", "edges/s", "max |err| tick", "drift tick", "max period err %"
    )?;
    for c in cases {
        writeln!(
            out,
            "{:<16} {:<16} {:>9} {:>14.3e} {:>15} {:>12} {:>16.4}",
            c.mv,
            c.imp,
            c.steps,
            c.edges_per_s,
            c.max_edge_error_ticks,
            c.drift_ticks,
            c.max_period_error_pct
        )?;
    }
    Ok(())
}
