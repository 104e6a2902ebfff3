//! The per-module table of each board (`multistep hdl modules`), checked against budgets:
//! a change that makes an axis larger fails here at once, with the whole table printed.
//! Budgets are Debian's Yosys 0.23 counts plus a margin for ABC's run-to-run variance
//! (small structural changes move a module by up to ~10 %); lower them when an axis
//! shrinks.

use multistep_hdl::boards::Board;
use multistep_hdl::modules::{per_module, ModuleTable, PER_AXIS};

/// A module's LUT budget for one instance (ECP5: LUT4 equivalents; iCE40: SB_LUT4).
struct Budget {
    module: &'static str,
    lut: u64,
}

/// Measured 2026-12-05 (LUT each): ms_fifo 16, ms_pulse 422, ms_axis_io 180,
/// ms_debounce 76, ms_stream 577-656; one axis 1372.
const ULX3S: &[Budget] = &[
    Budget {
        module: "ms_fifo",
        lut: 20,
    },
    Budget {
        module: "ms_pulse",
        lut: 460,
    },
    Budget {
        module: "ms_axis_io",
        lut: 200,
    },
    Budget {
        module: "ms_debounce",
        lut: 84,
    },
    Budget {
        module: "ms_stream",
        lut: 700,
    },
];
const ULX3S_AXIS: u64 = 1500;

/// Measured 2026-12-05: ms_fifo 30, ms_pulse 301, ms_axis_io 159, ms_debounce 70; one axis
/// 630 (no replay unit on this board).
const ICEBREAKER: &[Budget] = &[
    Budget {
        module: "ms_fifo",
        lut: 34,
    },
    Budget {
        module: "ms_pulse",
        lut: 330,
    },
    Budget {
        module: "ms_axis_io",
        lut: 175,
    },
    Budget {
        module: "ms_debounce",
        lut: 77,
    },
];
const ICEBREAKER_AXIS: u64 = 690;

fn table(board: &str, axes: u32) -> ModuleTable {
    let b = Board::by_name(board).unwrap();
    let dir = tempfile::tempdir().unwrap();
    per_module(b, axes, dir.path()).unwrap_or_else(|e| panic!("{board}: {e}"))
}

fn check(t: &ModuleTable, budgets: &[Budget], axis: u64) {
    let shown = serde_json::to_string_pretty(&t.rows).unwrap();
    let k = u64::from(t.axes);
    for b in budgets {
        let row = t
            .row(b.module)
            .unwrap_or_else(|| panic!("{}: no {} in\n{shown}", t.board, b.module));
        // one per axis; two debounce filters (Hall and limit) per axis
        let per = if b.module == "ms_debounce" { 2 } else { 1 };
        assert_eq!(
            row.instances,
            per * k,
            "{}: {} instances",
            t.board,
            b.module
        );
        assert!(
            row.each.lut <= b.lut,
            "{}: {} grew to {} LUTs (budget {}); regenerate with `multistep hdl modules \
             --board {} --axes {}` and update docs/HDL.md and this budget if intended\n{shown}",
            t.board,
            b.module,
            row.each.lut,
            b.lut,
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
            budgets.iter().any(|b| b.module == r.module),
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
    check(&table("ulx3s-25f", 2), ULX3S, ULX3S_AXIS);
}

#[test]
fn icebreaker_axis_modules_stay_within_their_budgets() {
    check(&table("icebreaker", 2), ICEBREAKER, ICEBREAKER_AXIS);
}
