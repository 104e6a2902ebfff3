//! Plots draw on a machine with no fonts installed: every plotting command runs in a private
//! mount namespace whose font directories are empty tmpfs mounts.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Every directory fontconfig-style lookups (and the old hard-coded paths) search.
const FONT_DIRS: [&str; 4] = [
    "/usr/share/fonts",
    "/usr/local/share/fonts",
    "$HOME/.fonts",
    "$HOME/.local/share/fonts",
];

/// Font files in the font directories (none on a machine without fonts).
fn visible_fonts() -> Vec<PathBuf> {
    let home = std::env::var("HOME").unwrap_or_default();
    let mut stack: Vec<PathBuf> = FONT_DIRS
        .iter()
        .map(|d| PathBuf::from(d.replace("$HOME", &home)))
        .collect();
    let mut found = Vec::new();
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p)
            } else {
                found.push(p)
            }
        }
    }
    found
}

/// Runs `multistep ARGS` with every font directory hidden, or `None` (with the reason
/// printed) where private mount namespaces are not available.
fn multistep_without_fonts(args: &[&str]) -> Option<Output> {
    let bin = env!("CARGO_BIN_EXE_multistep");
    if visible_fonts().is_empty() {
        // Nothing to hide (a machine without fonts, such as a minimal container).
        let out = Command::new(bin)
            .args(args)
            .env_remove("MULTISTEP_FONT")
            .output()
            .unwrap();
        return Some(out);
    }
    let probe = Command::new("unshare").args(["-m", "true"]).output();
    match probe {
        Ok(o) if o.status.success() => {}
        Ok(o) => {
            eprintln!(
                "skipped: fonts are installed and `unshare -m` failed (it needs root, and / a mount point): {}",
                String::from_utf8_lossy(&o.stderr).trim()
            );
            return None;
        }
        Err(e) => {
            eprintln!("skipped: unshare (util-linux) is not available: {e}");
            return None;
        }
    }
    let dirs = FONT_DIRS.join(" ");
    // Exit 97: a font file is still visible, so the test would prove nothing.
    let script = format!(
        "for d in {dirs}; do [ -d \"$d\" ] && {{ mount -t tmpfs tmpfs \"$d\" || exit 96; }}; done; \
         [ -z \"$(find {dirs} -type f 2>/dev/null)\" ] || exit 97; exec \"$@\""
    );
    let out = Command::new("unshare")
        .args(["-m", "sh", "-c", &script, "sh"])
        .arg(bin)
        .args(args)
        .env_remove("MULTISTEP_FONT")
        .output()
        .unwrap();
    let code = out.status.code();
    assert!(
        code != Some(96) && code != Some(97),
        "could not hide the fonts (exit {code:?}): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(out)
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("multistep-nofont-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// An SVG that plotters finished, with its labels as text.
fn assert_svg_with_text(path: &Path, label: &str) {
    let svg = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert!(svg.matches("<text").count() >= 5, "{}", path.display());
    assert!(svg.contains(label), "{} lacks {label:?}", path.display());
}

#[test]
fn demo_prints_its_table_and_draws_its_plots_with_no_fonts() {
    let dir = temp_dir("demo");
    let Some(out) = multistep_without_fonts(&["demo", "--out", dir.to_str().unwrap()]) else {
        return;
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let table = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = table.lines().collect();
    assert!(
        lines[0].starts_with("seed 000 two-axis run: TDM engine"),
        "{table}"
    );
    assert!(lines[1].starts_with("axis"), "{table}");
    for (line, (axis, steps)) in lines[2..4].iter().zip([("x", "2400"), ("y", "1800")]) {
        let cols: Vec<&str> = line.split_whitespace().collect();
        assert_eq!((cols[0], cols[1]), (axis, steps), "{table}");
        assert_eq!(cols[4], "0", "underruns: {table}");
        assert_eq!(cols.last(), Some(&"0"), "lost steps: {table}");
    }
    assert_eq!(lines[4], format!("plots: {}", dir.display()));
    for f in ["axis0-x.svg", "axis1-y.svg"] {
        assert_svg_with_text(&dir.join(f), "following error");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn simulate_png_and_tdm_sweep_plots_draw_with_no_fonts() {
    let dir = temp_dir("plots");
    let png = dir.join("speed.png");
    let Some(out) = multistep_without_fonts(&[
        "simulate",
        "--motor",
        "20mm",
        "--mode",
        "ideal",
        "--profile",
        "trapezoid",
        "--steps",
        "800",
        "--accel-time",
        "0.01",
        "--cruise-time",
        "0.01",
        "--decel-time",
        "0.01",
        "--plot",
        png.to_str().unwrap(),
    ]) else {
        return;
    };
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // A bitmap needs the glyphs themselves, not only their metrics.
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[1..4], b"PNG");
    assert!(bytes.len() > 10_000, "{} bytes", bytes.len());

    let svg = dir.join("sweep.svg");
    let out = multistep_without_fonts(&[
        "tdm",
        "--sweep",
        "--rates",
        "80000:100000:2",
        "--max-axes",
        "16",
        "--fifo-depths",
        "1",
        "--plot",
        svg.to_str().unwrap(),
    ])
    .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_svg_with_text(&svg, "eq. (12)");
    std::fs::remove_dir_all(&dir).ok();
}
