//! Co-simulation of the whole board (`ms_board`, UART included) in Verilator or Icarus
//! Verilog ([`Simulator`]). A [`Script`] is what the host and the world do: bytes on
//! `uart_rx` at the host's own bit time (not the board's rounded one), waits, Hall / limit
//! / e-stop / reset pin changes.
//! The testbench logs every pin change with its clock cycle, every byte the board sends,
//! every group start (`go`) and start write, and every accepted Hall edge ([`BoardLog`]).

use crate::link::{LinkError, Reply, ReplyDecoder, Request};
use crate::simulator::Simulator;
use crate::tools::run;
use crate::{BoardTop, HdlError};
use std::fmt::Write as _;
use std::path::Path;

/// The script file the testbench reads, and the log it writes.
pub const SCRIPT_FILE: &str = "script.txt";
pub const LOG_FILE: &str = "board.txt";

/// What the host and the world do, in order.
#[derive(Clone, Debug, Default)]
pub struct Script {
    lines: Vec<String>,
    /// Reply bytes expected so far (each request gets one reply).
    replies: u64,
    /// The host's baud (default: the board's nominal baud).
    pub host_baud: Option<f64>,
}

impl Script {
    pub fn new() -> Self {
        Self::default()
    }

    /// Sends raw bytes (no reply counted).
    pub fn bytes(&mut self, b: &[u8]) -> &mut Self {
        for x in b {
            self.lines.push(format!("b {x} 0"));
        }
        self
    }

    /// Sends a request (one reply expected).
    pub fn send(&mut self, r: &Request) -> &mut Self {
        self.bytes(&r.encode());
        self.replies += 1;
        self
    }

    /// Sends a bulk write (one reply expected).
    pub fn send_bulk(&mut self, w: &crate::link::BulkWrite) -> Result<&mut Self, HdlError> {
        let f = w.encode().map_err(|e| HdlError::Param(e.to_string()))?;
        self.bytes(&f);
        self.replies += 1;
        Ok(self)
    }

    /// Waits for the group start (`go`) of the last start write, then until `ticks` clocks
    /// after it: the move's tick.
    pub fn at_move_tick(&mut self, ticks: u64) -> &mut Self {
        self.lines.push(format!("g {ticks} 0"));
        self
    }

    /// Sends requests back to back.
    pub fn send_all(&mut self, rs: &[Request]) -> &mut Self {
        for r in rs {
            self.send(r);
        }
        self
    }

    /// Counts a reply for a frame sent with [`Script::bytes`] that the board answers.
    pub fn expect_reply(&mut self) -> &mut Self {
        self.replies += 1;
        self
    }

    /// Waits until every reply so far has arrived.
    pub fn sync(&mut self) -> &mut Self {
        let n = self.replies * crate::link::REPLY_LEN as u64;
        self.lines.push(format!("q {n} 0"));
        self
    }

    /// Waits `n` clock cycles.
    pub fn wait(&mut self, n: u64) -> &mut Self {
        self.lines.push(format!("w {n} 0"));
        self
    }

    /// Waits until no axis is busy and no group is pending.
    pub fn idle(&mut self) -> &mut Self {
        self.lines.push("i 0 0".into());
        self
    }

    /// Waits for `n` more STEP rises on `axis` (as the pin shows them, any level).
    pub fn steps(&mut self, axis: u32, n: u64) -> &mut Self {
        self.lines.push(format!("p {axis} {n}"));
        self
    }

    pub fn hall(&mut self, axis: u32, level: bool) -> &mut Self {
        self.lines.push(format!("h {axis} {}", u8::from(level)));
        self
    }

    pub fn limit(&mut self, axis: u32, level: bool) -> &mut Self {
        self.lines.push(format!("l {axis} {}", u8::from(level)));
        self
    }

    pub fn estop(&mut self, level: bool) -> &mut Self {
        self.lines.push(format!("e {} 0", u8::from(level)));
        self
    }

    /// Drives rst_n_async.
    pub fn reset_n(&mut self, level: bool) -> &mut Self {
        self.lines.push(format!("n {} 0", u8::from(level)));
        self
    }

    /// Waits `ns` nanoseconds (not aligned to the clock).
    pub fn delay_ns(&mut self, ns: u64) -> &mut Self {
        self.lines.push(format!("t {ns} 0"));
        self
    }

    /// Writes `mark ID CYCLE` to the log.
    pub fn mark(&mut self, id: u32) -> &mut Self {
        self.lines.push(format!("k {id} 0"));
        self
    }

    fn text(&self) -> String {
        let mut s = self.lines.join("\n");
        s.push_str("\nx 0 0\n");
        s
    }
}

/// A pin change: the clock edge (counted from 0) after which the pin has its new level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinEvent {
    pub cycle: u64,
    pub level: bool,
}

/// What the testbench saw.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BoardLog {
    /// Per axis: STEP, DIR and ENABLE pin changes.
    pub step: Vec<Vec<PinEvent>>,
    pub dir: Vec<Vec<PinEvent>>,
    pub enable: Vec<Vec<PinEvent>>,
    /// Cycles of every group start (`go`) and of every start write the core took.
    pub go: Vec<u64>,
    pub start: Vec<u64>,
    /// Cycles at which the board executed a request (in order).
    pub reqs: Vec<u64>,
    /// Per axis: the synchronized Hall and limit inputs' changes.
    pub hall_sync: Vec<Vec<PinEvent>>,
    pub limit_sync: Vec<Vec<PinEvent>>,
    /// Per axis: cycles at which a Hall edge was accepted (the position is latched at
    /// that clock edge).
    pub hall_accept: Vec<Vec<u64>>,
    /// Bytes the board sent, with the cycle each one's stop bit ended.
    pub tx: Vec<(u64, u8)>,
    /// (id, cycle) of the script's marks.
    pub marks: Vec<(u32, u64)>,
    /// Initial levels of the STEP pins (bit per axis).
    pub step0: u64,
    /// E-stop input changes (level, ns) and, while it is active, STEP pin changes
    /// (levels as a mask, ns).
    pub estop_ns: Vec<(bool, u64)>,
    pub step_during_estop_ns: Vec<(u64, u64)>,
    pub end_cycle: u64,
}

impl BoardLog {
    /// The replies in the board's byte stream (errors for frames that did not decode).
    pub fn replies(&self) -> Vec<Result<Reply, LinkError>> {
        let bytes: Vec<u8> = self.tx.iter().map(|t| t.1).collect();
        ReplyDecoder::new().push(&bytes)
    }

    /// Cycles at which STEP of `axis` went to its active level `active`.
    pub fn rises(&self, axis: usize, active: bool) -> Vec<u64> {
        self.step[axis]
            .iter()
            .filter(|e| e.level == active)
            .map(|e| e.cycle)
            .collect()
    }

    pub fn mark(&self, id: u32) -> Option<u64> {
        self.marks.iter().find(|m| m.0 == id).map(|m| m.1)
    }
}

/// The testbench; its timeout (`+timeout=`, clocks) and the host's bit time
/// (`+host_bit_ps=`) are plusargs, so one compiled testbench serves every script. Every
/// wait of the script ends 1 ps after a rising clock edge: the clock process has counted
/// the edge, and an input the host changes next is not sampled at that edge, in any
/// simulator.
fn testbench(b: &BoardTop) -> Result<String, HdlError> {
    let params = b.verilog_params()?;
    let k = b.core.axes;
    let clk_ns = 1e9 / b.core.clock_hz;
    let board_bit = f64::from(b.div()) * clk_ns;
    let estop_idle = u8::from(!b.estop_active_high);
    let estop_act = u8::from(b.estop_active_high);
    let mut s = String::new();
    let _ = write!(
        s,
        "`timescale 1ns/1ps
module tb;
    reg clk = 1'b0;
    always #({half}) clk = ~clk;
    reg rst_n = 1'b1, rx = 1'b1, estop = 1'b{estop_idle};
    reg [{k1}:0] hall = 0, limit = 0;
    wire tx;
    wire [{k1}:0] step, dir, en;
    wire [3:0] led;
    ms_board {params} dut (.clk(clk), .rst_n_async(rst_n), .uart_rx(rx), .uart_tx(tx),
        .estop_in(estop), .hall_in(hall), .limit_in(limit), .step_out(step), .dir_out(dir),
        .enable_out(en), .led(led), .sync_in(1'b1), .sync_oe());
    integer f, fs, r, a, cycle = 0, nrx = 0, i, c_a, c_b, t0, gocycle = 0, startcycle = -1;
    reg [63:0] timeout;
    reg [63:0] host_ps;
    real host_bit;
    reg [8*8-1:0] cmd;
    reg [{k1}:0] pstep, pdir, pen, phs, pls;
    reg [7:0] rb;
    integer nrise [0:{k1}];
    reg logging = 1'b0;   // pins are logged from the end of the power-on reset
    wire [{k1}:0] accept;
    genvar g;
    generate for (g = 0; g < {k}; g = g + 1) begin : acc
        assign accept[g] = dut.axis[g].u_io.accept;
    end endgenerate
    // pins are sampled just before each rising edge: `cycle` is the edge they changed after
    always @(posedge clk) begin
        if (dut.go) begin
            $fdisplay(f, \"go %0d\", cycle);
            gocycle = cycle;
        end
        if (dut.u_core.start_wr) begin
            $fdisplay(f, \"start %0d\", cycle);
            startcycle = cycle;
        end
        if (dut.req) $fdisplay(f, \"req %0d\", cycle);
        for (a = 0; a < {k}; a = a + 1) begin
            if (accept[a]) $fdisplay(f, \"hall %0d %0d\", a, cycle);
            if (logging && step[a] !== pstep[a]) begin
                $fdisplay(f, \"s %0d %0d %0d\", a, step[a], cycle - 1);
                nrise[a] = nrise[a] + 1;
            end
            if (logging && dir[a] !== pdir[a]) $fdisplay(f, \"d %0d %0d %0d\", a, dir[a], cycle - 1);
            if (logging && en[a] !== pen[a]) $fdisplay(f, \"n %0d %0d %0d\", a, en[a], cycle - 1);
            if (logging && dut.hall_s[a] !== phs[a]) $fdisplay(f, \"hs %0d %0d %0d\", a, dut.hall_s[a], cycle - 1);
            if (logging && dut.limit_s[a] !== pls[a]) $fdisplay(f, \"ls %0d %0d %0d\", a, dut.limit_s[a], cycle - 1);
        end
        pstep = step; pdir = dir; pen = en; phs = dut.hall_s; pls = dut.limit_s;
        cycle = cycle + 1;
        if (cycle > timeout) begin
            $fdisplay(f, \"timeout %0d\", cycle);
            $fclose(f);
            $finish;
        end
    end
    // the e-stop gate is combinational: while the e-stop input is active, log STEP
    // changes at the time they happen (ns), not at the next clock edge
    always @(estop) $fdisplay(f, \"ex %0d %0d\", estop, $time);
    always @(step) if (estop == 1'b{estop_act}) $fdisplay(f, \"sx %0d %0d\", step, $time);
    // the host's UART receiver: one byte per start bit, sampled at the middles
    always @(negedge tx) begin
        #({board_bit} * 1.5);
        for (i = 0; i < 8; i = i + 1) begin
            rb[i] = tx;
            #({board_bit});
        end
        $fdisplay(f, \"t %0d %0d\", rb, cycle);
        nrx = nrx + 1;
    end
    // the next rising edge, and 1 ps after it
    task edge_after;
        begin
            @(posedge clk);
            #0.001;
        end
    endtask
    task send(input [7:0] v);
        integer j;
        begin
            rx = 1'b0;
            #(host_bit);
            for (j = 0; j < 8; j = j + 1) begin
                rx = v[j];
                #(host_bit);
            end
            rx = 1'b1;
            #(host_bit);
        end
    endtask
    initial begin
        if (!$value$plusargs(\"timeout=%d\", timeout)) timeout = 0;
        if (!$value$plusargs(\"host_bit_ps=%d\", host_ps)) host_ps = 1000;
        host_bit = host_ps / 1000.0;
        f = $fopen(\"{LOG_FILE}\");
        fs = $fopen(\"{SCRIPT_FILE}\", \"r\");
        pstep = step; pdir = dir; pen = en;
        for (a = 0; a < {k}; a = a + 1) nrise[a] = 0;
        // the power-on reset: bytes sent before it ends are lost, as on the board
        repeat (64) edge_after;
        $fdisplay(f, \"init %0d %0d %0d\", step, dir, en);
        logging = 1'b1;
        r = $fscanf(fs, \"%s %d %d\\n\", cmd, c_a, c_b);
        while (r == 3 && cmd != \"x\") begin
            case (cmd)
                \"b\": send(c_a[7:0]);
                \"w\": repeat (c_a) edge_after;
                \"t\": #(c_a);
                // the go of the last start write (a chained group goes once its chains
                // have filled their FIFOs), then its tick
                \"g\": begin
                    while (gocycle <= startcycle) edge_after;
                    while (cycle < gocycle + c_a) edge_after;
                end
                \"q\": while (nrx < c_a) edge_after;
                \"i\": begin
                    edge_after;
                    while (dut.busy != 0 || dut.pending) edge_after;
                end
                \"p\": begin
                    t0 = nrise[c_a] + 2 * c_b;
                    while (nrise[c_a] < t0) edge_after;
                end
                // inputs change at a falling clock edge: no race with the sampling edge
                \"h\": begin @(negedge clk); hall[c_a] = c_b[0]; end
                \"l\": begin @(negedge clk); limit[c_a] = c_b[0]; end
                \"e\": estop = c_a[0];
                \"n\": begin @(negedge clk); rst_n = c_a[0]; end
                \"k\": $fdisplay(f, \"mark %0d %0d\", c_a, cycle);
                default: begin $fdisplay(f, \"badscript\"); end
            endcase
            r = $fscanf(fs, \"%s %d %d\\n\", cmd, c_a, c_b);
        end
        repeat (4 * {div} * 10) edge_after;
        $fdisplay(f, \"end %0d\", cycle);
        $fclose(f);
        $finish;
    end
endmodule
",
        half = clk_ns / 2.0,
        k1 = k - 1,
        div = b.div(),
    );
    Ok(s)
}

/// Runs `script` on the board inside `dir` in the simulator `MULTISTEP_SIM` names
/// (Verilator by default); stops after `timeout` cycles at the latest (an error).
pub fn simulate(
    b: &BoardTop,
    script: &Script,
    dir: &Path,
    timeout: u64,
) -> Result<BoardLog, HdlError> {
    simulate_with(Simulator::from_env()?, b, script, dir, timeout)
}

/// [`simulate`] in the simulator `sim`.
pub fn simulate_with(
    sim: Simulator,
    b: &BoardTop,
    script: &Script,
    dir: &Path,
    timeout: u64,
) -> Result<BoardLog, HdlError> {
    let host_baud = script.host_baud.unwrap_or(f64::from(b.baud));
    if !(host_baud.is_finite() && host_baud >= 1.0) {
        return Err(HdlError::Param(format!(
            "host baud {host_baud} is not a rate"
        )));
    }
    let mut files = b.files()?;
    files.push(("tb.v".into(), testbench(b)?));
    files.push((SCRIPT_FILE.into(), script.text()));
    let plusargs = [
        format!("timeout={timeout}"),
        format!("host_bit_ps={}", (1e12 / host_baud).round() as u64),
    ];
    let text = sim.run(dir, &files, LOG_FILE, &plusargs)?;
    parse(&text, b.core.axes as usize)
}

fn parse(text: &str, k: usize) -> Result<BoardLog, HdlError> {
    let mut log = BoardLog {
        step: vec![Vec::new(); k],
        dir: vec![Vec::new(); k],
        enable: vec![Vec::new(); k],
        hall_accept: vec![Vec::new(); k],
        hall_sync: vec![Vec::new(); k],
        limit_sync: vec![Vec::new(); k],
        ..Default::default()
    };
    let bad = |line: &str| HdlError::Sim(format!("unexpected testbench line {line:?}"));
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        let num = |i: usize| -> Result<u64, HdlError> {
            w.get(i)
                .and_then(|x| x.parse().ok())
                .ok_or_else(|| bad(line))
        };
        match w.first().copied() {
            Some("timeout") => {
                return Err(HdlError::Sim(format!(
                    "testbench timed out at cycle {}",
                    num(1)?
                )))
            }
            Some("badscript") => return Err(HdlError::Sim("bad script line".into())),
            Some("init") => log.step0 = num(1)?,
            Some("ex") => log.estop_ns.push((num(1)? == 1, num(2)?)),
            Some("sx") => log.step_during_estop_ns.push((num(1)?, num(2)?)),
            Some("go") => log.go.push(num(1)?),
            Some("start") => log.start.push(num(1)?),
            Some("req") => log.reqs.push(num(1)?),
            Some("end") => log.end_cycle = num(1)?,
            Some("mark") => log.marks.push((num(1)? as u32, num(2)?)),
            Some("t") => log.tx.push((num(2)?, num(1)? as u8)),
            Some("hall") => {
                let a = num(1)? as usize;
                log.hall_accept
                    .get_mut(a)
                    .ok_or_else(|| bad(line))?
                    .push(num(2)?);
            }
            Some(p @ ("s" | "d" | "n" | "hs" | "ls")) => {
                let a = num(1)? as usize;
                let ev = PinEvent {
                    level: num(2)? == 1,
                    cycle: num(3)?,
                };
                let list = match p {
                    "s" => &mut log.step,
                    "d" => &mut log.dir,
                    "n" => &mut log.enable,
                    "hs" => &mut log.hall_sync,
                    _ => &mut log.limit_sync,
                };
                list.get_mut(a).ok_or_else(|| bad(line))?.push(ev);
            }
            _ => return Err(bad(line)),
        }
    }
    Ok(log)
}

/// `verilator --lint-only -Wall` on `ms_board` with these parameters; any warning is an
/// error.
pub fn lint(b: &BoardTop, dir: &Path) -> Result<(), HdlError> {
    std::fs::create_dir_all(dir).map_err(|e| HdlError::io(dir, e))?;
    let mut args = vec![
        "--lint-only".to_string(),
        "-Wall".into(),
        "--top-module".into(),
        "ms_board_lint".into(),
        "ms_board_lint.v".into(),
    ];
    // a wrapper with the parameters as literals, as a board wrapper instantiates it
    let k1 = b.core.axes - 1;
    let wrapper = format!(
        "module ms_board_lint (\n\
         \x20   input wire clk, input wire rst_n_async, input wire uart_rx, output wire uart_tx,\n\
         \x20   input wire estop_in, input wire [{k1}:0] hall_in, input wire [{k1}:0] limit_in,\n\
         \x20   output wire [{k1}:0] step_out, output wire [{k1}:0] dir_out,\n\
         \x20   output wire [{k1}:0] enable_out, output wire [3:0] led,\n\
         \x20   input wire sync_in, output wire sync_oe);\n\
         \x20   ms_board {} u (.clk(clk), .rst_n_async(rst_n_async), .uart_rx(uart_rx),\n\
         \x20       .uart_tx(uart_tx), .estop_in(estop_in), .hall_in(hall_in), .limit_in(limit_in),\n\
         \x20       .step_out(step_out), .dir_out(dir_out), .enable_out(enable_out), .led(led),\n\
         \x20       .sync_in(sync_in), .sync_oe(sync_oe));\n\
         endmodule\n",
        b.verilog_params()?
    );
    let wp = dir.join("ms_board_lint.v");
    std::fs::write(&wp, wrapper).map_err(|e| HdlError::io(&wp, e))?;
    for (name, text) in b.files()? {
        let p = dir.join(&name);
        std::fs::write(&p, text).map_err(|e| HdlError::io(&p, e))?;
        args.push(name);
    }
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = run("verilator", "verilator", &args, dir)?;
    let text = String::from_utf8_lossy(&out.stderr);
    if text.contains("%Warning") || text.contains("%Error") {
        return Err(HdlError::ToolFailed {
            tool: "verilator",
            detail: text.into_owned(),
        });
    }
    Ok(())
}
