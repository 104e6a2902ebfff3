//! The per-axis forward-difference chain (`rtl/board/ms_chain.v`) in Icarus Verilog against
//! `multistep_core::int::chain` and plan's edges: random scurve and scurve4 moves (phase
//! and limits mode, start and end speeds), every period equal, a busy FIFO stalling it, and
//! a tick a clock when the FIFO has room.

mod common;

use common::{Rng, HZ};
use multistep_core::{edges, Family, LimitsMove, Move, PhaseMove, Profile};
use multistep_hdl::chain::{ChainLayout, CHAIN_LAYOUT};
use multistep_hdl::tools::run;
use std::fmt::Write;

const RTL: &str = include_str!("../rtl/board/ms_chain.v");

/// A testbench feeding `records` (one hex byte a line) to ms_chain, its FIFO full on the
/// clocks where a 16-bit LFSR's low `busy_bits` bits are all ones (none when 0); it logs
/// each push's cycle and period.
fn testbench(layout: &ChainLayout, records: usize, busy_bits: u32, timeout: u64) -> String {
    let bytes = layout.record_bytes();
    let mask = (1u32 << busy_bits) - 1;
    let mut s = String::new();
    writeln!(
        s,
        "`timescale 1ns/1ps
module tb;
    reg clk = 0, rst = 1, init = 0, ld = 0, go = 0;
    reg [7:0] ld_byte = 0;
    reg [7:0] mem [0:{total}];
    reg [15:0] lfsr = 16'hACE1;
    wire full = ({mask} != 0) && ((lfsr & 16'd{mask}) == 16'd{mask});
    wire busy, push, fault;
    wire [23:0] period;
    integer cycle = 0, f, rec, b;
    ms_chain {params} dut(.clk(clk), .rst(rst), .init(init), .halt(1'b0), .ld(ld),
        .ld_byte(ld_byte), .go(go), .full(full), .busy(busy), .push(push), .period(period),
        .fault(fault));
    always #10 clk = ~clk;
    always @(posedge clk) begin
        cycle <= cycle + 1;
        lfsr <= {{lfsr[14:0], lfsr[15] ^ lfsr[13] ^ lfsr[12] ^ lfsr[10]}};
        if (push) $fwrite(f, \"push %0d %0d\\n\", cycle, period);
        if (cycle > {timeout}) begin $fwrite(f, \"timeout\\n\"); $fclose(f); $finish; end
    end
    initial begin
        $readmemh(\"records.hex\", mem);
        f = $fopen(\"out.txt\", \"w\");
        @(posedge clk); rst <= 0; init <= 1;
        @(posedge clk); init <= 0;
        for (rec = 0; rec < {records}; rec = rec + 1) begin
            while (busy) @(posedge clk);
            for (b = 0; b < {bytes}; b = b + 1) begin
                ld <= 1; ld_byte <= mem[rec * {bytes} + b];
                @(posedge clk);
            end
            ld <= 0; go <= 1;
            @(posedge clk); go <= 0;
            @(posedge clk);
        end
        while (busy) @(posedge clk);
        $fwrite(f, \"fault %0d\\nend %0d\\n\", fault, cycle);
        $fclose(f);
        $finish;
    end
endmodule",
        total = records * bytes,
        params = layout.verilog_params(),
    )
    .unwrap();
    s
}

struct Run {
    /// Each push's cycle and period.
    pushes: Vec<(u64, u64)>,
    fault: bool,
}

fn simulate(profile: &Profile, busy_bits: u32, name: &str) -> Run {
    let layout = CHAIN_LAYOUT;
    let records = layout
        .records(profile, HZ)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let dir = tempfile::Builder::new().prefix("chain").tempdir().unwrap();
    let hex: String = records
        .iter()
        .flatten()
        .map(|b| format!("{b:02x}\n"))
        .collect();
    std::fs::write(dir.path().join("records.hex"), hex).unwrap();
    std::fs::write(dir.path().join("ms_chain.v"), RTL).unwrap();
    let timeout = 4 * (profile.duration() * HZ as f64) as u64 + 100_000;
    let tb = testbench(&layout, records.len(), busy_bits, timeout);
    std::fs::write(dir.path().join("tb.v"), tb).unwrap();
    let args = ["-g2005", "-o", "sim.vvp", "-s", "tb", "tb.v", "ms_chain.v"];
    run("iverilog", "iverilog", &args, dir.path()).unwrap();
    run("vvp", "iverilog", &["-n", "sim.vvp"], dir.path()).unwrap();
    let text = std::fs::read_to_string(dir.path().join("out.txt")).unwrap();
    let mut out = Run {
        pushes: Vec::new(),
        fault: true,
    };
    for line in text.lines() {
        let v: Vec<&str> = line.split_whitespace().collect();
        match v.as_slice() {
            ["push", c, p] => out.pushes.push((c.parse().unwrap(), p.parse().unwrap())),
            ["fault", x] => out.fault = *x != "0",
            ["end", _] => {}
            _ => panic!("{name}: {line}"),
        }
    }
    out
}

fn periods(m: &Move<'_>) -> Vec<u64> {
    let e: Vec<u64> = edges(m, HZ as f64).unwrap().collect();
    e.iter()
        .scan(0, |last, &x| {
            let p = x - *last;
            *last = x;
            Some(p)
        })
        .collect()
}

fn random_move(rng: &mut Rng, k: usize) -> Move<'static> {
    let u = |rng: &mut Rng, lo: f64, hi: f64| lo + (hi - lo) * (rng.next() % 10_000) as f64 / 1e4;
    let speeds = |rng: &mut Rng, v: f64| {
        if rng.next() & 1 == 0 {
            (0.0, 0.0)
        } else {
            (u(rng, 0.0, v), u(rng, 0.0, v))
        }
    };
    if matches!(k % 4, 0 | 2) {
        let family = if k % 4 < 1 {
            Family::SCurve4 {
                phi: u(rng, 0.1, 0.5),
                psi: u(rng, 0.1, 0.5),
            }
        } else {
            Family::SCurve {
                phi: u(rng, 0.1, 0.5),
            }
        };
        let (vs, ve) = speeds(rng, 20_000.0);
        let m = PhaseMove::new(
            rng.range(20, 120),
            family,
            u(rng, 2e-4, 8e-4),
            u(rng, 0.0, 3e-4),
            u(rng, 2e-4, 8e-4),
        )
        .with_speeds(vs, ve);
        Move::Phase(m)
    } else {
        let (vs, ve) = speeds(rng, 30_000.0);
        let (steps, vmax, amax) = (rng.range(10, 100), 100_000.0, u(rng, 2e8, 1e9));
        let m = if k % 4 == 1 {
            LimitsMove::scurve4(steps, vmax, amax, u(rng, 1e12, 1e13), u(rng, 1e16, 1e17))
        } else {
            LimitsMove::scurve(steps, vmax, amax, u(rng, 1e12, 1e13))
        };
        Move::Limits(m.with_speeds(vs, ve))
    }
}

/// Random moves of the four kinds: every period plan's; with the FIFO never full each
/// edge is pushed within the loading clocks of its tick (a tick a clock).
#[test]
fn chain_periods_equal_plan() {
    let mut rng = Rng(0x5eed_c4a1);
    let per_record = CHAIN_LAYOUT.record_bytes() as u64 + 3;
    for k in 0..8 {
        let m = random_move(&mut rng, k);
        let name = format!("move {k}: {m:?}");
        let profile = Profile::plan_on_clock(&m, HZ as f64).unwrap();
        let want = periods(&m);
        let busy_bits = if k % 3 == 2 { 1 } else { 0 };
        let out = simulate(&profile, busy_bits, &name);
        assert!(!out.fault, "{name}: fault");
        let got: Vec<u64> = out.pushes.iter().map(|p| p.1).collect();
        assert_eq!(got, want, "{name}");
        if busy_bits == 0 {
            let records = CHAIN_LAYOUT.records(&profile, HZ).unwrap().len() as u64;
            let mut edge = 0;
            for (i, (&(cycle, _), p)) in out.pushes.iter().zip(&want).enumerate() {
                edge += p;
                assert!(
                    cycle <= edge + records * per_record + 4,
                    "{name}: step {} pushed at {cycle}, edge {edge}",
                    i + 1
                );
            }
        }
    }
}

/// Link bytes a step for the docs' moves (printed with `--nocapture`): a record per piece
/// holding steps and one for step N, however long the move.
#[test]
fn record_bytes_per_step() {
    let s4 = Family::SCurve4 { phi: 0.5, psi: 0.5 };
    let s3 = Family::SCurve { phi: 0.5 };
    let moves = [
        (
            "scurve4 0.1/0.3/0.1 s",
            Move::Phase(PhaseMove::new(40_000, s4, 0.1, 0.3, 0.1)),
        ),
        (
            "scurve 0.1/0.3/0.1 s",
            Move::Phase(PhaseMove::new(40_000, s3, 0.1, 0.3, 0.1)),
        ),
        (
            "scurve4 5000/2000 end speeds",
            Move::Phase(PhaseMove::new(40_000, s4, 0.1, 0.3, 0.1).with_speeds(5000.0, 2000.0)),
        ),
        (
            "limits scurve4 smax 1e9",
            Move::Limits(LimitsMove::scurve4(40_000, 100_000.0, 1e6, 2e7, 1e9)),
        ),
    ];
    let bytes = CHAIN_LAYOUT.record_bytes();
    assert_eq!(bytes * 8, 112 + 2 * 304 + 280 + 264 + 248 + 240);
    for (name, m) in moves {
        let p = Profile::plan_on_clock(&m, HZ as f64).unwrap();
        let recs = CHAIN_LAYOUT.records(&p, HZ).unwrap();
        assert!(recs.iter().all(|r| r.len() == bytes));
        let per_step = (recs.len() * bytes) as f64 / p.steps() as f64;
        eprintln!("{name}: {} records, {:.4} bytes/step", recs.len(), per_step);
        assert!(recs.len() <= 16 && per_step < 0.1, "{name}");
    }
}
