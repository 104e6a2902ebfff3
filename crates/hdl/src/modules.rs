//! Where a board's logic goes: each module of its Verilog synthesized alone, its own cells
//! counted (not its submodules'), and how many instances the board has, so the
//! per-axis cost and the shared part are read off one table.

use crate::boards::{Board, Family};
use crate::report::{parse_cells, Resources, Target};
use crate::tools::run;
use crate::HdlError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// One module of the hierarchy.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ModuleRow {
    /// The module's name in the Verilog (parameterized copies folded together).
    pub module: String,
    /// Instances in the board (the top counts once).
    pub instances: u64,
    /// Cells of one instance, its submodules left out (the mean when the parameterized
    /// copies differ).
    pub each: Resources,
    /// Cells of all instances.
    pub total: Resources,
}

/// The table of one board build.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ModuleTable {
    pub board: String,
    pub axes: u32,
    pub target: Target,
    pub rows: Vec<ModuleRow>,
}

impl ModuleTable {
    /// The row of `module`, if the board has it.
    pub fn row(&self, module: &str) -> Option<&ModuleRow> {
        self.rows.iter().find(|r| r.module == module)
    }

    /// The sum over all modules: the whole board before placement.
    pub fn total(&self) -> Resources {
        self.rows
            .iter()
            .fold(Resources::default(), |a, r| a.plus(r.total))
    }

    /// The cells of one axis: the [`PER_AXIS`] modules the board has, per axis.
    pub fn per_axis(&self) -> Resources {
        let k = u64::from(self.axes.max(1));
        self.rows
            .iter()
            .filter(|r| PER_AXIS.contains(&r.module.as_str()))
            .fold(Resources::default(), |a, r| a.plus(r.total))
            .per(k)
    }
}

/// The modules a board has once (or twice) per axis; everything else is shared.
pub const PER_AXIS: &[&str] = &[
    "ms_fifo",
    "ms_pulse",
    "ms_axis_io",
    "ms_debounce",
    "ms_replay_axis",
    "ms_step_count",
    "ms_stream",
    "ms_chain_axis",
];

/// The synthesis family of a board.
pub fn target_of(family: Family) -> Target {
    match family {
        Family::Ecp5 => Target::Ecp5,
        Family::Ice40 => Target::Ice40,
    }
}

/// Writes `axes` axes of board `b` into `dir`, synthesizes each of its modules with
/// yosys on its own (its submodules as black boxes), and counts each module's cells.
///
/// One module at a time, because ABC's mapping of a module depends on the order of its
/// cells, and in one run of the whole board that order follows names interned for every
/// other module: the same `ms_pulse` came out anywhere from 113 to 182 LUT4s as other
/// modules changed. Alone, a module's count changes only when its own Verilog does (or
/// that of a module under it, read to find its ports).
pub fn per_module(b: &Board, axes: u32, dir: &Path) -> Result<ModuleTable, HdlError> {
    let params = b.params(axes)?;
    let files = crate::build::sources(b, &params)?;
    std::fs::create_dir_all(dir).map_err(|e| HdlError::io(dir, e))?;
    for (name, text) in &files {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| HdlError::io(&path, e))?;
    }
    let target = target_of(b.family);
    let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
    // the hierarchy, elaborated: which modules, their parameters, their instances
    let script = format!(
        "read_verilog -defer {}; hierarchy -top {}; tee -q -o hierarchy.json stat -json; \
         write_rtlil hierarchy.il",
        names.join(" "),
        b.top
    );
    run("yosys", "yosys", &["-q", "-p", &script], dir)?;
    let read = |name: &str| {
        let path = dir.join(name);
        std::fs::read_to_string(&path).map_err(|e| HdlError::io(&path, e))
    };
    let hierarchy = read("hierarchy.json")?;
    let modules = parameters(&read("hierarchy.il")?);
    let tree = Hierarchy::parse(&hierarchy, b.top)?;
    let own = modules
        .par_iter()
        .enumerate()
        .map(|(i, (name, params))| {
            let base = base_name(name);
            // its own file and those of the modules under it (all, if one is not found)
            let mut needed: Vec<&str> = tree
                .under(name)
                .iter()
                .map(|m| base_name(m))
                .chain([base])
                .map(|m| format!("{m}.v"))
                .filter_map(|f| names.iter().find(|n| **n == f).copied())
                .collect();
            if !needed.iter().any(|f| *f == format!("{base}.v")) {
                needed = names.clone();
            }
            needed.sort_unstable();
            needed.dedup();
            let set: String = params
                .iter()
                .map(|(p, v)| format!(" -set {p} {v}"))
                .collect();
            let chparam = if set.is_empty() {
                String::new()
            } else {
                format!("chparam{set} {base}; ")
            };
            let out = format!("module{i}.json");
            let script = format!(
                "read_verilog -defer {}; {chparam}hierarchy -top {base}; blackbox A:top %n; \
                 {}; tee -q -o {out} stat -json",
                needed.join(" "),
                target.synth_hierarchy(base)
            );
            run("yosys", "yosys", &["-q", "-p", &script], dir)?;
            Ok((name.clone(), top_cells(&read(&out)?, target, base)?))
        })
        .collect::<Result<BTreeMap<String, Resources>, HdlError>>()?;
    Ok(ModuleTable {
        board: b.name.to_string(),
        axes,
        target,
        rows: tree.rows(&own, b.top)?,
    })
}

/// Each module of an elaborated design (`write_rtlil`) with its parameters, as `chparam`
/// takes them: `24`, or a sized binary constant `1'1` as `1'b1`.
fn parameters(rtlil: &str) -> Vec<(String, Vec<(String, String)>)> {
    let mut modules: Vec<(String, Vec<(String, String)>)> = Vec::new();
    for line in rtlil.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["module", name] => modules.push((name.to_string(), Vec::new())),
            // a module's own (a cell's are indented deeper)
            ["parameter", .., p, v] if p.starts_with('\\') && line.starts_with("  parameter") => {
                if let Some((_, ps)) = modules.last_mut() {
                    let value = match v.split_once('\'') {
                        Some((n, bits)) if !bits.starts_with(['b', 'd', 'h', 'o', 's']) => {
                            format!("{n}'b{bits}")
                        }
                        _ => v.to_string(),
                    };
                    ps.push((p[1..].to_string(), value));
                }
            }
            _ => {}
        }
    }
    modules
}

/// The cells of module `base` itself in `stat -json` of it synthesized alone.
fn top_cells(json: &str, target: Target, base: &str) -> Result<Resources, HdlError> {
    let modules = stat_modules(json)?;
    let (_, m) = modules
        .iter()
        .find(|(k, _)| base_name(k) == base)
        .ok_or_else(|| stat_error(format!("no module {base}")))?;
    let cells = m
        .get("num_cells_by_type")
        .and_then(|c| c.as_object())
        .ok_or_else(|| stat_error(format!("no cells in {base}")))?;
    // the black boxes' instances are not cells of the family: not counted
    Ok(parse_cells(cells, target))
}

fn stat_error(m: String) -> HdlError {
    HdlError::ToolFailed {
        tool: "yosys",
        detail: format!("stat -json: {m}"),
    }
}

/// The "modules" object of `stat -json`. Only it is read: Yosys 0.23 prints the hierarchy
/// as plain text after it, inside the JSON, when the design has a top.
fn stat_modules(json: &str) -> Result<serde_json::Map<String, serde_json::Value>, HdlError> {
    let at = json
        .find("\"modules\":")
        .ok_or_else(|| stat_error("no modules".into()))?;
    let mut de = serde_json::Deserializer::from_str(&json[at + "\"modules\":".len()..]);
    let v = serde_json::Value::deserialize(&mut de).map_err(|e| stat_error(e.to_string()))?;
    match v {
        serde_json::Value::Object(m) => Ok(m),
        _ => Err(stat_error("modules is not an object".into())),
    }
}

/// The base name of a (possibly parameterized) yosys module name:
/// `$paramod$2f3…\ms_fifo` and `$paramod\ms_fifo\W=24` are both `ms_fifo`.
fn base_name(name: &str) -> &str {
    let name = name.strip_prefix('\\').unwrap_or(name);
    match name.strip_prefix("$paramod") {
        Some(rest) => rest.split('\\').nth(1).unwrap_or(rest),
        None => name,
    }
}

/// A design's module hierarchy from `stat -json`: which modules each instantiates, and
/// how often.
struct Hierarchy {
    top: String,
    children: BTreeMap<String, Vec<(String, u64)>>,
}

impl Hierarchy {
    fn parse(json: &str, top: &str) -> Result<Hierarchy, HdlError> {
        let modules = stat_modules(json)?;
        let mut children = BTreeMap::new();
        for (name, m) in &modules {
            let cells = m
                .get("num_cells_by_type")
                .and_then(|c| c.as_object())
                .ok_or_else(|| stat_error(format!("no cells in {name}")))?;
            let mut kids = Vec::new();
            for (cell, n) in cells {
                // a plain module is named `\name` but instantiated as `name`
                let key = modules
                    .get_key_value(cell)
                    .or_else(|| modules.get_key_value(&format!("\\{cell}")));
                if let Some((key, _)) = key {
                    kids.push((key.clone(), n.as_u64().unwrap_or(0)));
                }
            }
            children.insert(name.clone(), kids);
        }
        let top = modules
            .keys()
            .find(|k| base_name(k) == top)
            .ok_or_else(|| stat_error(format!("no top module {top}")))?
            .clone();
        Ok(Hierarchy { top, children })
    }

    /// Every module below `name` (not `name` itself).
    fn under(&self, name: &str) -> Vec<&str> {
        let mut seen: Vec<&str> = Vec::new();
        let mut stack: Vec<&str> = vec![name];
        while let Some(m) = stack.pop() {
            for (kid, _) in self.children.get(m).into_iter().flatten() {
                if !seen.contains(&kid.as_str()) {
                    seen.push(kid);
                    stack.push(kid);
                }
            }
        }
        seen
    }

    /// The rows: each module's instances under the top and `own` cells, folded by base
    /// name (a module missing from `own` counts nothing).
    fn rows(
        &self,
        own: &BTreeMap<String, Resources>,
        top: &str,
    ) -> Result<Vec<ModuleRow>, HdlError> {
        let mut count: BTreeMap<&str, u64> = BTreeMap::new();
        let mut stack = vec![(self.top.as_str(), 1u64)];
        while let Some((name, n)) = stack.pop() {
            *count.entry(name).or_default() += n;
            for (kid, m) in self.children.get(name).into_iter().flatten() {
                stack.push((kid, n * m));
            }
        }
        let mut rows: BTreeMap<&str, ModuleRow> = BTreeMap::new();
        for (name, n) in count {
            let base = base_name(name);
            let row = rows.entry(base).or_insert_with(|| ModuleRow {
                module: base.to_string(),
                instances: 0,
                each: Resources::default(),
                total: Resources::default(),
            });
            row.instances += n;
            row.total = row
                .total
                .plus(own.get(name).copied().unwrap_or_default().times(n));
        }
        let mut rows: Vec<ModuleRow> = rows.into_values().collect();
        for r in &mut rows {
            r.each = r.total.per(r.instances);
        }
        // the top first, then by total LUTs, largest first
        rows.sort_by_key(|r| (r.module != top, std::cmp::Reverse(r.total.lut)));
        Ok(rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameterized_names_fold_to_the_module() {
        assert_eq!(base_name("$paramod$2f3a\\ms_fifo"), "ms_fifo");
        assert_eq!(
            base_name("$paramod\\ms_fifo\\W=s32'00000000000000000000000000011000"),
            "ms_fifo"
        );
        assert_eq!(base_name("\\ms_board"), "ms_board");
        assert_eq!(base_name("ms_board"), "ms_board");
    }

    #[test]
    fn module_parameters_are_read_as_chparam_takes_them() {
        let il = "attribute \\top 1\n\
                  module \\top\n\
                  \x20 wire input 1 \\clk\n\
                  \x20 cell $paramod\\leaf\\W=24 \\u\n\
                  \x20   parameter \\WIDTH 3\n\
                  \x20 end\n\
                  end\n\
                  module $paramod\\leaf\\W=24\n\
                  \x20 parameter \\W 24\n\
                  \x20 parameter \\BULK 1'1\n\
                  \x20 parameter \\S 2'10\n\
                  end\n";
        let m = parameters(il);
        assert_eq!(m.len(), 2);
        assert_eq!(
            (m[0].0.as_str(), m[0].1.len()),
            ("\\top", 0),
            "a cell's are not"
        );
        let p: Vec<(&str, &str)> = m[1]
            .1
            .iter()
            .map(|(a, b)| (a.as_str(), b.as_str()))
            .collect();
        assert_eq!(p, [("W", "24"), ("BULK", "1'b1"), ("S", "2'b10")]);
    }

    /// The rows of the hierarchy below, each module's own cells as synthesis would count
    /// them (a CCU2C: 2 LUT4).
    fn rows_of(json: &str, top: &str) -> Result<Vec<ModuleRow>, HdlError> {
        let tree = Hierarchy::parse(json, top)?;
        let r = |lut, ff| Resources {
            lut,
            ff,
            ..Resources::default()
        };
        let own = BTreeMap::from([
            ("\\top".to_string(), r(10, 0)),
            ("\\plain".to_string(), r(0, 1)),
            ("$paramod\\mid\\K=2".to_string(), r(3, 4)),
            ("\\leaf".to_string(), r(10, 0)),
        ]);
        tree.rows(&own, top)
    }

    #[test]
    fn instances_multiply_down_the_hierarchy() {
        let json = r#"{"modules": {
            "\\top": {"num_cells_by_type": {"LUT4": 10, "$paramod\\mid\\K=2": 2}},
            "\\plain": {"num_cells_by_type": {"TRELLIS_FF": 1}},
            "$paramod\\mid\\K=2": {"num_cells_by_type": {"LUT4": 3, "TRELLIS_FF": 4, "\\leaf": 3, "plain": 1}},
            "\\leaf": {"num_cells_by_type": {"CCU2C": 5}}
        }}"#;
        let rows = rows_of(json, "top").unwrap();
        let row = |m: &str| rows.iter().find(|r| r.module == m).unwrap().clone();
        assert_eq!(rows[0].module, "top");
        assert_eq!((row("top").instances, row("top").each.lut), (1, 10));
        assert_eq!(
            (
                row("mid").instances,
                row("mid").each.lut,
                row("mid").each.ff
            ),
            (2, 3, 4)
        );
        assert_eq!((row("plain").instances, row("plain").each.ff), (2, 1));
        assert_eq!(
            (
                row("leaf").instances,
                row("leaf").each.lut,
                row("leaf").total.lut
            ),
            (6, 10, 60)
        );
        let t = ModuleTable {
            board: "b".into(),
            axes: 2,
            target: Target::Ecp5,
            rows,
        };
        assert_eq!(t.total().lut, 10 + 6 + 60);
        // no module of the table is a per-axis one
        assert_eq!(t.per_axis(), Resources::default());
        assert!(rows_of(json, "nope").is_err());
    }
}
