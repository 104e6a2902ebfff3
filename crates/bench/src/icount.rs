//! Instructions per edge, counted by valgrind's callgrind (repeatable on a loaded machine,
//! unlike wall time): a run of one implementation on one move, minus the same run that
//! plans and stops, over the move's steps.

use std::path::Path;
use std::process::{Command, Stdio};

/// Whether `valgrind` runs here.
pub fn valgrind_present() -> bool {
    Command::new("valgrind")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Instructions (callgrind's `Ir`) of the whole process `exe args…`.
pub fn instructions(exe: &Path, args: &[&str]) -> Option<u64> {
    let out = Command::new("valgrind")
        .args(["--tool=callgrind", "--callgrind-out-file=/dev/null"])
        .arg(exe)
        .args(args)
        .stdout(Stdio::null())
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    parse_collected(&String::from_utf8_lossy(&out.stderr))
}

/// The `Collected : N` line of callgrind's summary.
fn parse_collected(stderr: &str) -> Option<u64> {
    stderr.lines().find_map(|l| {
        let (_, rest) = l.split_once("Collected :")?;
        rest.trim().parse().ok()
    })
}

/// `(Ir(run) − Ir(plan only)) / steps`.
pub fn per_edge(exe: &Path, run: &[&str], plan_only: &[&str], steps: u64) -> Option<f64> {
    per_call(exe, run, plan_only, steps)
}

/// `(Ir(run) − Ir(floor)) / n`: what each of the n calls `run` makes more than `floor` costs.
pub fn per_call(exe: &Path, run: &[&str], floor: &[&str], n: u64) -> Option<f64> {
    let full = instructions(exe, run)?;
    let fixed = instructions(exe, floor)?;
    Some(full.saturating_sub(fixed) as f64 / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_callgrinds_summary() {
        let s = "==12== Events    : Ir\n==12== Collected : 123456789\n==12==\n";
        assert_eq!(parse_collected(s), Some(123_456_789));
        assert_eq!(parse_collected("nothing"), None);
    }
}
