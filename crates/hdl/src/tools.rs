//! Runners for the external tools: Icarus Verilog (iverilog + vvp), Verilator (lint) and
//! yosys. A missing tool is an error naming the Debian package, never a silent skip.

use crate::simulator::Simulator;
use crate::testbench::{testbench, EDGE_FILE};
use crate::{Arch, AxisMove, Design, HdlError};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The path of `tool`, or [`HdlError::ToolMissing`].
pub fn find(tool: &'static str, package: &'static str) -> Result<PathBuf, HdlError> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .map(|dir| dir.join(tool))
        .find(|p| p.is_file())
        .ok_or(HdlError::ToolMissing { tool, package })
}

/// Runs `tool args…` in `dir`; a non-zero exit is [`HdlError::ToolFailed`] with its output.
pub fn run(
    tool: &'static str,
    package: &'static str,
    args: &[&str],
    dir: &Path,
) -> Result<Output, HdlError> {
    let exe = find(tool, package)?;
    let out = Command::new(exe)
        .args(args)
        .current_dir(dir)
        .output()
        .map_err(|e| HdlError::ToolFailed {
            tool,
            detail: e.to_string(),
        })?;
    if !out.status.success() {
        return Err(HdlError::ToolFailed {
            tool,
            detail: format!(
                "exit {}: {}{}",
                out.status,
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            ),
        });
    }
    Ok(out)
}

pub(crate) fn file_names_of(paths: &[PathBuf]) -> Vec<String> {
    paths
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect()
}

/// What one simulation produced.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimOutput {
    /// Edge ticks (STEP rises) of each axis, in order (tick 0 = the group's go).
    pub edges: Vec<Vec<u64>>,
    /// STEP falls of each axis.
    pub falls: Vec<Vec<u64>>,
    /// Axes whose pulse unit underran.
    pub underrun: u32,
    /// DIR levels at the end.
    pub dir: u32,
    /// Per calculator (one for the TDM core, one per axis for independent cores): the
    /// cycles of each select (a period's start) and of each FIFO write.
    pub sels: Vec<Vec<u64>>,
    pub pushes: Vec<Vec<u64>>,
    /// Cycles of the start write and of the group's go.
    pub start_cycle: u64,
    pub go_cycle: u64,
}

/// Writes `files` (name, text) into `dir` (made if missing); returns the names of the
/// Verilog sources among them.
pub(crate) fn write_files(dir: &Path, files: &[(String, String)]) -> Result<Vec<String>, HdlError> {
    std::fs::create_dir_all(dir).map_err(|e| HdlError::io(dir, e))?;
    let mut sources = Vec::new();
    for (name, text) in files {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| HdlError::io(&p, e))?;
        if name.ends_with(".v") {
            sources.push(name.clone());
        }
    }
    Ok(sources)
}

/// Writes `files` (name, text) into `dir`, compiles them with Icarus Verilog (top
/// module `tb`), runs the simulation there with `plusargs` and returns the text of the
/// file `log` it wrote.
pub(crate) fn icarus(
    dir: &Path,
    files: &[(String, String)],
    log: &str,
    plusargs: &[String],
) -> Result<String, HdlError> {
    let sources = write_files(dir, files)?;
    let mut args = vec!["-g2005".to_string(), "-o".into(), "sim.vvp".into()];
    args.extend(["-s".into(), "tb".into()]);
    args.extend(sources);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    run("iverilog", "iverilog", &args, dir)?;
    let mut vvp = vec!["-n".to_string(), "sim.vvp".into()];
    vvp.extend(plusargs.iter().map(|a| format!("+{a}")));
    let vvp: Vec<&str> = vvp.iter().map(String::as_str).collect();
    run("vvp", "iverilog", &vvp, dir)?;
    let path = dir.join(log);
    std::fs::read_to_string(&path).map_err(|e| HdlError::io(&path, e))
}

/// Simulates `moves` on the design in Icarus Verilog inside `dir`.
pub fn simulate(
    design: &Design,
    moves: &[AxisMove],
    dir: &Path,
    timeout: u64,
) -> Result<SimOutput, HdlError> {
    simulate_in(Simulator::Icarus, design, moves, dir, timeout)
}

/// [`simulate`] in `sim`. The testbench holds the moves, so Verilator compiles one per
/// set of moves (seconds): it pays off on long runs only.
pub fn simulate_in(
    sim: Simulator,
    design: &Design,
    moves: &[AxisMove],
    dir: &Path,
    timeout: u64,
) -> Result<SimOutput, HdlError> {
    let mut files = design.files.clone();
    files.push(("tb.v".into(), testbench(design, moves, timeout)?));
    let text = sim.run(dir, &files, EDGE_FILE, &[])?;
    let calcs = match design.arch {
        Arch::Tdm => 1,
        Arch::Independent => design.params.axes as usize,
    };
    parse_edges(&text, design.params.axes as usize, calcs)
}

fn parse_edges(text: &str, axes: usize, calcs: usize) -> Result<SimOutput, HdlError> {
    let mut out = SimOutput {
        edges: vec![Vec::new(); axes],
        falls: vec![Vec::new(); axes],
        underrun: 0,
        dir: 0,
        sels: vec![Vec::new(); calcs],
        pushes: vec![Vec::new(); calcs],
        start_cycle: 0,
        go_cycle: 0,
    };
    let bad = |line: &str| HdlError::Sim(format!("unexpected testbench line {line:?}"));
    for line in text.lines() {
        let mut it = line.split_whitespace();
        match (it.next(), it.next()) {
            (Some("timeout"), _) => return Err(HdlError::Sim("testbench timed out".into())),
            (Some("underrun"), Some(v)) => out.underrun = v.parse().map_err(|_| bad(line))?,
            (Some("dir"), Some(v)) => out.dir = v.parse().map_err(|_| bad(line))?,
            (Some("start"), Some(v)) => out.start_cycle = v.parse().map_err(|_| bad(line))?,
            (Some("go"), Some(v)) => out.go_cycle = v.parse().map_err(|_| bad(line))?,
            (Some(kind @ ("rise" | "fall" | "sel" | "push")), Some(t)) => {
                let t: u64 = t.parse().map_err(|_| bad(line))?;
                let a: usize = it
                    .next()
                    .and_then(|a| a.parse().ok())
                    .ok_or_else(|| bad(line))?;
                let list = match kind {
                    "rise" => &mut out.edges,
                    "fall" => &mut out.falls,
                    "sel" => &mut out.sels,
                    _ => &mut out.pushes,
                };
                list.get_mut(a).ok_or_else(|| bad(line))?.push(t);
            }
            _ => return Err(bad(line)),
        }
    }
    Ok(out)
}

/// `verilator --lint-only -Wall` on the design; any warning is an error.
pub fn lint(design: &Design, dir: &Path) -> Result<(), HdlError> {
    let paths = design.write(dir)?;
    let mut args = vec![
        "--lint-only".to_string(),
        "-Wall".into(),
        "--top-module".into(),
        design.arch.top().into(),
    ];
    args.extend(file_names_of(&paths));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = run("verilator", "verilator", &args, dir)?;
    let text = String::from_utf8_lossy(&out.stderr);
    if text.contains("%Warning") || text.contains("%Error") {
        return Err(HdlError::ToolFailed {
            tool: "verilator",
            detail: text.into_owned(),
        });
    }
    Ok(())
}

/// `yosys -V`, e.g. "Yosys 0.23 (git sha1 7ce5011c24b)".
pub fn yosys_version() -> Result<String, HdlError> {
    let out = run("yosys", "yosys", &["-V"], Path::new("."))?;
    Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
}
