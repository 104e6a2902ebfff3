//! The pulse unit (`ms_pulse`) alone in Icarus Verilog at WP = 8, against the core TDM
//! model's `PulseUnit`: late periods shift their edge and the later ones by the delay, the
//! held pulse falls half the late period after its arrival, and waits longer than any
//! WP-bit count (the unit counts none) are exact too.

use multistep_core::tdm::pulse::{PulseShape, PulseUnit, StepPulse};
use multistep_hdl::{tools, LIBRARY};

const WP: u32 = 8;

/// One period of the move: the tick it is pushed (`None`: in the FIFO before the go) and
/// its length.
type Period = (Option<u64>, u64);

/// Runs `periods` through `ms_pulse` and returns its (rise, fall) ticks and the STEP,
/// running and underrun levels at the end.
fn simulate(periods: &[Period]) -> (Vec<(u64, u64)>, String) {
    let end = periods.iter().filter_map(|p| p.0).max().unwrap_or(0) + 4 * 256;
    let mut init = String::new();
    for (i, &(at, p)) in periods.iter().enumerate() {
        let at = at.map_or(-1, |t| t as i64);
        init += &format!("        per[{i}] = {p}; at[{i}] = {at};\n");
    }
    let n = periods.len();
    let tb = format!(
        r#"`timescale 1ns/1ns
module tb;
    localparam WP = {WP};
    localparam N = {n};
    reg clk = 1'b0;
    always #5 clk = ~clk;
    reg [WP-1:0] per [0:N-1];
    integer at [0:N-1];
    reg [WP-1:0] q [0:N];
    integer head = 0, tail = 0, pushed = 0, tick = -1;
    reg go = 1'b0;
    reg prev = 1'b0;
    wire empty = head == tail;
    wire [WP-1:0] din = q[head];
    wire more = pushed < N;
    wire arrive = tick >= 0 && more && at[pushed] == tick;
    wire [WP-1:0] ain = per[pushed];
    wire pop, step, running, underrun;
    ms_pulse #(.WP(WP)) dut (
        .clk(clk), .go(go), .din(din), .empty(empty), .more(more), .arrive(arrive),
        .ain(ain), .halt(1'b0), .clear(1'b0), .pop(pop), .step(step), .running(running),
        .underrun(underrun)
    );
    initial begin
{init}        while (pushed < N && at[pushed] < 0) begin
            q[tail] = per[pushed];
            tail = tail + 1;
            pushed = pushed + 1;
        end
        @(negedge clk);
        go = 1'b1;
        @(negedge clk);
        go = 1'b0;
    end
    always @(posedge clk) begin
        if (go || tick >= 0) tick <= tick + 1;
        if (pop && !empty) head <= head + 1;
        if (arrive) begin
            pushed <= pushed + 1;
            // a period pushed while the unit takes it passes the FIFO by
            if (!(pop && empty)) begin
                q[tail] <= ain;
                tail <= tail + 1;
            end
        end
        prev <= step;
        if (step && !prev) $display("rise %0d", tick);
        if (!step && prev) $display("fall %0d", tick);
        if (tick == {end}) begin
            $display("end %0d %0d %0d", step, running, underrun);
            $finish;
        end
    end
endmodule
"#
    );
    let dir = tempfile::tempdir().unwrap();
    let rtl = LIBRARY.iter().find(|f| f.0 == "ms_pulse.v").unwrap().1;
    std::fs::write(dir.path().join("ms_pulse.v"), rtl).unwrap();
    std::fs::write(dir.path().join("tb.v"), tb).unwrap();
    let args = ["-g2005", "-s", "tb", "-o", "sim.vvp", "tb.v", "ms_pulse.v"];
    tools::run("iverilog", "iverilog", &args, dir.path()).unwrap();
    let out = tools::run("vvp", "iverilog", &["-n", "sim.vvp"], dir.path()).unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let (mut rises, mut falls, mut end) = (Vec::new(), Vec::new(), String::new());
    for line in text.lines() {
        match line.split_once(' ') {
            Some(("rise", t)) => rises.push(t.parse::<u64>().unwrap()),
            Some(("fall", t)) => falls.push(t.parse::<u64>().unwrap()),
            Some(("end", levels)) => end = levels.to_string(),
            _ => panic!("unexpected line {line:?}"),
        }
    }
    assert_eq!(rises.len(), falls.len(), "{text}");
    (rises.into_iter().zip(falls).collect(), end)
}

/// The ticks each period is loaded: period 1 at the go (tick 0), each later one at the
/// previous edge or, when pushed after it, the tick after its push.
fn loads(periods: &[Period]) -> Vec<u64> {
    let mut out = vec![0];
    let mut rise = periods[0].1;
    for &(at, p) in &periods[1..] {
        let load = at.map_or(rise, |t| rise.max(t + 1));
        out.push(load);
        rise = load + p;
    }
    out
}

/// The core TDM model's pulses for `periods`.
fn model(periods: &[Period]) -> Vec<(u64, u64)> {
    let mut u = PulseUnit::new(PulseShape::HalfInterval);
    let mut out: Vec<StepPulse> = Vec::new();
    let mut sink = |p| out.push(p);
    for (&load, &(_, p)) in loads(periods).iter().zip(periods) {
        u.load(0, load, p, &mut sink);
    }
    u.finish(0, &mut sink);
    out.iter().map(|s| (s.rise, s.fall)).collect()
}

/// Pulses as the STEP line shows them: one whose fall is the next one's rise (merged, no
/// low time between) is one pulse.
fn joined(pulses: Vec<(u64, u64)>) -> Vec<(u64, u64)> {
    let mut out: Vec<(u64, u64)> = Vec::new();
    for (rise, fall) in pulses {
        match out.last_mut() {
            Some(last) if last.1 == rise => last.1 = fall,
            _ => out.push((rise, fall)),
        }
    }
    out
}

fn check(periods: &[Period]) {
    let (pulses, end) = simulate(periods);
    // only a period of one tick leaves no low time before its edge
    let merged = periods[1..].iter().filter(|p| p.1 == 1).count();
    assert_eq!(
        pulses.len(),
        periods.len() - merged,
        "{periods:?}: {pulses:?}"
    );
    let waits: Vec<u64> = loads(periods)[1..]
        .iter()
        .zip(model(periods))
        .map(|(&load, (rise, _))| load - rise)
        .collect();
    let underrun = waits.iter().any(|&w| w > 0);
    let levels = format!("0 0 {}", u8::from(underrun));
    assert_eq!(
        end, levels,
        "{periods:?}: STEP, running, underrun at the end"
    );
    assert_eq!(pulses, joined(model(periods)), "{periods:?}");
}

#[test]
fn late_periods_after_long_waits_lose_no_pulse() {
    // period 2 arrives 200 ticks after edge 1, more than the 128 a WP - 1 bit count holds
    check(&[
        (None, 20),
        (Some(220), 30),
        (Some(230), 20),
        (Some(240), 20),
    ]);
    // a late period longer than the wait: the held pulse falls before its edge
    check(&[(None, 20), (Some(220), 250), (Some(230), 40)]);
    check(&[(None, 20), (Some(1_000), 255), (Some(1_100), 255)]);
    // the shortest late period after a long wait (merged), then the last step
    check(&[(None, 5), (Some(1_000), 1)]);
    check(&[(None, 5), (Some(1_000), 1), (Some(1_001), 2)]);
    // two underruns in a row, one long and one short
    check(&[
        (None, 20),
        (Some(300), 40),
        (Some(400), 200),
        (Some(410), 20),
    ]);
    // waits of 124..=132 ticks, and past 2^WP
    for wait in [300, 600] {
        check(&[(None, 10), (Some(10 + wait), 200), (Some(10 + wait + 5), 7)]);
    }
    for wait in 124..=132 {
        for p in [1, 2, 3, 127, 128, 129, 130, 131, 200, 255] {
            check(&[
                (None, 10),
                (Some(10 + wait - 1), p),
                (Some(10 + wait + 5), 7),
            ]);
        }
    }
}

#[test]
fn on_time_and_short_late_periods_are_the_models() {
    check(&[
        (None, 20),
        (None, 30),
        (Some(10), 3),
        (Some(30), 2),
        (Some(49), 9),
    ]);
    check(&[(None, 20), (Some(19), 30), (Some(60), 4), (Some(100), 255)]);
}
