//! `multistep plan --track RATE --duration S`: the edges of open-ended motion (a ramp from
//! the start speed to RATE within amax/jmax, then a cruise at exactly RATE), cut at S seconds.

use crate::moveargs::MoveArgs;
use crate::output::Format;
use crate::plan::{itoa_buf, write_row};
use anyhow::{bail, Context};
use clap::Args;
use multistep_core::track::TrackSegment;
use multistep_core::{EdgeGenerator, Rate, TrackRun};
use serde::Serialize;
use std::io::Write;

#[derive(Args, Debug, Default)]
pub struct TrackArgs {
    /// Track: ramp to RATE steps/s (decimal or NUM/DEN, exact) and cruise at it; uses
    /// --start-speed, --amax and --jmax
    #[arg(long, value_name = "RATE")]
    pub track: Option<String>,
    /// With --track: how many seconds of edges to print
    #[arg(long, value_name = "S", requires = "track")]
    pub duration: Option<f64>,
}

#[derive(Serialize, Debug)]
struct TrackSummary {
    rate_steps_per_s: f64,
    rate_exact: String,
    clock_hz: f64,
    duration_s: f64,
    steps: u64,
    ramp_steps: u64,
    /// Tick where the cruise's step 0 lies (an exact binary fraction; f64 shown).
    cruise_origin_tick: f64,
    last_edge_tick: u64,
    min_cruise_period_ticks: u64,
    max_cruise_period_ticks: u64,
}

/// Refuses the flags of a fixed move, which a tracking motion does not take.
fn check_flags(mv: &MoveArgs) -> anyhow::Result<()> {
    let fixed = [
        ("--steps", mv.steps.is_some()),
        ("--profile", mv.shape.profile.is_some()),
        ("--accel-time", mv.shape.params.accel_time.is_some()),
        ("--cruise-time", mv.shape.params.cruise_time.is_some()),
        ("--decel-time", mv.shape.params.decel_time.is_some()),
        ("--end-speed", mv.shape.params.end_speed.is_some()),
        ("--vmax", mv.shape.params.vmax.is_some()),
        ("--smax", mv.shape.params.smax.is_some()),
        ("--segment", !mv.segments.is_empty()),
    ];
    if let Some((name, _)) = fixed.iter().find(|(_, given)| *given) {
        bail!("--track runs until --duration and takes no {name}");
    }
    Ok(())
}

pub fn run(track: &TrackArgs, mv: &MoveArgs, clock: f64, format: Format) -> anyhow::Result<()> {
    check_flags(mv)?;
    let text = track.track.as_deref().unwrap_or_default();
    let rate = Rate::parse(text)?;
    let duration = track.duration.context("--track needs --duration S")?;
    let run = TrackRun {
        rate,
        duration,
        start_speed: mv.shape.params.start_speed.unwrap_or(0.0),
        amax: mv.shape.params.amax,
        jmax: mv.shape.params.jmax,
    };
    let (mut tr, end) = run.start::<EdgeGenerator>(clock)?;
    let stdout = std::io::stdout();
    if let Format::Csv = format {
        let mut w = std::io::BufWriter::with_capacity(1 << 16, stdout.lock());
        writeln!(w, "step,edge_tick,period_ticks")?;
        let (mut last, mut buf) = (0, itoa_buf());
        while let Some(e) = tr.next().filter(|&e| e <= end) {
            write_row(&mut w, &mut buf, tr.steps(), e, e - last)?;
            last = e;
        }
        return Ok(w.flush()?);
    }
    let (mut last, mut ramp_steps, mut origin, mut steps) = (0u64, 0u64, 0.0, 0u64);
    let (mut min_p, mut max_p) = (u64::MAX, 0u64);
    while let Some(e) = tr.next().filter(|&e| e <= end) {
        steps = tr.steps();
        match tr.segment() {
            TrackSegment::Cruise {
                origin_tick,
                frac_num,
                frac_bits,
                ..
            } => {
                origin = origin_tick as f64 + frac_num as f64 / (frac_bits as f64).exp2();
                if tr.steps() > ramp_steps + 1 {
                    min_p = min_p.min(e - last);
                    max_p = max_p.max(e - last);
                }
            }
            _ => ramp_steps = tr.steps(),
        }
        last = e;
    }
    let s = TrackSummary {
        rate_steps_per_s: rate.to_f64(),
        rate_exact: format!("{}/{}", rate.num(), rate.den()),
        clock_hz: clock,
        duration_s: duration,
        steps,
        ramp_steps,
        cruise_origin_tick: origin,
        last_edge_tick: last,
        min_cruise_period_ticks: if max_p == 0 { 0 } else { min_p },
        max_cruise_period_ticks: max_p,
    };
    let mut out = stdout.lock();
    if let Format::Json = format {
        writeln!(out, "{}", serde_json::to_string_pretty(&s)?)?;
        return Ok(());
    }
    writeln!(
        out,
        "track         {} steps/s ({} exactly)",
        s.rate_steps_per_s, s.rate_exact
    )?;
    writeln!(out, "clock         {} Hz", s.clock_hz)?;
    writeln!(out, "duration      {} s", s.duration_s)?;
    writeln!(
        out,
        "steps         {} ({} in the ramp)",
        s.steps, s.ramp_steps
    )?;
    writeln!(out, "cruise from   {:.6} ticks", s.cruise_origin_tick)?;
    writeln!(out, "last edge     {} ticks", s.last_edge_tick)?;
    writeln!(
        out,
        "cruise period {} .. {} ticks",
        s.min_cruise_period_ticks, s.max_cruise_period_ticks
    )?;
    Ok(())
}
