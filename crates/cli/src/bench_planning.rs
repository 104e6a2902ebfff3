//! `multistep bench --planning`: one move planned by multistep and by Ruckig, natively and
//! through Python, in instructions (callgrind) and time.

use anyhow::{anyhow, Result};
use multistep_bench::icount;
use multistep_bench::planning::{plan_n, time_native, PlanCase, PlanRow, PLAN_CASES, PY_DRIVER};
use std::io::Write;
use std::path::Path;
use std::process::Command;

/// Plans under callgrind: this many plans (native) and calls (Python) per count.
const COUNT_NATIVE: u64 = 20_000;
const COUNT_PYTHON: u64 = 20_000;

/// `--plan-one CASE --reps N`: N plans of the case, their total duration printed.
pub fn plan_one(name: &str, reps: u64) -> Result<()> {
    let c = PlanCase::by_name(name).ok_or_else(|| anyhow!("unknown planning case {name}"))?;
    println!("{}", plan_n(c, reps)?);
    Ok(())
}

/// Whether `python` imports both packages.
fn python_ready(python: &str) -> bool {
    Command::new(python)
        .args(["-c", "import multistep, ruckig"])
        .output()
        .is_ok_and(|o| o.status.success())
}

fn python_times(python: &str, case: &str, quick: bool) -> Result<serde_json::Value> {
    let (rounds, n) = if quick {
        ("5", "2000")
    } else {
        ("21", "20000")
    };
    let out = Command::new(python)
        .args(["-c", PY_DRIVER, "time", "-", case, rounds, n])
        .output()?;
    if !out.status.success() {
        return Err(anyhow!(
            "the Python driver failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(serde_json::from_slice(&out.stdout)?)
}

pub fn rows(python: &str, instructions: bool, quick: bool) -> Result<Vec<PlanRow>> {
    let exe = std::env::current_exe()?;
    let py_ok = python_ready(python);
    if !py_ok {
        eprintln!("note: {python} cannot import multistep and ruckig; Python rows are left out");
    }
    let mut rows = Vec::new();
    for c in &PLAN_CASES {
        let (rounds, per) = if quick { (5, 2_000) } else { (21, 50_000) };
        let n = COUNT_NATIVE.to_string();
        let native = instructions
            .then(|| {
                icount::per_call(
                    &exe,
                    &["bench", "--plan-one", c.name, "--reps", &n],
                    &["bench", "--plan-one", c.name, "--reps", "0"],
                    COUNT_NATIVE,
                )
            })
            .flatten();
        rows.push(PlanRow {
            case: c.name,
            imp: "multistep (Rust)",
            instructions: native,
            us_per_call: Some(time_native(c, rounds, per)? / 1e3),
        });
        if !py_ok {
            continue;
        }
        let case = serde_json::to_string(c)?;
        let t = python_times(python, &case, quick)?;
        for (imp, key) in [
            ("multistep (Python)", "multistep"),
            ("ruckig (Python)", "ruckig"),
        ] {
            let n = COUNT_PYTHON.to_string();
            let count = |k: &str| ["-c", PY_DRIVER, "count", key, &case, "0", k].map(String::from);
            let (run, floor) = (count(&n), count("0"));
            let ir = instructions
                .then(|| {
                    icount::per_call(
                        Path::new(python),
                        &run.each_ref().map(String::as_str),
                        &floor.each_ref().map(String::as_str),
                        COUNT_PYTHON,
                    )
                })
                .flatten();
            rows.push(PlanRow {
                case: c.name,
                imp,
                instructions: ir,
                us_per_call: t[key].as_f64(),
            });
        }
    }
    Ok(rows)
}

pub fn table(out: &mut impl Write, rows: &[PlanRow]) -> Result<()> {
    writeln!(
        out,
        "{:<16} {:<20} {:>12} {:>10}",
        "planning case", "impl", "instr/call", "µs/call"
    )?;
    for r in rows {
        writeln!(
            out,
            "{:<16} {:<20} {:>12} {:>10}",
            r.case,
            r.imp,
            r.instructions.map_or("-".into(), |v| format!("{v:.0}")),
            r.us_per_call.map_or("-".into(), |v| format!("{v:.3}")),
        )?;
    }
    Ok(())
}
