//! Testbench generator: loads moves through the register bus, starts them as one group
//! and writes every STEP edge as `rise|fall tick axis` (tick 0 = the group's `go`), then
//! `underrun MASK`, `dir MASK` and `calc BUSY_CYCLES STARTS`.

use crate::{AxisMove, Design, HdlError};
use std::fmt::Write as _;

/// Name of the edge dump the testbench writes in its working directory.
pub const EDGE_FILE: &str = "edges.txt";

/// A bus address: `{glob, axis, seg, field}` (see `ms_core.v`).
pub fn bus_addr(d: &Design, glob: bool, axis: u32, seg: u32, field: u32) -> u32 {
    let w = &d.widths;
    (u32::from(glob) << (w.aw - 1)) | (axis << (w.ls + 2)) | (seg << 2) | field
}

/// Counts the calculators' busy cycles and starts (hierarchical references into the DUT).
fn calc_counters(d: &Design) -> String {
    let cores: Vec<String> = match d.arch {
        crate::Arch::Tdm => vec!["dut.u_core".into()],
        crate::Arch::Independent => (0..d.params.axes)
            .map(|a| format!("dut.u_core{a}"))
            .collect(),
    };
    cores
        .iter()
        .map(|c| {
            format!(
                "        if ({c}.u_calc.busy) calc_busy = calc_busy + 1;\n\
                 \x20       if ({c}.calc_go) calc_starts = calc_starts + 1;\n"
            )
        })
        .collect()
}

/// The testbench for `moves` (one per axis, all started as one group), stopping after
/// `timeout` cycles at the latest. Checks the moves against the core first.
pub fn testbench(d: &Design, moves: &[AxisMove], timeout: u64) -> Result<String, HdlError> {
    let k = d.params.axes;
    if moves.len() != k as usize {
        return Err(HdlError::Sim(format!(
            "{} moves for a core of {k} axes",
            moves.len()
        )));
    }
    for m in moves {
        m.check(&d.params)?;
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
         \x20   integer calc_busy = 0, calc_starts = 0;\n\
         \x20   always @(posedge clk) begin\n\
         {calc_count}\
         \x20   end\n\
         \x20   reg going = 1'b0;\n\
         \x20   reg [{k1}:0] prev = 0;\n\
         \x20   // DUT registers update after this block reads them (nonblocking), so `go` and\n\
         \x20   // `step` are the values of the cycle that just ended.\n\
         \x20   always @(posedge clk) begin\n\
         \x20       if (going) tick = tick + 1;\n\
         \x20       if (go) begin going = 1'b1; tick = 0; end\n\
         \x20       for (a = 0; a < {k}; a = a + 1)\n\
         \x20           if (step[a] != prev[a])\n\
         \x20               $fdisplay(f, \"%0s %0d %0d\", step[a] ? \"rise\" : \"fall\", tick - 1, a);\n\
         \x20       prev = step;\n\
         \x20   end\n\
         \x20   task wr(input [{aw1}:0] ad, input [31:0] da);\n\
         \x20       begin\n\
         \x20           @(negedge clk); wr_en = 1'b1; wr_addr = ad; wr_data = da;\n\
         \x20           @(negedge clk); wr_en = 1'b0;\n\
         \x20       end\n\
         \x20   endtask\n\
         \x20   initial begin\n\
         \x20       f = $fopen(\"{EDGE_FILE}\");\n",
        aw1 = aw - 1,
        k1 = k - 1,
        top = d.arch.top(),
        calc_count = calc_counters(d),
    );
    for (a, m) in moves.iter().enumerate() {
        let a = a as u32;
        for (j, seg) in m.segs.iter().enumerate() {
            let j = j as u32;
            for (field, v) in [(0, seg.n), (1, seg.d), (2, seg.s)] {
                let _ = writeln!(
                    s,
                    "        wr({}, 32'd{v});",
                    bus_addr(d, false, a, j, field)
                );
            }
        }
        let ctl = (u32::from(m.dir) << 31) | (m.segs.len() as u32 - 1);
        let _ = writeln!(s, "        wr({}, 32'd{ctl});", bus_addr(d, false, a, 0, 3));
    }
    let mask: u64 = (1u64 << k) - 1;
    let _ = write!(
        s,
        "        wr({}, 32'd{mask});\n\
         \x20       cycles = 0;\n\
         \x20       while ((!going || busy != 0) && cycles < {timeout}) begin\n\
         \x20           @(posedge clk); cycles = cycles + 1;\n\
         \x20       end\n\
         \x20       @(posedge clk); @(posedge clk);  // record the last STEP fall\n\
         \x20       if (cycles >= {timeout}) $fdisplay(f, \"timeout\");\n\
         \x20       $fdisplay(f, \"underrun %0d\", underrun);\n\
         \x20       $fdisplay(f, \"dir %0d\", dir);\n\
         \x20       $fdisplay(f, \"calc %0d %0d\", calc_busy, calc_starts);\n\
         \x20       $fclose(f);\n\
         \x20       $finish;\n\
         \x20   end\n\
         endmodule\n",
        bus_addr(d, true, 0, 0, 0)
    );
    Ok(s)
}
