//! Every measured figure in the docs can be traced: to the command that regenerates it, or
//! to the day and the machine it was measured on.
//!
//! The rule, for docs/BENCHMARKS.md, docs/HDL.md, docs/HIL.md and docs/PYTHON.md:
//! - a *section* runs from a heading (any level) to the next heading;
//! - a section *holds measured figures* when it has a table whose header row names a
//!   measured quantity (a rate `…/s`, a time — `wall`, `CPU s`, `(ms)`, `(µs)`, `p50`,
//!   `compile`, `time` —, instructions, FPGA resources — LUT, FF, DSP, LCs, logic cells,
//!   TRELLIS, Fmax —, or `before` / `after` columns), or a line of prose that says
//!   "measured" next to a number;
//! - such a section must hold a provenance line: `Regenerate: `COMMAND`` (or prose that
//!   says "regenerate with `COMMAND`"), or the marker
//!   `<!-- measured: YYYY-MM-DD, MACHINE -->` (MACHINE: the CPU, its cores, the load).
//!
//! Fenced blocks are neither headings, tables nor prose.

use std::path::Path;

const DOCS: &[&str] = &[
    "docs/BENCHMARKS.md",
    "docs/HDL.md",
    "docs/HIL.md",
    "docs/PYTHON.md",
];

/// Header words of a table of measured quantities (matched in lower case).
const MEASURED_HEADER: &[&str] = &[
    "/s ",
    "/s|",
    "/s)",
    "instr",
    "before",
    "after",
    "lut",
    " ff ",
    "dsp",
    " lcs",
    "logic cells",
    "trellis",
    "fmax",
    "wall",
    "cpu s",
    "(ms)",
    "(µs)",
    "p50",
    "compile",
    "per edge",
    "median",
    "edges per",
    "skew",
    "time",
];

/// One heading's section of a doc.
#[derive(Debug)]
struct Section {
    /// `FILE:LINE` of its heading.
    at: String,
    /// `LINE: text` of each measured figure (a table's header, a line of prose).
    figures: Vec<String>,
    traced: bool,
}

fn is_measured_header(row: &str) -> bool {
    let row = format!("{} ", row.to_lowercase());
    MEASURED_HEADER.iter().any(|w| row.contains(w))
}

fn is_measured_prose(line: &str) -> bool {
    line.to_lowercase().contains("measured") && line.chars().any(|c| c.is_ascii_digit())
}

/// `Regenerate: `…``, prose "regenerate with `…`", or `<!-- measured: DATE, MACHINE -->`.
fn is_provenance(line: &str) -> bool {
    let l = line.trim();
    let lower = l.to_lowercase();
    if let Some(i) = lower.find("regenerate") {
        return lower[i..].matches('`').count() >= 2;
    }
    let Some(rest) = l
        .strip_prefix("<!-- measured:")
        .and_then(|r| r.strip_suffix("-->"))
    else {
        return false;
    };
    let (date, machine) = rest.trim().split_once(',').unwrap_or((rest.trim(), ""));
    let d: Vec<&str> = date.split('-').collect();
    let is_date = d.len() == 3
        && [4, 2, 2]
            .iter()
            .zip(&d)
            .all(|(n, p)| p.len() == *n && p.chars().all(|c| c.is_ascii_digit()));
    is_date && machine.trim().len() >= 5
}

fn sections(name: &str, text: &str) -> Vec<Section> {
    let mut out = vec![Section {
        at: format!("{name}:1"),
        figures: Vec::new(),
        traced: false,
    }];
    let mut in_fence = false;
    let mut in_table = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
            in_table = false;
            continue;
        }
        let s = out.last_mut().unwrap();
        if in_fence {
            continue;
        }
        if is_provenance(line) {
            s.traced = true;
            continue;
        }
        if line.starts_with('#') {
            out.push(Section {
                at: format!("{name}:{}", i + 1),
                figures: Vec::new(),
                traced: false,
            });
            in_table = false;
            continue;
        }
        let row = line.starts_with('|');
        let figure = if row {
            !in_table && is_measured_header(line)
        } else {
            is_measured_prose(line)
        };
        if figure {
            s.figures.push(format!("{}: {}", i + 1, line.trim()));
        }
        in_table = row;
    }
    out
}

#[test]
fn every_measured_figure_says_how_to_regenerate_it_or_when_and_where_it_was_measured() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut untraced = Vec::new();
    let mut measured = 0;
    for doc in DOCS {
        let text = std::fs::read_to_string(root.join(doc)).unwrap();
        for s in sections(doc, &text) {
            if s.figures.is_empty() {
                continue;
            }
            measured += 1;
            if !s.traced {
                untraced.push(format!("{}\n    {}", s.at, s.figures.join("\n    ")));
            }
        }
    }
    assert!(
        measured >= 30,
        "found only {measured} sections with figures"
    );
    assert!(
        untraced.is_empty(),
        "sections with measured figures but no `Regenerate: `COMMAND`` line nor \
         `<!-- measured: YYYY-MM-DD, MACHINE -->` marker:\n{}",
        untraced.join("\n")
    );
}

#[test]
fn the_rule_tells_measured_figures_and_provenance_apart() {
    let doc = "# A\n\n| move | edges/s |\n|---|---|\n| x | 1 M |\n\n\
               # B\n\n| addr | name |\n|---|---|\n| 0x00 | Session |\n\n\
               # C\n\nMeasured 2026-12-01: 3 s.\n\
               <!-- measured: 2026-12-01, 2-core AMD EPYC, load 1 -->\n\n\
               # D\n\n| K | LUT |\n|---|---|\n| 2 | 2796 |\n\nRegenerate: `multistep hdl report`\n\n\
               # E\n\n```\n| wall | s |\n```\n";
    let s = sections("t.md", doc);
    let got: Vec<(usize, bool)> = s.iter().map(|s| (s.figures.len(), s.traced)).collect();
    assert_eq!(
        got,
        [
            (0, false),
            (1, false),
            (0, false),
            (1, true),
            (1, true),
            (0, false)
        ]
    );
    assert!(!is_provenance("<!-- measured: yesterday, here -->"));
    assert!(!is_provenance("<!-- measured: 2026-12-01 -->"));
    assert!(!is_provenance("Regenerate: by hand"));
}
