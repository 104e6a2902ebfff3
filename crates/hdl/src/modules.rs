//! Where a board's logic goes: its Verilog synthesized without flattening, each module's
//! own cells counted (not its submodules'), and how many instances the board has, so the
//! per-axis cost and the shared part are read off one table.

use crate::boards::{Board, Family};
use crate::report::{parse_cells, Resources, Target};
use crate::tools::run;
use crate::HdlError;
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

/// Writes `axes` axes of board `b` into `dir`, synthesizes them with yosys without
/// flattening, and counts each module's cells.
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
    let script = format!(
        "read_verilog -defer {}; {}; tee -q -o stat.json stat -json",
        names.join(" "),
        target.synth_hierarchy(b.top)
    );
    run("yosys", "yosys", &["-q", "-p", &script], dir)?;
    let path = dir.join("stat.json");
    let text = std::fs::read_to_string(&path).map_err(|e| HdlError::io(&path, e))?;
    Ok(ModuleTable {
        board: b.name.to_string(),
        axes,
        target,
        rows: parse_hierarchy(&text, target, b.top)?,
    })
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

/// Per-module rows from `stat -json` of a design synthesized without flattening.
pub fn parse_hierarchy(json: &str, target: Target, top: &str) -> Result<Vec<ModuleRow>, HdlError> {
    let bad = |m: String| HdlError::ToolFailed {
        tool: "yosys",
        detail: format!("stat -json: {m}"),
    };
    // Only the "modules" object is read: Yosys 0.23 prints the hierarchy as plain text
    // after it, inside the JSON, when the design has a top.
    let at = json
        .find("\"modules\":")
        .ok_or_else(|| bad("no modules".into()))?;
    let mut de = serde_json::Deserializer::from_str(&json[at + "\"modules\":".len()..]);
    let v = serde_json::Value::deserialize(&mut de).map_err(|e| bad(e.to_string()))?;
    let modules = v
        .as_object()
        .ok_or_else(|| bad("modules is not an object".into()))?;
    // cells of each yosys module, and the yosys modules each instantiates
    let mut own: BTreeMap<&str, Resources> = BTreeMap::new();
    let mut children: BTreeMap<&str, Vec<(&str, u64)>> = BTreeMap::new();
    for (name, m) in modules {
        let cells = m
            .get("num_cells_by_type")
            .and_then(|c| c.as_object())
            .ok_or_else(|| bad(format!("no cells in {name}")))?;
        let mut kids = Vec::new();
        let mut leaf = serde_json::Map::new();
        for (cell, n) in cells {
            // a plain module is named `\name` but instantiated as `name`
            let key = modules
                .get_key_value(cell)
                .or_else(|| modules.get_key_value(&format!("\\{cell}")));
            match key {
                Some((key, _)) => kids.push((key.as_str(), n.as_u64().unwrap_or(0))),
                None => {
                    leaf.insert(cell.clone(), n.clone());
                }
            }
        }
        own.insert(name, parse_cells(&leaf, target));
        children.insert(name, kids);
    }
    let top_key = modules
        .keys()
        .find(|k| base_name(k) == top)
        .ok_or_else(|| bad(format!("no top module {top}")))?;
    // instances of every yosys module under the top, then folded by base name
    let mut count: BTreeMap<&str, u64> = BTreeMap::new();
    let mut stack = vec![(top_key.as_str(), 1u64)];
    while let Some((name, n)) = stack.pop() {
        *count.entry(name).or_default() += n;
        for &(kid, m) in children.get(name).into_iter().flatten() {
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
        row.total = row.total.plus(own[name].times(n));
    }
    let mut rows: Vec<ModuleRow> = rows.into_values().collect();
    for r in &mut rows {
        r.each = r.total.per(r.instances);
    }
    // the top first, then by total LUTs, largest first
    rows.sort_by_key(|r| (r.module != top, std::cmp::Reverse(r.total.lut)));
    Ok(rows)
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
    fn instances_multiply_down_the_hierarchy() {
        let json = r#"{"modules": {
            "\\top": {"num_cells_by_type": {"LUT4": 10, "$paramod\\mid\\K=2": 2}},
            "\\plain": {"num_cells_by_type": {"TRELLIS_FF": 1}},
            "$paramod\\mid\\K=2": {"num_cells_by_type": {"LUT4": 3, "TRELLIS_FF": 4, "\\leaf": 3, "plain": 1}},
            "\\leaf": {"num_cells_by_type": {"CCU2C": 5}}
        }}"#;
        let rows = parse_hierarchy(json, Target::Ecp5, "top").unwrap();
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
        assert!(parse_hierarchy(json, Target::Ecp5, "nope").is_err());
    }
}
