//! The per-step recurrence's jump-and-walk unit (`ms_recur`) in Icarus Verilog at the
//! board's widths, against `multistep_core::int::recurrence`'s walk: on every step of
//! random trapezoids, limits moves and seed 000 segment chains at 50 MHz, from candidates
//! around the edge (walks of 0 to 24 ticks: found, abandoned at the walk limit, or
//! stopped at a piece's first or last tick), the same edge or failure, the same ticks
//! moved, in 5 + moves clocks (8 + moves digit-serial); and the model's edges are the
//! closed form's.

use multistep_core::int::recurrence::{WalkInputs, WALK_LIMIT};
use multistep_core::int::{IntClock, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment};
use multistep_hdl::{tools, RECURRENCE_UNIT};
use proptest::prelude::Rng as _;
use proptest::test_runner::{RngAlgorithm, TestRng};
use std::fmt::Write as _;

const HZ: u64 = 50_000_000;
// the board core's widths: 24 tick bits, 2A below 2^66, B within 68 bits, 4M 128
const WE: u32 = 24;
const WA: u32 = 66;
const WB: u32 = 68;

/// proptest's deterministic generator, for one fixed set of vectors.
struct Rng(TestRng);
impl Rng {
    fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.0.next_u64() % (hi - lo + 1)
    }
}

fn profiles(r: &mut Rng) -> Vec<IntProfile> {
    let c = IntClock::hz(HZ);
    let mut out = Vec::new();
    while out.len() < 24 {
        let v = |r: &mut Rng| {
            if r.range(0, 1) == 0 {
                0
            } else {
                r.range(1, 20_000)
            }
        };
        let ph = IntPhaseMove {
            steps: r.range(1, 3_000),
            accel_ticks: r.range(0, 2_000_000),
            cruise_ticks: r.range(0, 1_000_000),
            decel_ticks: r.range(1, 2_000_000),
            start_speed: v(r),
            end_speed: v(r),
        };
        let lm = IntLimitsMove {
            steps: r.range(1, 3_000),
            vmax: r.range(1_000, 100_000),
            amax: r.range(100_000, 5_000_000),
            start_speed: 0,
            end_speed: 0,
        };
        let sg: Vec<IntSegment> = (0..r.range(1, 3))
            .map(|_| IntSegment {
                v0: r.range(0, 3_000),
                ticks: r.range(1, 1_000_000),
                steps: 800,
            })
            .collect();
        for p in [
            IntProfile::phase(&ph, c),
            IntProfile::limits(&lm, c),
            IntProfile::segments(&sg, c),
        ]
        .into_iter()
        .flatten()
        {
            out.push(p);
        }
    }
    out
}

fn hex(x: u128, bits: u32) -> String {
    let m = if bits >= 128 {
        u128::MAX
    } else {
        (1 << bits) - 1
    };
    format!("{:x}", x & m)
}

/// Every step of [`profiles`] from a candidate 0 to 24 ticks off its edge: the walk's
/// inputs, the model's answer and ticks moved.
type Vectors = Vec<(WalkInputs, Option<u64>, u32)>;

fn vectors() -> Vectors {
    let mut r = Rng(TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    let mut vectors: Vec<(WalkInputs, Option<u64>, u32)> = Vec::new();
    let (mut found, mut abandoned, mut bounded) = (0, 0, 0);
    for p in profiles(&mut r) {
        for q in p.pieces() {
            for j in 0..q.steps {
                let local = q.edge(j) - q.t0;
                let off = r.range(0, 48) as i128 - 24;
                let Some(w) = WalkInputs::new(q, j, local as i128 + off) else {
                    continue;
                };
                let fits = w.two_a >> WA == 0
                    && (w.b >> (WB - 1) == 0 || w.b >> (WB - 1) == -1)
                    && w.hi >> WE == 0;
                assert!(fits, "a piece beyond the board's widths: {w:?}");
                let out = w.walk();
                match out.edge {
                    Some(e) => {
                        assert_eq!(e, local, "{w:?}");
                        found += 1;
                    }
                    None if out.abandoned => abandoned += 1,
                    None => bounded += 1,
                }
                vectors.push((w, out.edge, out.moves));
            }
        }
    }
    assert!(
        found > 1000 && abandoned > 50 && bounded > 5,
        "{found} {abandoned} {bounded}"
    );
    let n = vectors.len();
    println!("{n} steps: {found} found, {abandoned} abandoned, {bounded} stopped at a boundary");
    vectors
}

/// The unit with multiply digits of `md` bits (0: full width) answers every vector as the
/// model, in `lat` + moves clocks.
fn unit_agrees(vectors: &Vectors, md: u32, lat: u32) {
    let n = vectors.len();
    let dir = tempfile::tempdir().unwrap();
    let mut files = [String::new(), String::new(), String::new(), String::new()];
    for (w, _, _) in vectors {
        writeln!(files[0], "{}", hex(w.two_a, WA)).unwrap();
        writeln!(files[1], "{}", hex(w.b as u128, WB)).unwrap();
        writeln!(files[2], "{}", hex(w.m4, 128)).unwrap();
        let e = (w.e0 as u128) << 48 | (w.lo as u128) << 24 | w.hi as u128;
        writeln!(files[3], "{}", hex(e, 72)).unwrap();
    }
    for (name, text) in ["a.hex", "b.hex", "m.hex", "e.hex"].iter().zip(&files) {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let tb = format!(
        r#"`timescale 1ns/1ns
module tb;
    localparam N = {n};
    reg clk = 1'b0;
    always #5 clk = ~clk;
    reg [{WA}-1:0] a [0:N-1];
    reg [{WB}-1:0] b [0:N-1];
    reg [127:0] m [0:N-1];
    reg [71:0] e [0:N-1];
    reg go = 1'b0;
    reg [{WA}-1:0] two_a;
    reg [{WB}-1:0] bb;
    reg [127:0] m4;
    reg [71:0] ee;
    wire busy, done, fail;
    wire [{WE}-1:0] at;
    wire [4:0] moves;
    ms_recur #(.WE({WE}), .WA({WA}), .WB({WB}), .WU(128), .LIMIT({WALK_LIMIT}), .MD({md})) dut (
        .clk(clk), .rst(1'b0), .go(go), .e0(ee[71:48]), .lo(ee[47:24]), .hi(ee[23:0]),
        .two_a(two_a), .b(bb), .m4(m4), .busy(busy), .done(done), .fail(fail),
        .at(at), .moves(moves));
    integer i, clocks;
    initial begin
        $readmemh("a.hex", a);
        $readmemh("b.hex", b);
        $readmemh("m.hex", m);
        $readmemh("e.hex", e);
        for (i = 0; i < N; i = i + 1) begin
            @(negedge clk);
            two_a = a[i]; bb = b[i]; m4 = m[i]; ee = e[i];
            go = 1'b1;
            clocks = 0;
            @(negedge clk);
            go = 1'b0;
            while (!done && !fail) begin
                @(negedge clk);
                clocks = clocks + 1;
            end
            if (done) $display("v %0d %0d %0d", at, moves, clocks);
            else $display("f - %0d %0d", moves, clocks);
        end
        $finish;
    end
endmodule
"#
    );
    std::fs::write(dir.path().join("tb.v"), tb).unwrap();
    std::fs::write(dir.path().join(RECURRENCE_UNIT.0), RECURRENCE_UNIT.1).unwrap();
    let args = [
        "-g2005",
        "-s",
        "tb",
        "-o",
        "sim.vvp",
        "tb.v",
        RECURRENCE_UNIT.0,
    ];
    tools::run("iverilog", "iverilog", &args, dir.path()).unwrap();
    let out = tools::run("vvp", "iverilog", &["-n", "sim.vvp"], dir.path()).unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), n, "{}", &text[..text.len().min(2000)]);
    for (i, (line, (w, edge, moves))) in lines.iter().zip(vectors).enumerate() {
        let f: Vec<&str> = line.split(' ').collect();
        let got_edge = (f[0] == "v").then(|| f[1].parse::<u64>().unwrap());
        let (got_moves, clocks): (u32, u32) = (f[2].parse().unwrap(), f[3].parse().unwrap());
        assert_eq!(
            (got_edge, got_moves, clocks),
            (*edge, *moves, lat + moves),
            "vector {i}, MD = {md}: {w:?}"
        );
    }
}

#[test]
fn the_unit_walks_as_the_model() {
    unit_agrees(&vectors(), 0, 5);
}

/// Digit-serial: t's 25 bits in two digits of 13 (2·2 + 4 clocks to U), the products
/// through one 70 × 14-bit multiplier.
#[test]
fn the_digit_serial_unit_walks_as_the_model() {
    unit_agrees(&vectors(), 13, 8);
}

/// Verilator's lint, every warning on, at the board's widths and at narrow ones.
#[test]
fn the_unit_lints_clean() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(RECURRENCE_UNIT.0), RECURRENCE_UNIT.1).unwrap();
    for params in [
        vec![],
        vec!["-GWE=4", "-GWA=6", "-GWB=6", "-GWU=12", "-GLIMIT=3"],
        vec!["-GMD=13"],
        vec![
            "-GWE=4",
            "-GWA=6",
            "-GWB=6",
            "-GWU=12",
            "-GLIMIT=3",
            "-GMD=2",
        ],
    ] {
        let mut args = vec!["--lint-only", "-Wall", RECURRENCE_UNIT.0];
        args.extend(params);
        tools::run("verilator", "verilator", &args, dir.path()).unwrap();
    }
}
