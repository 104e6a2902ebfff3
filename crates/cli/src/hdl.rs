//! `multistep hdl`: emit the TDM IP core as Verilog, and report its resource use from
//! yosys against K independent single-axis cores.

use crate::output::ReportFormat;
use anyhow::Context;
use clap::{Args, Subcommand, ValueEnum};
use multistep_hdl::boards::Family;
use multistep_hdl::boards::{Board, BOARDS};
use multistep_hdl::build::BuildReport;
use multistep_hdl::pnr::{Nextpnr, Placed};
use multistep_hdl::report::{
    place, sweep, Baseline, Row, Target, PAPER_DSP_RATIO, PAPER_FF_RATIO, PAPER_LUT_RATIO,
};
use multistep_hdl::{tools, Arch, CoreParams, Design, HdlError};
use std::io::Write;
use std::path::PathBuf;

mod regs;

#[derive(Args, Debug)]
pub struct HdlArgs {
    #[command(subcommand)]
    cmd: HdlCmd,
}

#[derive(Subcommand, Debug)]
enum HdlCmd {
    /// Write the Verilog-2005 of the TDM core (ms_tdm_top) and of K independent cores (ms_indep_top)
    Emit(EmitArgs),
    /// Synthesize both with yosys for each axis count and compare LUT, FF, DSP and memory use
    Report(ReportArgs),
    /// Build a board's bitstream: emit, synthesize, place and route, pack (YoWASP flow)
    Build(BuildArgs),
    /// List the boards `hdl build` supports
    Boards,
    /// Where a board's logic goes: each module's own cells and instance count (yosys, no
    /// place and route), the per-axis cost and the shared part
    Modules(ModulesArgs),
    /// Print the link frames and register writes that load a move into a board and start it
    Regs(Box<regs::RegsArgs>),
}

#[derive(Args, Debug)]
struct BuildArgs {
    /// Board name (see `multistep hdl boards`)
    #[arg(long)]
    board: String,
    /// Axes (default: the board's largest that fits and meets timing)
    #[arg(long)]
    axes: Option<u32>,
    /// Output directory (created): rtl/, the pin file, logs, the bitstream, report.json
    #[arg(long)]
    out: PathBuf,
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    format: ReportFormat,
    /// A native nextpnr of the board's family (e.g. nextpnr-ecp5 from a toolchain bundle)
    /// instead of YoWASP's: it runs on every core, with --parallel-refine when it has it
    /// (the ULX3S-85F's 8-axis build needs this; YoWASP's runs on one core for hours)
    #[arg(long, value_name = "EXE")]
    nextpnr: Option<PathBuf>,
    /// Build the core with the per-step recurrence, its multiplier digit in bits (0..=15,
    /// 0: full width), instead of the board's choice
    #[arg(long, value_name = "BITS")]
    recurrence: Option<u32>,
}

#[derive(Args, Debug)]
struct ModulesArgs {
    /// Board name (see `multistep hdl boards`)
    #[arg(long)]
    board: String,
    /// Axes (default: the board's default build)
    #[arg(long)]
    axes: Option<u32>,
    /// Keep the Verilog and yosys's stat.json here (default: a temporary directory)
    #[arg(long)]
    out: Option<PathBuf>,
    /// The core with the per-step recurrence, its multiplier digit in bits (as `build`)
    #[arg(long, value_name = "BITS")]
    recurrence: Option<u32>,
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    format: ReportFormat,
}

/// Core parameters shared by both subcommands.
#[derive(Args, Debug)]
struct CoreArgs {
    /// Periods per axis FIFO (a power of two, at least 2)
    #[arg(long, default_value_t = 16)]
    fifo_depth: u32,
    /// Piece slots per axis (a power of two, at least 2; a trapezoid needs 3)
    #[arg(long, default_value_t = 4)]
    pieces: u32,
    /// Bits of a piece's step count
    #[arg(long, default_value_t = 20)]
    step_bits: u32,
    /// Bits of a piece's duration in ticks (and of a period)
    #[arg(long, default_value_t = 24)]
    tick_bits: u32,
    /// Bits of the square root's radicand (a multiple of 2 × --radix-bits, at most 128)
    #[arg(long, default_value_t = 128)]
    radicand_bits: u32,
    /// Bits of the divisor (the kernel's k has one more)
    #[arg(long, default_value_t = 68)]
    kernel_bits: u32,
    /// Result bits per cycle of the square root and divider (1 = radix 2, 2 = radix 4)
    #[arg(long, default_value_t = 2)]
    radix_bits: u32,
    /// Clock (Hz)
    #[arg(long, default_value_t = multistep_core::DEFAULT_CLOCK_HZ)]
    clock: f64,
    /// Highest step rate (steps/s)
    #[arg(long, default_value_t = 200_000.0)]
    max_rate: f64,
    /// Longest piece (s)
    #[arg(long, default_value_t = 0.3)]
    max_piece: f64,
    /// Find steps by the per-step recurrence too, with this multiplier digit (bits, 0 for
    /// full-width multiplies, up to 15); default: the closed form alone
    #[arg(long)]
    recurrence: Option<u32>,
}

impl CoreArgs {
    fn params(&self, axes: u32) -> CoreParams {
        CoreParams {
            axes,
            fifo_depth: self.fifo_depth,
            pieces: self.pieces,
            step_bits: self.step_bits,
            tick_bits: self.tick_bits,
            radicand_bits: self.radicand_bits,
            kernel_bits: self.kernel_bits,
            radix_bits: self.radix_bits,
            clock_hz: self.clock,
            max_rate: self.max_rate,
            max_piece_s: self.max_piece,
            recurrence: self.recurrence,
        }
    }
}

#[derive(Args, Debug)]
struct EmitArgs {
    /// Axes sharing the calculator (K)
    #[arg(long)]
    axes: u32,
    /// Output directory (created)
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    core: CoreArgs,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum TargetArg {
    Xilinx,
    Ice40,
    Ecp5,
}

#[derive(Args, Debug)]
struct ReportArgs {
    /// Axis counts, comma separated
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16")]
    axes: Vec<u32>,
    #[arg(long, value_enum, default_value_t = TargetArg::Xilinx)]
    target: TargetArg,
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    format: ReportFormat,
    /// Synthesize the whole K-core baseline instead of one core times K (slow)
    #[arg(long)]
    full_baseline: bool,
    /// Working directory for yosys (default: a fresh temporary directory)
    #[arg(long)]
    work: Option<PathBuf>,
    /// Also place and route (iCE40 UP5K, ECP5 LFE5U-25F) the TDM core and the K independent
    /// cores of each row with the YoWASP flow: a "fits / Fmax" column and placed LUTs (slow).
    /// When the K cores do not fit the device, one is placed and counted K times
    #[arg(long)]
    pnr: bool,
    #[command(flatten)]
    core: CoreArgs,
}

/// A row's place-and-route result, or why it has none.
#[derive(Debug)]
struct PlacedRow {
    axes: u32,
    tdm: Result<Placed, String>,
    independent: Result<Placed, String>,
    /// One single-axis core, placed when the K independent cores do not fit: they share
    /// nothing, so K of them use K times its logic (as synthesis's scaled baseline).
    one: Option<Result<Placed, String>>,
}

impl PlacedRow {
    fn fits(&self) -> String {
        fits_fmax(&self.tdm)
    }
    /// The independent cores' placed logic: all K placed, or K × one core's.
    fn independent_lut(&self) -> Option<u64> {
        match (&self.independent, &self.one) {
            (Ok(i), _) => Some(i.lut.used),
            (Err(_), Some(Ok(one))) => Some(one.lut.used * u64::from(self.axes)),
            _ => None,
        }
    }
    fn lut_ratio(&self) -> Option<f64> {
        match (&self.tdm, self.independent_lut()) {
            (Ok(t), Some(i)) if i > 0 => Some(t.lut.used as f64 / i as f64),
            _ => None,
        }
    }
}

/// "yes, 54.3 MHz" / "yes, 28.1 MHz < 50" / "no: ICESTORM_LC 7216 of 5280 (137 %)".
fn fits_fmax(r: &Result<Placed, String>) -> String {
    match r {
        Ok(p) if p.timing_met() => format!("yes, {:.1} MHz", p.fmax_mhz),
        Ok(p) => format!("yes, {:.1} MHz < {}", p.fmax_mhz, p.constraint_mhz),
        Err(e) => format!("no: {e}"),
    }
}

fn place_rows(
    base: &CoreParams,
    rows: &[Row],
    family: Family,
    work: &std::path::Path,
) -> anyhow::Result<Vec<PlacedRow>> {
    let one =
        |p: &CoreParams, arch: Arch, dir: PathBuf| -> anyhow::Result<Result<Placed, String>> {
            let d = Design::for_family(p, arch, family)?;
            Ok(match place(&d, family, &dir) {
                Ok(placed) => Ok(placed),
                Err(HdlError::DoesNotFit(m)) => Err(m),
                Err(e) => return Err(e.into()),
            })
        };
    rows.iter()
        .map(|r| {
            let p = CoreParams {
                axes: r.axes,
                ..base.clone()
            };
            // K independent cores with more multipliers or block RAMs than the device
            // has are not placed (their synthesis alone takes minutes at K = 32)
            let independent = match multistep_hdl::report::blocks_over(family, &r.independent) {
                Some(why) => Err(why),
                None => one(
                    &p,
                    Arch::Independent,
                    work.join(format!("pnr-indep-{}", r.axes)),
                )?,
            };
            let single = CoreParams {
                axes: 1,
                ..base.clone()
            };
            let one_core = match &independent {
                Err(_) if r.axes > 1 => {
                    Some(one(&single, Arch::Independent, work.join("pnr-indep-1"))?)
                }
                _ => None,
            };
            Ok(PlacedRow {
                axes: r.axes,
                tdm: one(&p, Arch::Tdm, work.join(format!("pnr-tdm-{}", r.axes)))?,
                independent,
                one: one_core,
            })
        })
        .collect()
}

pub fn run(a: &HdlArgs) -> anyhow::Result<()> {
    match &a.cmd {
        HdlCmd::Emit(e) => emit(e),
        HdlCmd::Report(r) => report(r),
        HdlCmd::Build(b) => build(b),
        HdlCmd::Boards => boards(),
        HdlCmd::Modules(m) => modules(m),
        HdlCmd::Regs(r) => regs::run(r),
    }
}

fn boards() -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "{:<12} {:<18} {:>9} {:>9} {:>5}  description",
        "board", "device", "osc MHz", "core MHz", "axes"
    )?;
    for b in &BOARDS {
        writeln!(
            out,
            "{:<12} {:<18} {:>9} {:>9} {:>5}  {}",
            b.name,
            b.device,
            b.osc_hz / 1e6,
            b.clock_hz() / 1e6,
            format!("{}..{}", 1, b.max_axes),
            b.description
        )?;
    }
    Ok(())
}

/// The board `name`, with the per-step recurrence's digit if one is asked for.
fn board_with(name: &str, recurrence: Option<u32>) -> anyhow::Result<Board> {
    let mut board = *Board::by_name(name)?;
    if recurrence.is_some() {
        board.core.recurrence = recurrence;
    }
    Ok(board)
}

fn modules(a: &ModulesArgs) -> anyhow::Result<()> {
    let board = &board_with(&a.board, a.recurrence)?;
    let axes = a.axes.unwrap_or(board.default_axes);
    board.params(axes)?;
    tools::find("yosys", "yosys")?;
    let tmp;
    let dir = match &a.out {
        Some(d) => d.clone(),
        None => {
            tmp = tempfile::tempdir().context("temporary directory")?;
            tmp.path().to_path_buf()
        }
    };
    eprintln!(
        "synthesizing each module of {} axes of {} alone with yosys (under a minute)…",
        axes, board.name
    );
    let t = multistep_hdl::modules::per_module(board, axes, &dir)?;
    let mut out = std::io::stdout().lock();
    match a.format {
        ReportFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&t)?)?,
        ReportFormat::Table => write_modules_table(&mut out, &t)?,
    }
    Ok(())
}

fn write_modules_table(
    out: &mut impl Write,
    t: &multistep_hdl::modules::ModuleTable,
) -> std::io::Result<()> {
    let unit = match t.target {
        Target::Ice40 => "SB_LUT4",
        _ => "LUT4-eq",
    };
    writeln!(
        out,
        "{} with {} axes, yosys, each module alone ({unit}: own cells, submodules left out)",
        t.board, t.axes
    )?;
    writeln!(
        out,
        "{:<16} {:>5} {:>8} {:>6} {:>7} {:>5} {:>9} {:>8} {:>7}",
        "module", "inst", "LUT each", "FF", "LUTRAM", "BRAM", "LUT total", "FF total", "DSP"
    )?;
    let line = |out: &mut dyn Write,
                name: &str,
                n: String,
                e: multistep_hdl::report::Resources,
                tot: multistep_hdl::report::Resources| {
        writeln!(
            out,
            "{:<16} {:>5} {:>8} {:>6} {:>7} {:>5} {:>9} {:>8} {:>7}",
            name, n, e.lut, e.ff, e.lutram, e.bram, tot.lut, tot.ff, tot.dsp
        )
    };
    for r in &t.rows {
        line(out, &r.module, r.instances.to_string(), r.each, r.total)?;
    }
    let total = t.total();
    line(out, "whole board", String::new(), total, total)?;
    if t.axes > 1 {
        let a = t.per_axis();
        line(
            out,
            "one axis",
            String::new(),
            a,
            a.times(u64::from(t.axes)),
        )?;
    }
    Ok(())
}

fn build(a: &BuildArgs) -> anyhow::Result<()> {
    let board = &board_with(&a.board, a.recurrence)?;
    let axes = a.axes.unwrap_or(board.default_axes);
    let nextpnr = a.nextpnr.clone().map_or(Nextpnr::YoWasp, Nextpnr::Native);
    let r = multistep_hdl::build::build_with(board, axes, &a.out, nextpnr)?;
    let mut out = std::io::stdout().lock();
    match a.format {
        ReportFormat::Json => writeln!(out, "{}", build_json(&r))?,
        ReportFormat::Table => write_build_table(&mut out, &r)?,
    }
    Ok(())
}

/// The build report as JSON: board, device, axes, clock, timing, resources, bitstream.
fn build_json(r: &BuildReport) -> serde_json::Value {
    serde_json::json!({
        "board": r.board,
        "device": r.device,
        "axes": r.axes,
        "clock_hz": r.clock_hz,
        "fmax_mhz": r.fmax_mhz,
        "timing_met": r.timing_met,
        "lut": r.lut,
        "ff": r.ff,
        "dsp": r.dsp,
        "bram": r.bram,
        "bitstream": r.bitstream,
        "axes_at_100k_steps_per_s": r.axes_at_100k_steps_per_s,
    })
}

fn write_build_table(out: &mut impl Write, r: &BuildReport) -> std::io::Result<()> {
    let pct = |u: u64, a: u64| {
        if a == 0 {
            0.0
        } else {
            100.0 * u as f64 / a as f64
        }
    };
    writeln!(out, "board      {} ({})", r.board, r.device)?;
    writeln!(out, "axes       {}", r.axes)?;
    writeln!(
        out,
        "clock      {} MHz, Fmax {:.2} MHz, timing {}",
        r.clock_hz / 1e6,
        r.fmax_mhz,
        if r.timing_met { "met" } else { "NOT met" }
    )?;
    writeln!(
        out,
        "LUT        {} of {} ({:.0} %)",
        r.lut,
        r.lut_available,
        pct(r.lut, r.lut_available)
    )?;
    writeln!(out, "FF         {}", r.ff)?;
    writeln!(out, "DSP        {} of {}", r.dsp, r.dsp_available)?;
    writeln!(out, "BRAM       {} of {}", r.bram, r.bram_available)?;
    writeln!(
        out,
        "100 k/s    {} axes on one calculator",
        r.axes_at_100k_steps_per_s
    )?;
    writeln!(out, "bitstream  {}", r.bitstream.display())
}

fn emit(a: &EmitArgs) -> anyhow::Result<()> {
    let p = a.core.params(a.axes);
    // both designs are checked before anything is written
    let designs = [
        Design::new(&p, Arch::Tdm)?,
        Design::new(&p, Arch::Independent)?,
    ];
    let mut out = std::io::stdout().lock();
    for d in &designs {
        for path in d.write(&a.out)? {
            writeln!(out, "{}", path.display())?;
        }
    }
    Ok(())
}

fn report(a: &ReportArgs) -> anyhow::Result<()> {
    if a.axes.is_empty() {
        anyhow::bail!("--axes needs at least one axis count");
    }
    for &k in &a.axes {
        a.core.params(k).widths()?;
    }
    let target = match a.target {
        TargetArg::Xilinx => Target::Xilinx,
        TargetArg::Ice40 => Target::Ice40,
        TargetArg::Ecp5 => Target::Ecp5,
    };
    let baseline = if a.full_baseline {
        Baseline::Full
    } else {
        Baseline::Scaled
    };
    let version = tools::yosys_version()?;
    let tmp;
    let work = match &a.work {
        Some(w) => w.clone(),
        None => {
            tmp = std::env::temp_dir().join(format!("multistep-hdl-{}", std::process::id()));
            tmp
        }
    };
    let family = match target {
        Target::Ice40 => Some(Family::Ice40),
        Target::Ecp5 => Some(Family::Ecp5),
        Target::Xilinx => None,
    };
    if a.pnr && family.is_none() {
        anyhow::bail!(
            "--pnr places on iCE40 or ECP5 only (no open place and route for Xilinx 7-series)"
        );
    }
    let rows = sweep(&a.core.params(1), &a.axes, target, baseline, &work).context("synthesis")?;
    let placed = match family.filter(|_| a.pnr) {
        Some(f) => Some(place_rows(&a.core.params(1), &rows, f, &work).context("place and route")?),
        None => None,
    };
    if a.work.is_none() {
        let _ = std::fs::remove_dir_all(&work);
    }
    let mut out = std::io::stdout().lock();
    match a.format {
        ReportFormat::Json => {
            let v: Vec<serde_json::Value> = rows
                .iter()
                .enumerate()
                .map(|(i, r)| {
                    let mut v = row_json(r, &version, target, baseline);
                    if let Some(p) = placed.as_ref().map(|p| &p[i]) {
                        v["placed"] = serde_json::json!({
                            "fits_fmax": p.fits(),
                            "tdm": p.tdm.as_ref().ok(),
                            "independent": p.independent.as_ref().ok(),
                            "one_independent_core": p.one.as_ref().and_then(|o| o.as_ref().ok()),
                            "independent_lut": p.independent_lut(),
                            "lut_ratio": p.lut_ratio(),
                        });
                    }
                    v
                })
                .collect();
            writeln!(out, "{}", serde_json::to_string_pretty(&v)?)?;
        }
        ReportFormat::Table => {
            write_table(&mut out, &rows, &version, target, baseline)?;
            if let Some(p) = &placed {
                write_placed(&mut out, &rows, p)?;
            }
        }
    }
    Ok(())
}

fn write_placed(out: &mut impl Write, rows: &[Row], placed: &[PlacedRow]) -> std::io::Result<()> {
    writeln!(
        out,
        "place and route (YoWASP nextpnr, the core behind a 4-pin shift-register bus):"
    )?;
    writeln!(
        out,
        "{:>4} | {:<40} | {:>8} | {:<40} | {:>8} | {:>9}",
        "K", "TDM fits / Fmax", "TDM LUT", "independent fits / Fmax", "ind. LUT", "LUT ratio"
    )?;
    for (r, p) in rows.iter().zip(placed) {
        let lut = |x: &Result<Placed, String>| {
            x.as_ref()
                .map_or("-".to_string(), |p| p.lut.used.to_string())
        };
        let ind_lut = match (&p.independent, &p.one) {
            (Err(_), Some(Ok(one))) => format!("{} x {}", r.axes, one.lut.used),
            _ => lut(&p.independent),
        };
        writeln!(
            out,
            "{:>4} | {:<40} | {:>8} | {:<40} | {:>8} | {:>9}",
            r.axes,
            p.fits(),
            lut(&p.tdm),
            fits_fmax(&p.independent),
            ind_lut,
            p.lut_ratio().map_or("-".to_string(), |x| format!("{x:.3}"))
        )?;
    }
    if let Some(Some(Ok(one))) = placed.iter().map(|p| &p.one).find(|o| o.is_some()) {
        writeln!(
            out,
            "(K x N: the K cores do not fit; one single-axis core placed alone: {}, {} LUT)",
            fits_fmax(&Ok(one.clone())),
            one.lut.used
        )?;
    }
    Ok(())
}

fn row_json(r: &Row, version: &str, target: Target, baseline: Baseline) -> serde_json::Value {
    serde_json::json!({
        "axes": r.axes,
        "tdm": r.tdm,
        "independent": r.independent,
        "ratio": { "lut": finite(r.lut_ratio()), "ff": finite(r.ff_ratio()), "dsp": finite(r.dsp_ratio()) },
        "paper_ratio": { "lut": PAPER_LUT_RATIO, "ff": PAPER_FF_RATIO, "dsp": PAPER_DSP_RATIO },
        "target": target,
        "baseline": baseline,
        "yosys": version,
    })
}

/// JSON has no NaN: a ratio over zero cells is null.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

fn write_table(
    out: &mut impl Write,
    rows: &[Row],
    version: &str,
    target: Target,
    baseline: Baseline,
) -> std::io::Result<()> {
    let base = match baseline {
        Baseline::Scaled => "K x one synthesized single-axis core",
        Baseline::Full => "K single-axis cores synthesized together",
    };
    writeln!(out, "{version}; target {target:?}; independent = {base}")?;
    writeln!(
        out,
        "{:>4} | {:>6} {:>6} {:>4} {:>6} {:>4} | {:>6} {:>6} {:>4} {:>6} {:>4} | {:>9} {:>8} {:>9}",
        "K",
        "LUT",
        "FF",
        "DSP",
        "LUTRAM",
        "BRAM",
        "LUT",
        "FF",
        "DSP",
        "LUTRAM",
        "BRAM",
        "LUT ratio",
        "FF ratio",
        "DSP ratio"
    )?;
    writeln!(
        out,
        "{:>4} | {:^32} | {:^32} |",
        "", "TDM core", "K independent cores"
    )?;
    for r in rows {
        let (t, i) = (r.tdm, r.independent);
        writeln!(
            out,
            "{:>4} | {:>6} {:>6} {:>4} {:>6} {:>4} | {:>6} {:>6} {:>4} {:>6} {:>4} | {:>9.3} {:>8.3} {:>9.3}",
            r.axes, t.lut, t.ff, t.dsp, t.lutram, t.bram, i.lut, i.ff, i.dsp, i.lutram, i.bram,
            r.lut_ratio(), r.ff_ratio(), r.dsp_ratio()
        )?;
    }
    writeln!(
        out,
        "paper (seed 000, K = 2, vendor tools): LUT ratio {PAPER_LUT_RATIO:.3}, FF ratio {PAPER_FF_RATIO:.3}, DSP ratio {PAPER_DSP_RATIO:.3}; absolute counts differ between tools, compare ratios"
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use multistep_hdl::report::Resources;

    fn row() -> Row {
        let one = Resources {
            lut: 1000,
            ff: 600,
            dsp: 3,
            lutram: 10,
            bram: 0,
        };
        Row {
            axes: 2,
            tdm: Resources {
                lut: 1200,
                ff: 660,
                ..one
            },
            independent: one.times(2),
        }
    }

    #[test]
    fn json_row_has_the_documented_fields() {
        let v = row_json(&row(), "Yosys 0.23", Target::Xilinx, Baseline::Scaled);
        assert_eq!(v["axes"], 2);
        assert_eq!(v["tdm"]["lut"], 1200);
        assert_eq!(v["independent"]["ff"], 1200);
        assert_eq!(v["independent"]["dsp"], 6);
        assert_eq!(v["ratio"]["lut"], 0.6);
        assert_eq!(v["ratio"]["dsp"], 0.5);
        assert_eq!(v["yosys"], "Yosys 0.23");
        assert!((v["paper_ratio"]["lut"].as_f64().unwrap() - 0.663).abs() < 1e-3);
    }

    #[test]
    fn table_shows_ratios_paper_and_version() {
        let mut out = Vec::new();
        write_table(
            &mut out,
            &[row()],
            "Yosys 0.23",
            Target::Xilinx,
            Baseline::Scaled,
        )
        .unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(text.starts_with("Yosys 0.23; target Xilinx"), "{text}");
        assert!(
            text.contains("0.600") && text.contains("0.550") && text.contains("0.500"),
            "{text}"
        );
        assert!(
            text.contains("LUT ratio 0.663, FF ratio 0.713, DSP ratio 0.833"),
            "{text}"
        );
    }

    fn placed(lut: u64) -> Placed {
        let u = |used| multistep_hdl::pnr::Use {
            used,
            available: 24288,
        };
        Placed {
            lut: u(lut),
            ff: 0,
            dsp: u(0),
            bram: u(0),
            fmax_mhz: 63.8,
            constraint_mhz: 50.0,
            bitstream: None,
        }
    }

    #[test]
    fn k_cores_that_do_not_fit_are_counted_as_k_times_one() {
        let mut p = PlacedRow {
            axes: 8,
            tdm: Ok(placed(5985)),
            independent: Err("DP16KD 72 of 56 (129 %)".into()),
            one: Some(Ok(placed(2842))),
        };
        assert_eq!(p.independent_lut(), Some(22736));
        assert!((p.lut_ratio().unwrap() - 5985.0 / 22736.0).abs() < 1e-12);
        let mut out = Vec::new();
        let rows = [Row { axes: 8, ..row() }];
        write_placed(&mut out, &rows, std::slice::from_ref(&p)).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert!(
            text.contains("8 x 2842") && text.contains("0.263"),
            "{text}"
        );
        assert!(text.contains("one single-axis core placed alone"), "{text}");
        // placed together, the K cores are the baseline; neither placed: no ratio
        p.independent = Ok(placed(20000));
        assert_eq!(p.independent_lut(), Some(20000));
        p.independent = Err("no".into());
        p.one = Some(Err("no".into()));
        assert_eq!((p.independent_lut(), p.lut_ratio()), (None, None));
    }
}
