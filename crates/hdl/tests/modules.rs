//! The per-module table of each board (`multistep hdl modules`), checked against budgets:
//! a change that makes an axis larger fails here at once, with the whole table printed.
//! Budgets are Debian's Yosys 0.23 counts (ECP5 without wide-LUT mapping, as the command
//! synthesizes) plus a small margin: each module is synthesized alone, so its count moves
//! only with its own Verilog (and the tool's version). Lower them when an axis shrinks.

use multistep_hdl::boards::Board;
use multistep_hdl::modules::{per_module, ModuleTable, PER_AXIS};

/// Per-axis modules and their LUT budgets for one instance (ECP5: LUT4 equivalents;
/// iCE40: SB_LUT4).
type Budgets = &'static [(&'static str, u64)];

/// Measured 2026-12-07 (LUT each, the same at K = 2, 4, 8 and 14): ms_fifo 19, ms_pulse
/// 121, ms_axis_io 27, ms_debounce 32, ms_replay_axis 29 (the replay unit's per-axis
/// flags; the shared decoder, ms_replay, with the pointers, the step counts,
/// ms_step_counts, and the positions, ms_positions, are not an axis's); one axis 260.
const ULX3S: Budgets = &[
    ("ms_fifo", 21),
    ("ms_pulse", 126),
    ("ms_axis_io", 30),
    ("ms_debounce", 34),
    ("ms_replay_axis", 32),
];
const ULX3S_AXIS: u64 = 272;

/// What one more axis adds to the whole ULX3S board, its share of the register map's
/// per-axis registers, the positions' deltas and the shared replay decoder's multiplexers
/// and step count memories included: (K = 4 − K = 2) / 2, measured 405.
const ULX3S_ADDED_AXIS: u64 = 420;

/// Measured 2026-12-07: ms_fifo 31, ms_pulse 101, ms_axis_io 26, ms_debounce 40; one axis
/// 198 (no replay unit and no limit input on this board: one filter an axis; the
/// positions a counter and a latch per axis in ms_positions, shared).
const ICEBREAKER: Budgets = &[
    ("ms_fifo", 33),
    ("ms_pulse", 106),
    ("ms_axis_io", 29),
    ("ms_debounce", 42),
];
const ICEBREAKER_AXIS: u64 = 208;

fn table(board: &str, axes: u32) -> ModuleTable {
    let b = Board::by_name(board).unwrap();
    let dir = tempfile::tempdir().unwrap();
    per_module(b, axes, dir.path()).unwrap_or_else(|e| panic!("{board}: {e}"))
}

fn check(t: &ModuleTable, budgets: Budgets, axis: u64) {
    let shown = serde_json::to_string_pretty(&t.rows).unwrap();
    let k = u64::from(t.axes);
    for &(module, lut) in budgets {
        let row = t
            .row(module)
            .unwrap_or_else(|| panic!("{}: no {module} in\n{shown}", t.board));
        // one per axis; two debounce filters per axis where it has a limit input
        let limits = Board::by_name(&t.board).unwrap().pinout.limits;
        let per = if module == "ms_debounce" && limits {
            2
        } else {
            1
        };
        assert_eq!(row.instances, per * k, "{}: {module} instances", t.board);
        assert!(
            row.each.lut <= lut,
            "{}: {} grew to {} LUTs (budget {}); regenerate with `multistep hdl modules \
             --board {} --axes {}` and update docs/HDL.md and this budget if intended\n{shown}",
            t.board,
            module,
            row.each.lut,
            lut,
            t.board,
            t.axes
        );
    }
    let one = t.per_axis();
    assert!(
        one.lut <= axis,
        "{}: one axis is {} LUTs (budget {axis})\n{shown}",
        t.board,
        one.lut
    );
    // every per-axis module the board has is budgeted
    for r in t
        .rows
        .iter()
        .filter(|r| PER_AXIS.contains(&r.module.as_str()))
    {
        assert!(
            budgets.iter().any(|&(m, _)| m == r.module),
            "{}: {} has no budget",
            t.board,
            r.module
        );
    }
    // the shared part is the rest, and the whole is their sum
    assert!(
        t.total().lut > one.lut * k,
        "{}: nothing shared?\n{shown}",
        t.board
    );
}

#[test]
fn ulx3s_axis_modules_stay_within_their_budgets() {
    let two = table("ulx3s-25f", 2);
    check(&two, ULX3S, ULX3S_AXIS);
    // the shared units grow with K too (the readback's multiplexers)
    let four = table("ulx3s-25f", 4);
    let added = (four.total().lut - two.total().lut) / 2;
    assert!(
        added <= ULX3S_ADDED_AXIS,
        "one more ULX3S axis adds {added} LUT4-eq (budget {ULX3S_ADDED_AXIS}); compare \
         `multistep hdl modules --board ulx3s-25f` at --axes 2 and 4"
    );
}

#[test]
fn icebreaker_axis_modules_stay_within_their_budgets() {
    check(&table("icebreaker", 2), ICEBREAKER, ICEBREAKER_AXIS);
}
