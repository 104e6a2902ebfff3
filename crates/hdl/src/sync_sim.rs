//! Several boards (`ms_board`) in one Icarus Verilog testbench, each on its own clock
//! (period and power-up instant), their SYNC pins wired together as an open-drain line with
//! a pull-up: the cross-board group start (docs/HDL.md, "Cross-board start"). The host
//! talks to each board over its own UART; the testbench logs times in picoseconds: every
//! STEP change, every group start (`go`, with the board's free-running count), every fall
//! of the SYNC line (with every board's count at that instant).

use crate::link::{LinkError, Reply, ReplyDecoder, Request};
use crate::tools::icarus;
use crate::{BoardTop, HdlError};
use std::fmt::Write as _;
use std::path::Path;

/// One board's clock in the testbench: the clock starts low at `start_ps` and toggles
/// every `period_ps / 2` (its first rising edge is at `start_ps + period_ps / 2`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimClock {
    /// Even, at least 2.
    pub period_ps: u64,
    pub start_ps: u64,
}

impl SimClock {
    /// Rising edges in (0, t]: the board's free-running count at time t (between edges).
    pub fn edges_by(&self, t_ps: u64) -> u64 {
        let first = self.start_ps + self.period_ps / 2;
        if t_ps < first {
            0
        } else {
            (t_ps - first) / self.period_ps + 1
        }
    }
}

/// What the host does, in order, to which board.
#[derive(Clone, Debug, Default)]
pub struct MultiScript {
    lines: Vec<String>,
    replies: Vec<u64>,
}

impl MultiScript {
    pub fn new(boards: usize) -> Self {
        MultiScript {
            lines: Vec::new(),
            replies: vec![0; boards],
        }
    }

    /// Sends a request to `board` (one reply expected); requests to one board go back to
    /// back, to different boards one after the other.
    pub fn send(&mut self, board: usize, r: &Request) -> &mut Self {
        for x in r.encode() {
            self.lines.push(format!("b {board} {x}"));
        }
        if let Some(n) = self.replies.get_mut(board) {
            *n += 1;
        }
        self
    }

    /// Waits until every reply so far has arrived, from every board.
    pub fn sync(&mut self) -> &mut Self {
        for (b, n) in self.replies.iter().enumerate() {
            let bytes = n * crate::link::REPLY_LEN as u64;
            self.lines.push(format!("q {b} {bytes}"));
        }
        self
    }

    /// Waits until `board` has no busy axis and no pending group.
    pub fn idle(&mut self, board: usize) -> &mut Self {
        self.lines.push(format!("i {board} 0"));
        self
    }

    /// Waits `ns` nanoseconds.
    pub fn delay_ns(&mut self, ns: u64) -> &mut Self {
        self.lines.push(format!("t {ns} 0"));
        self
    }

    fn text(&self) -> String {
        let mut s = self.lines.join("\n");
        s.push_str("\nx 0 0\n");
        s
    }
}

/// A group start on one board: its time and the board's free-running count at that clock
/// edge (before the edge's increment).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GoEvent {
    pub ps: u64,
    pub free: u64,
}

/// What the testbench saw, per board.
#[derive(Clone, Debug, Default)]
pub struct MultiLog {
    /// [board][axis]: STEP pin changes (ps, level).
    pub step: Vec<Vec<Vec<(u64, bool)>>>,
    pub go: Vec<Vec<GoEvent>>,
    /// [board]: the bytes the board sent.
    pub tx: Vec<Vec<u8>>,
    /// Falls of the SYNC line: (ps, every board's free-running count at that instant).
    pub sync_falls: Vec<(u64, Vec<u64>)>,
}

impl MultiLog {
    pub fn replies(&self, board: usize) -> Vec<Result<Reply, LinkError>> {
        ReplyDecoder::new().push(self.tx.get(board).map_or(&[][..], |v| v))
    }

    /// Times (ps) at which STEP of `axis` on `board` went high.
    pub fn rises(&self, board: usize, axis: usize) -> Vec<u64> {
        self.step
            .get(board)
            .and_then(|b| b.get(axis))
            .map_or_else(Vec::new, |v| {
                v.iter().filter(|e| e.1).map(|e| e.0).collect()
            })
    }
}

fn testbench(boards: &[(BoardTop, SimClock)], timeout_ps: u64) -> Result<String, HdlError> {
    let n = boards.len();
    let mut s = String::from("`timescale 1ps/1ps\nmodule tb;\n");
    let _ = writeln!(s, "    reg [{}:0] rx = {{{n}{{1'b1}}}};", n - 1);
    let _ = writeln!(s, "    wire [{}:0] oe;", n - 1);
    s.push_str("    // open drain with a pull-up: low while any board drives it\n");
    s.push_str("    wire sync_line = ~(|oe);\n");
    s.push_str("    reg logging = 1'b0;\n    integer f, fs, r, c_a, c_b, i, j;\n");
    s.push_str("    reg [8*8-1:0] cmd;\n");
    let _ = writeln!(s, "    integer nrx [0:{}];", n - 1);
    let mut host_bits = Vec::new();
    for (i, (b, c)) in boards.iter().enumerate() {
        if c.period_ps < 2 || c.period_ps % 2 != 0 {
            return Err(HdlError::Param(format!(
                "board {i}: the clock period must be even and at least 2 ps, got {}",
                c.period_ps
            )));
        }
        let k1 = b.core.axes - 1;
        let board_bit = u64::from(b.div()) * c.period_ps;
        host_bits.push(1e12 / f64::from(b.baud));
        let _ = write!(
            s,
            "    // ---- board {i} ----
    reg clk{i} = 1'b0;
    initial begin #({start}); forever #({half}) clk{i} = ~clk{i}; end
    wire tx{i};
    wire [{k1}:0] step{i}, dir{i}, en{i};
    wire [3:0] led{i};
    reg [{k1}:0] zero{i} = 0;
    ms_board {params} dut{i} (.clk(clk{i}), .rst_n_async(1'b1), .uart_rx(rx[{i}]),
        .uart_tx(tx{i}), .estop_in(1'b0), .hall_in(zero{i}), .limit_in(zero{i}),
        .step_out(step{i}), .dir_out(dir{i}), .enable_out(en{i}), .led(led{i}),
        .sync_in(sync_line), .sync_oe(oe[{i}]));
    always @(posedge clk{i}) if (dut{i}.go) $fdisplay(f, \"go {i} %0d %0d\", $time, dut{i}.u_regs.free);
    reg [{k1}:0] ps{i};
    always @(step{i}) begin
        if (logging) for (j = 0; j < {k}; j = j + 1)
            if (step{i}[j] !== ps{i}[j]) $fdisplay(f, \"s {i} %0d %0d %0d\", j, step{i}[j], $time);
        ps{i} = step{i};
    end
    reg [7:0] rb{i};
    integer bi{i};
    always @(negedge tx{i}) begin
        #({b15});
        for (bi{i} = 0; bi{i} < 8; bi{i} = bi{i} + 1) begin
            rb{i}[bi{i}] = tx{i};
            #({board_bit});
        end
        $fdisplay(f, \"t {i} %0d\", rb{i});
        nrx[{i}] = nrx[{i}] + 1;
    end
",
            start = c.start_ps,
            half = c.period_ps / 2,
            params = b.verilog_params()?,
            k = b.core.axes,
            b15 = board_bit * 3 / 2,
        );
    }
    let frees: Vec<String> = (0..n).map(|i| format!("dut{i}.u_regs.free")).collect();
    let _ = write!(
        s,
        "    always @(negedge sync_line) if (logging)
        $fdisplay(f, \"sf %0d{fmt}\", $time, {frees});
    task send(input integer bd, input [7:0] v, input integer bit_ps);
        integer k;
        begin
            rx[bd] = 1'b0;
            #(bit_ps);
            for (k = 0; k < 8; k = k + 1) begin
                rx[bd] = v[k];
                #(bit_ps);
            end
            rx[bd] = 1'b1;
            #(bit_ps);
        end
    endtask
    initial begin
        #({timeout_ps});
        $fdisplay(f, \"timeout %0d\", $time);
        $fclose(f);
        $finish;
    end
    initial begin
        f = $fopen(\"{log}\");
        fs = $fopen(\"{script}\", \"r\");
        for (i = 0; i < {n}; i = i + 1) nrx[i] = 0;
        // every board's power-on reset has ended
        #({settle});
        logging = 1'b1;
        r = $fscanf(fs, \"%s %d %d\\n\", cmd, c_a, c_b);
        while (r == 3 && cmd != \"x\") begin
            case (cmd)
                \"b\": begin
{send_cases}                end
                \"q\": while (nrx[c_a] < c_b) #(1000);
                \"t\": #(c_a * 1000);
                \"i\": begin
{idle_cases}                end
                default: $fdisplay(f, \"badscript\");
            endcase
            r = $fscanf(fs, \"%s %d %d\\n\", cmd, c_a, c_b);
        end
        #({tail});
        $fdisplay(f, \"end %0d\", $time);
        $fclose(f);
        $finish;
    end
endmodule
",
        fmt = " %0d".repeat(n),
        frees = frees.join(", "),
        log = LOG_FILE,
        script = SCRIPT_FILE,
        settle = boards
            .iter()
            .map(|(_, c)| c.start_ps + 64 * c.period_ps)
            .max()
            .unwrap_or(0),
        tail = boards
            .iter()
            .map(|(b, c)| 40 * u64::from(b.div()) * c.period_ps)
            .max()
            .unwrap_or(0),
        send_cases = (0..n)
            .map(|i| format!(
                "                    if (c_a == {i}) send({i}, c_b[7:0], {});\n",
                host_bits[i].round() as u64
            ))
            .collect::<String>(),
        idle_cases = (0..n)
            .map(|i| format!(
                "                    if (c_a == {i}) begin #(1000); while (dut{i}.busy != 0 || dut{i}.pending) #(1000); end\n"
            ))
            .collect::<String>(),
    );
    Ok(s)
}

const SCRIPT_FILE: &str = "script.txt";
const LOG_FILE: &str = "boards.txt";

/// Runs `script` on `boards` (each with its clock) in Icarus Verilog inside `dir`; stops
/// at `timeout_ps` of simulated time at the latest (an error).
pub fn simulate_boards(
    boards: &[(BoardTop, SimClock)],
    script: &MultiScript,
    dir: &Path,
    timeout_ps: u64,
) -> Result<MultiLog, HdlError> {
    if boards.is_empty() {
        return Err(HdlError::Param("no boards".into()));
    }
    let mut files = boards[0].0.files()?;
    files.push(("tb.v".into(), testbench(boards, timeout_ps)?));
    files.push((SCRIPT_FILE.into(), script.text()));
    let text = icarus(dir, &files, LOG_FILE, &[])?;
    let axes: Vec<usize> = boards.iter().map(|(b, _)| b.core.axes as usize).collect();
    parse(&text, &axes)
}

fn parse(text: &str, axes: &[usize]) -> Result<MultiLog, HdlError> {
    let n = axes.len();
    let mut log = MultiLog {
        step: axes.iter().map(|&k| vec![Vec::new(); k]).collect(),
        go: vec![Vec::new(); n],
        tx: vec![Vec::new(); n],
        sync_falls: Vec::new(),
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
                    "testbench timed out at {} ps",
                    num(1)?
                )))
            }
            Some("badscript") => return Err(HdlError::Sim("bad script line".into())),
            Some("end") => {}
            Some("go") => {
                let b = num(1)? as usize;
                let ev = GoEvent {
                    ps: num(2)?,
                    free: num(3)?,
                };
                log.go.get_mut(b).ok_or_else(|| bad(line))?.push(ev);
            }
            Some("s") => {
                let (b, a) = (num(1)? as usize, num(2)? as usize);
                let ev = (num(4)?, num(3)? == 1);
                log.step
                    .get_mut(b)
                    .and_then(|v| v.get_mut(a))
                    .ok_or_else(|| bad(line))?
                    .push(ev);
            }
            Some("t") => {
                let b = num(1)? as usize;
                let x = num(2)? as u8;
                log.tx.get_mut(b).ok_or_else(|| bad(line))?.push(x);
            }
            Some("sf") => {
                let t = num(1)?;
                let frees = (0..n).map(|i| num(2 + i)).collect::<Result<Vec<_>, _>>()?;
                log.sync_falls.push((t, frees));
            }
            _ => return Err(bad(line)),
        }
    }
    Ok(log)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_by_counts_rising_edges() {
        let c = SimClock {
            period_ps: 20_000,
            start_ps: 5_000,
        };
        // rising edges at 15 000, 35 000, 55 000 ...
        assert_eq!(c.edges_by(14_999), 0);
        assert_eq!(c.edges_by(15_000), 1);
        assert_eq!(c.edges_by(34_999), 1);
        assert_eq!(c.edges_by(55_001), 3);
    }

    #[test]
    fn parse_reads_every_line_kind() {
        let log = parse(
            "go 1 100 7\ns 0 1 1 200\nt 1 90\nsf 50 3 4\nend 300\n",
            &[2, 2],
        )
        .unwrap();
        assert_eq!(log.go[1], vec![GoEvent { ps: 100, free: 7 }]);
        assert_eq!(log.rises(0, 1), vec![200]);
        assert_eq!(log.tx[1], vec![90]);
        assert_eq!(log.sync_falls, vec![(50, vec![3, 4])]);
        assert!(parse("sf 50 3\n", &[2, 2]).is_err());
        assert!(parse("timeout 9\n", &[1]).is_err());
    }
}
