//! The per-step recurrence unit (`ms_recur`) placed and routed alone with the project's
//! flow, for docs/HDL.md: `cargo run --release -p multistep-hdl --example place_recur --
//! ice40 13` places it at the iCEBreaker's widths (20 tick bits, 2A in 27 bits, B in 26,
//! 4M in 48) on the UP5K at 18 MHz with 13-bit multiply digits (0: full-width multiplies);
//! `ecp5 0` at the ULX3S's (24, 66, 68, 128) on the LFE5U-25F at 50 MHz. The unit sits
//! behind a shift register that loads every input from one pin and an XOR that folds
//! every output into one, so all its logic stays and it needs four pins.
use multistep_hdl::boards::{Family, BOARDS};
use multistep_hdl::pnr::{place_and_route, Flow, Nextpnr};
use multistep_hdl::RECURRENCE_UNIT;

fn main() {
    let mut args = std::env::args().skip(1);
    let family = match args.next().as_deref() {
        Some("ice40") => Family::Ice40,
        Some("ecp5") => Family::Ecp5,
        _ => {
            eprintln!("usage: place_recur ice40|ecp5 [MD]");
            std::process::exit(2);
        }
    };
    let md: u32 = args
        .next()
        .map_or(0, |m| m.parse().expect("MD: digit bits"));
    // (WE, WA, WB, WU, clock)
    let (we, wa, wb, wu, hz) = match family {
        Family::Ice40 => (20, 27, 26, 48, 18e6),
        Family::Ecp5 => (24, 66, 68, 128, 50e6),
    };
    let board = BOARDS.iter().find(|b| b.family == family).unwrap();
    let inputs = 3 * we + wa + wb + wu;
    let top = format!(
        "module recur_place (input wire clk, input wire sin, input wire go, output reg fold);\n\
         \x20   reg [{i1}:0] sr;\n\
         \x20   reg go_r;\n\
         \x20   wire busy, done, fail;\n\
         \x20   wire [{we1}:0] at;\n\
         \x20   wire [4:0] moves;\n\
         \x20   ms_recur #(.WE({we}), .WA({wa}), .WB({wb}), .WU({wu}), .MD({md})) u (\n\
         \x20       .clk(clk), .rst(1'b0), .go(go_r),\n\
         \x20       .e0(sr[{we1}:0]), .lo(sr[{lo1}:{we}]), .hi(sr[{hi1}:{lo0}]),\n\
         \x20       .two_a(sr[{a1}:{hi0}]), .b(sr[{b1}:{a0}]), .m4(sr[{i1}:{b0}]),\n\
         \x20       .busy(busy), .done(done), .fail(fail), .at(at), .moves(moves));\n\
         \x20   always @(posedge clk) begin\n\
         \x20       sr <= {{sr[{i2}:0], sin}};\n\
         \x20       go_r <= go;\n\
         \x20       fold <= ^{{busy, done, fail, at, moves}};\n\
         \x20   end\n\
         endmodule\n",
        i1 = inputs - 1,
        i2 = inputs - 2,
        we1 = we - 1,
        lo1 = 2 * we - 1,
        lo0 = 2 * we,
        hi1 = 3 * we - 1,
        hi0 = 3 * we,
        a1 = 3 * we + wa - 1,
        a0 = 3 * we + wa,
        b1 = 3 * we + wa + wb - 1,
        b0 = 3 * we + wa + wb,
    );
    let dir = std::env::temp_dir().join(format!("multistep-place-recur-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("recur_place.v"), top).unwrap();
    std::fs::write(dir.join(RECURRENCE_UNIT.0), RECURRENCE_UNIT.1).unwrap();
    let flow = Flow {
        family,
        nextpnr_args: board.nextpnr_args,
        top: "recur_place",
        sources: vec!["recur_place.v".into(), RECURRENCE_UNIT.0.into()],
        constraints: None,
        clock_hz: hz,
        pack: false,
        nextpnr: Nextpnr::YoWasp,
    };
    let t = std::time::Instant::now();
    match place_and_route(&flow, &dir) {
        Ok(p) => println!(
            "{family:?} WE {we} WA {wa} WB {wb} WU {wu} MD {md}: {}\n({:.0} s; work in {})",
            serde_json::to_string(&p).unwrap(),
            t.elapsed().as_secs_f64(),
            dir.display()
        ),
        Err(e) => {
            eprintln!("{e} (work in {})", dir.display());
            std::process::exit(1);
        }
    }
}
