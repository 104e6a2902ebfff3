//! `multistep plan`: a move's edges as CSV, or a summary after running the whole generator.

use crate::moveargs::MoveArgs;
use crate::output::Format;
use clap::Args;
use multistep_core::{EdgeGenerator, MoveName, PlanSummary, DEFAULT_CLOCK_HZ};
use std::io::Write;

/// Moves of more steps than this show the summary's progress (about a second of ramp steps).
const PROGRESS_STEPS: u64 = 10_000_000;
/// Steps per part of a summary with progress: a part's overhead is lost among them.
const PROGRESS_PART: u64 = 1 << 20;

#[derive(Args, Debug)]
pub struct PlanArgs {
    #[command(flatten)]
    pub mv: MoveArgs,
    /// Clock frequency (Hz) that edges are counted in
    #[arg(long, value_name = "HZ", default_value_t = DEFAULT_CLOCK_HZ)]
    pub clock: f64,
    /// Output: table (summary), csv (every edge) or json (summary)
    #[arg(long, value_enum, default_value_t = Format::Table)]
    pub format: Format,
    #[command(flatten)]
    pub track: crate::track::TrackArgs,
}

pub fn run(args: &PlanArgs) -> anyhow::Result<()> {
    if args.track.track.is_some() {
        return crate::track::run(&args.track, &args.mv, args.clock, args.format);
    }
    let spec = args.mv.spec();
    let mv = spec.resolve()?;
    // on the clock: limits-mode trapezoids on whole ticks, as the integer datapath and the FPGA
    let profile = spec.plan_on_clock(args.clock)?;
    let mut gen = EdgeGenerator::new(profile, args.clock)?;
    let stdout = std::io::stdout();
    if let Format::Csv = args.format {
        let mut w = std::io::BufWriter::with_capacity(1 << 16, stdout.lock());
        writeln!(w, "step,edge_tick,period_ticks")?;
        let mut last = 0;
        let mut buf = itoa_buf();
        for (k, e) in (&mut gen).enumerate() {
            write_row(&mut w, &mut buf, k as u64 + 1, e, e - last)?;
            last = e;
        }
        w.flush()?;
        return Ok(());
    }
    // a summary of many ramp steps takes seconds or more (cruise runs are O(1)): in parts,
    // with a bar on stderr when it is a terminal (hidden otherwise)
    let bar = (gen.remaining() > PROGRESS_STEPS).then(|| {
        let b = multistep_sim::progress::progress(gen.remaining());
        b.set_message("summarising");
        b
    });
    let part = if bar.is_some() {
        PROGRESS_PART
    } else {
        u64::MAX
    };
    let s = PlanSummary::run_in_parts(MoveName::of(&mv), &mut gen, part, |done| {
        if let Some(b) = &bar {
            b.set_position(done)
        }
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let mut out = stdout.lock();
    match args.format {
        Format::Json => writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?,
        _ => {
            writeln!(out, "move          {}", s.mode)?;
            writeln!(out, "steps         {}", s.steps)?;
            writeln!(out, "clock         {} Hz", s.clock_hz)?;
            writeln!(out, "duration      {:.9} s", s.duration_s)?;
            writeln!(out, "last edge     {} ticks", s.last_edge_tick)?;
            writeln!(out, "peak speed    {:.3} steps/s", s.peak_speed_steps_per_s)?;
            writeln!(
                out,
                "peak accel    {:.3} steps/s²",
                s.peak_accel_steps_per_s2
            )?;
            writeln!(
                out,
                "period        {} .. {} ticks",
                s.min_period_ticks, s.max_period_ticks
            )?;
        }
    }
    Ok(())
}

pub(crate) fn itoa_buf() -> Vec<u8> {
    Vec::with_capacity(64)
}

/// One CSV row, formatted without going through `fmt` machinery per field.
pub(crate) fn write_row(
    w: &mut impl Write,
    buf: &mut Vec<u8>,
    step: u64,
    edge: u64,
    period: u64,
) -> std::io::Result<()> {
    buf.clear();
    push_u64(buf, step);
    buf.push(b',');
    push_u64(buf, edge);
    buf.push(b',');
    push_u64(buf, period);
    buf.push(b'\n');
    w.write_all(buf)
}

fn push_u64(buf: &mut Vec<u8>, mut x: u64) {
    let mut tmp = [0u8; 20];
    let mut i = tmp.len();
    loop {
        i -= 1;
        tmp[i] = b'0' + (x % 10) as u8;
        x /= 10;
        if x == 0 {
            break;
        }
    }
    buf.extend_from_slice(&tmp[i..]);
}
