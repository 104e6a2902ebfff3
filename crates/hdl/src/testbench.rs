//! Testbench generator: loads moves through the register bus, starts them as one group
//! and writes every STEP edge as `rise|fall tick axis` (tick 0 = the group's `go`), every
//! calculator select and FIFO write as `sel|push cycle core`, then `go CYCLE`,
//! `underrun MASK` and `dir MASK`.

use crate::link::piece_words;
use crate::{Arch, AxisMove, Design, HdlError, PieceRegs};
use std::fmt::Write as _;

/// Name of the edge dump the testbench writes in its working directory.
pub const EDGE_FILE: &str = "edges.txt";

/// Bus commands (`ms_core.v`).
pub const CMD_COMMIT: u32 = 0;
pub const CMD_CONTROL: u32 = 1;
pub const CMD_START: u32 = 2;

/// A bus address: `{cmd, axis, word}` (see `ms_core.v`).
pub fn bus_addr(d: &Design, cmd: bool, axis: u32, word: u32) -> u32 {
    (u32::from(cmd) << (d.widths.aw - 1)) | (axis << 5) | word
}

/// The 17 staging words of a piece, as the link loads them.
pub use crate::link::staging_words;

/// Logs the calculators' selects and FIFO writes (hierarchical references into the DUT).
fn calc_log(d: &Design) -> String {
    let cores: Vec<String> = match d.arch {
        Arch::Tdm => vec!["dut.u_core".into()],
        Arch::Independent => (0..d.params.axes)
            .map(|a| format!("dut.u_core{a}"))
            .collect(),
    };
    cores
        .iter()
        .enumerate()
        .map(|(i, c)| {
            format!(
                "        if ({c}.do_sel) $fdisplay(f, \"sel %0d {i}\", cycle);\n\
                 \x20       if ({c}.done) $fdisplay(f, \"push %0d {i}\", cycle);\n"
            )
        })
        .collect()
}

/// The testbench for `moves` (one per axis, all started as one group), stopping after
/// `timeout` cycles at the latest. Checks the moves against the core first. A move of
/// more pieces than the core's slots is loaded while it runs ([`AxisMove::rolling`]): its
/// first pieces before the start, then piece i into slot i mod slots once the axis has
/// made the STEP rises of piece i − slots, the control word naming that slot the last.
pub fn testbench(d: &Design, moves: &[AxisMove], timeout: u64) -> Result<String, HdlError> {
    let k = d.params.axes;
    if moves.len() != k as usize {
        return Err(HdlError::Sim(format!(
            "{} moves for a core of {k} axes",
            moves.len()
        )));
    }
    let slots = d.params.pieces as usize;
    for m in moves {
        if m.pieces.len() > slots {
            m.check_rolling(&d.params)?;
        } else {
            m.check(&d.params)?;
        }
    }
    let aw = d.widths.aw;
    let mut s = String::new();
    let _ = write!(
        s,
        "`timescale 1ns/1ps\n\
         module tb;\n\
         \x20   reg clk = 1'b0;\n\
         \x20   always #5 clk = ~clk;\n\
         \x20   reg wr_en = 1'b0;\n\
         \x20   reg [{aw1}:0] wr_addr = 0;\n\
         \x20   reg [31:0] wr_data = 0;\n\
         \x20   wire go;\n\
         \x20   wire [{k1}:0] step, dir, busy, underrun;\n\
         \x20   {top} dut (.clk(clk), .wr_en(wr_en), .wr_addr(wr_addr), .wr_data(wr_data),\n\
         \x20       .go(go), .step(step), .dir(dir), .busy(busy), .underrun(underrun));\n\
         \x20   integer f, a, tick, cycles;\n\
         \x20   integer rises [0:{k1}];   // STEP rises of each axis so far\n\
         \x20   integer cycle = 0;\n\
         \x20   reg going = 1'b0;\n\
         \x20   reg [{k1}:0] prev = 0;\n\
         \x20   // DUT registers update after this block reads them (nonblocking), so `go`,\n\
         \x20   // `step` and the strobes are the values of the cycle that just ended.\n\
         \x20   always @(posedge clk) begin\n\
         {calc_log}\
         \x20       if (going) tick = tick + 1;\n\
         \x20       if (go && !going) $fdisplay(f, \"go %0d\", cycle);\n\
         \x20       if (go) begin going = 1'b1; tick = 0; end\n\
         \x20       for (a = 0; a < {k}; a = a + 1)\n\
         \x20           if (step[a] != prev[a]) begin\n\
         \x20               $fdisplay(f, \"%0s %0d %0d\", step[a] ? \"rise\" : \"fall\", tick - 1, a);\n\
         \x20               if (step[a]) rises[a] = rises[a] + 1;\n\
         \x20           end\n\
         \x20       prev = step;\n\
         \x20       cycle = cycle + 1;\n\
         \x20   end\n\
         \x20   task wr(input [{aw1}:0] ad, input [31:0] da);\n\
         \x20       begin\n\
         \x20           @(negedge clk); wr_en = 1'b1; wr_addr = ad; wr_data = da;\n\
         \x20           @(negedge clk); wr_en = 1'b0;\n\
         \x20       end\n\
         \x20   endtask\n\
         \x20   initial begin\n\
         \x20       f = $fopen(\"{EDGE_FILE}\");\n\
         \x20       for (a = 0; a < {k}; a = a + 1) rises[a] = 0;\n",
        aw1 = aw - 1,
        k1 = k - 1,
        top = d.arch.top(),
        calc_log = calc_log(d),
    );
    for (a, m) in moves.iter().enumerate() {
        let loaded = m.pieces.len().min(slots);
        for i in 0..loaded {
            piece_lines(&mut s, d, a as u32, &m.pieces[i], i);
        }
        control_line(&mut s, d, a as u32, m.dir, loaded - 1);
    }
    let mask: u64 = (1u64 << k) - 1;
    let _ = write!(
        s,
        "        $fdisplay(f, \"start %0d\", cycle);\n\
         \x20       wr({}, 32'd{mask});\n\
         \x20       cycles = 0;\n",
        bus_addr(d, true, 0, CMD_START)
    );
    // the roll: piece i once piece i - slots is done, in the order those pieces end
    let mut roll: Vec<(u64, usize, usize, u64)> = Vec::new();
    for (a, m) in moves.iter().enumerate() {
        for (i, done) in m.late_pieces(slots) {
            let freed = &m.pieces[i - slots];
            roll.push((freed.t0 + freed.dur, a, i, done));
        }
    }
    roll.sort_unstable();
    for (_, a, i, done) in roll {
        let _ = writeln!(
            s,
            "        while (rises[{a}] < {done} && cycles < {timeout}) begin\n\
             \x20           @(posedge clk); cycles = cycles + 1;\n\
             \x20       end"
        );
        piece_lines(&mut s, d, a as u32, &moves[a].pieces[i], i);
        control_line(&mut s, d, a as u32, moves[a].dir, i);
    }
    let _ = write!(
        s,
        "        cycles = 0;\n\
         \x20       while ((!going || busy != 0) && cycles < {timeout}) begin\n\
         \x20           @(posedge clk); cycles = cycles + 1;\n\
         \x20       end\n\
         \x20       @(posedge clk); @(posedge clk);  // record the last STEP fall\n\
         \x20       if (cycles >= {timeout}) $fdisplay(f, \"timeout\");\n\
         \x20       $fdisplay(f, \"underrun %0d\", underrun);\n\
         \x20       $fdisplay(f, \"dir %0d\", dir);\n\
         \x20       $fclose(f);\n\
         \x20       $finish;\n\
         \x20   end\n\
         endmodule\n"
    );
    Ok(s)
}

/// The bus writes of piece `i` (`pc`) of `axis` into slot i mod slots.
fn piece_lines(s: &mut String, d: &Design, axis: u32, pc: &PieceRegs, i: usize) {
    for (word, v) in piece_words(&d.widths, pc).into_iter().enumerate() {
        let _ = writeln!(
            s,
            "        wr({}, 32'd{v});",
            bus_addr(d, false, axis, word as u32)
        );
    }
    let slot = i % d.params.pieces as usize;
    let _ = writeln!(
        s,
        "        wr({}, 32'd{slot});",
        bus_addr(d, true, axis, CMD_COMMIT)
    );
}

/// The axis control word: DIR, and the slot of piece `last` as the move's last.
fn control_line(s: &mut String, d: &Design, axis: u32, dir: bool, last: usize) {
    let ctl = (u32::from(dir) << 31) | (last % d.params.pieces as usize) as u32;
    let _ = writeln!(
        s,
        "        wr({}, 32'd{ctl});",
        bus_addr(d, true, axis, CMD_CONTROL)
    );
}
