//! Which simulator runs a generated testbench. Icarus Verilog starts at once but runs the
//! 85F board at some 5 500 clocks per second; Verilator 5 (`--binary --timing`) takes some
//! 15 s to compile it and then runs it forty times faster (docs/BENCHMARKS.md). Verilator
//! binaries are cached by a hash of every source and flag, so a board is compiled once
//! per machine. The testbenches are race-free, so both give the same log (a test checks).

use crate::tools::{find, icarus, run, write_files};
use crate::verilator::{default_cache_dir, fnv1a, lock_key};
use crate::HdlError;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// A Verilog simulator for the testbenches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Simulator {
    /// Icarus Verilog (`iverilog` + `vvp`).
    Icarus,
    /// Verilator 5.006 or later, compiled to a binary with its timing support.
    #[default]
    Verilator,
}

/// The environment variable that picks the simulator: `icarus` or `verilator`.
pub const SIM_ENV: &str = "MULTISTEP_SIM";

impl Simulator {
    /// The simulator `MULTISTEP_SIM` names, else Verilator.
    pub fn from_env() -> Result<Simulator, HdlError> {
        match std::env::var(SIM_ENV).as_deref() {
            Err(_) | Ok("") | Ok("verilator") => Ok(Simulator::Verilator),
            Ok("icarus") => Ok(Simulator::Icarus),
            Ok(other) => Err(HdlError::Param(format!(
                "{SIM_ENV}={other:?}: the simulators are `icarus` and `verilator`"
            ))),
        }
    }

    /// Writes `files` (name, text) into `dir`, runs the testbench (top module `tb`) there
    /// with `plusargs` (`name=value`, read by `$value$plusargs`) and returns the text of
    /// the file `log` it wrote.
    pub fn run(
        self,
        dir: &Path,
        files: &[(String, String)],
        log: &str,
        plusargs: &[String],
    ) -> Result<String, HdlError> {
        match self {
            Simulator::Icarus => icarus(dir, files, log, plusargs),
            Simulator::Verilator => verilated(dir, files, log, plusargs),
        }
    }
}

/// Verilator's options: the testbench's delays need `--timing`; the model's C++ is built
/// at -O1, which compiles in half the time of -O2 and runs as fast here.
const FLAGS: [&str; 17] = [
    "--binary",
    "--timing",
    "--timescale",
    "1ns/1ps",
    "-O3",
    "--x-assign",
    "fast",
    "--x-initial",
    "fast",
    "-Wno-fatal",
    "-Wno-lint",
    "-Wno-style",
    "--top-module",
    "tb",
    "-j",
    "2",
    "-MAKEFLAGS",
];
const MAKEFLAGS: &str = "OPT_FAST=-O1 OPT_SLOW=-O0 OPT_GLOBAL=-O1";

/// The oldest Verilator whose `--binary --timing` runs the testbenches.
const MIN_VERSION: (u32, u32) = (5, 6);

/// One build at a time in this process (tests start several simulations at once).
static BUILD_LOCK: Mutex<()> = Mutex::new(());

fn verilated(
    dir: &Path,
    files: &[(String, String)],
    log: &str,
    plusargs: &[String],
) -> Result<String, HdlError> {
    write_files(dir, files)?;
    let exe = build(files)?;
    let out = std::process::Command::new(&exe)
        .args(plusargs.iter().map(|a| format!("+{a}")))
        .current_dir(dir)
        .output()
        .map_err(|e| HdlError::ToolFailed {
            tool: "verilator",
            detail: format!("{}: {e}", exe.display()),
        })?;
    if !out.status.success() {
        return Err(HdlError::ToolFailed {
            tool: "verilator",
            detail: format!(
                "{} exited with {}: {}",
                exe.display(),
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ),
        });
    }
    let path = dir.join(log);
    std::fs::read_to_string(&path).map_err(|e| HdlError::io(&path, e))
}

/// The testbench binary of the Verilog in `files`, from the cache or built into it.
fn build(files: &[(String, String)]) -> Result<PathBuf, HdlError> {
    let version = verilator_version()?;
    let sources: Vec<&(String, String)> = files.iter().filter(|f| f.0.ends_with(".v")).collect();
    let mut parts: Vec<&[u8]> = vec![version.as_bytes(), MAKEFLAGS.as_bytes()];
    parts.extend(FLAGS.iter().map(|f| f.as_bytes()));
    for (n, t) in &sources {
        parts.extend([n.as_bytes(), t.as_bytes()]);
    }
    let cache = default_cache_dir();
    let key = format!("tb-{:016x}", fnv1a(&parts));
    let exe = cache.join(&key).join("Vtb");
    let _guard = BUILD_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    if exe.is_file() {
        return Ok(exe);
    }
    let _lock = lock_key(&cache, &key)?;
    if exe.is_file() {
        return Ok(exe);
    }
    // built aside and renamed into place: another process never runs a half-written binary
    let work = cache.join(format!("{key}.tmp{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&work);
    let names = write_files(&work, files)?;
    let mut args: Vec<&str> = FLAGS.to_vec();
    args.extend([MAKEFLAGS, "--Mdir", "obj"]);
    args.extend(names.iter().map(String::as_str));
    run("verilator", "verilator", &args, &work)?;
    let dest = cache.join(&key);
    std::fs::create_dir_all(&dest).map_err(|e| HdlError::io(&dest, e))?;
    let tmp = dest.join(format!("Vtb.{}", std::process::id()));
    let built = work.join("obj").join("Vtb");
    std::fs::copy(&built, &tmp).map_err(|e| HdlError::io(&built, e))?;
    std::fs::rename(&tmp, &exe).map_err(|e| HdlError::io(&exe, e))?;
    let _ = std::fs::remove_dir_all(&work);
    Ok(exe)
}

/// `verilator --version`, checked, asked once per process (every simulation needs it for
/// its cache key).
fn verilator_version() -> Result<&'static str, HdlError> {
    static VERSION: OnceLock<String> = OnceLock::new();
    if let Some(v) = VERSION.get() {
        return Ok(v);
    }
    find("verilator", "verilator")?;
    let out = run("verilator", "verilator", &["--version"], Path::new("."))?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    check_version(&text)?;
    Ok(VERSION.get_or_init(|| text))
}

/// `Verilator 5.006 2023-01-22 …`: at least [`MIN_VERSION`].
fn check_version(text: &str) -> Result<(), HdlError> {
    let parsed = text
        .split_whitespace()
        .nth(1)
        .and_then(|v| v.split_once('.'))
        .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)));
    match parsed {
        Some(v) if v >= MIN_VERSION => Ok(()),
        _ => Err(HdlError::ToolFailed {
            tool: "verilator",
            detail: format!(
                "{:?} is too old for the testbenches: they need Verilator {}.{:03} or later \
                 (or {SIM_ENV}=icarus)",
                text.trim(),
                MIN_VERSION.0,
                MIN_VERSION.1
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_before_5_006_are_refused() {
        assert!(check_version("Verilator 5.006 2023-01-22 rev (Debian 5.006-3)").is_ok());
        assert!(check_version("Verilator 5.020 2024-01-01").is_ok());
        assert!(check_version("Verilator 4.228 2022-10-01").is_err());
        assert!(check_version("Verilator 5.004 2022-12-14").is_err());
        assert!(check_version("nonsense").is_err());
    }
}
