//! `hdl build` on every supported board with the YoWASP flow (yosys, nextpnr, ecppack /
//! icepack): the bitstream is written and nextpnr reports the core clock met. Place and
//! route is minutes per board, so each board builds once, at the axis count in
//! `TEST_AXES` (docs/HDL.md lists the full-K figures and how long each build takes). The
//! boards build in parallel: each place and route (WebAssembly) runs on one core.

use multistep_hdl::boards::{Board, Family, BOARDS};
use multistep_hdl::build::build;

/// The axes each board is built with here.
fn test_axes(b: &Board) -> u32 {
    match b.family {
        // K = 8 takes 4.6-21.5 min here (docs/HDL.md); 2 axes keep the test short
        Family::Ecp5 => 2,
        Family::Ice40 => b.default_axes,
    }
}

fn builds(name: &str) {
    let b = Board::by_name(name).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let k = test_axes(b);
    let t = std::time::Instant::now();
    let r = build(b, k, dir.path()).unwrap_or_else(|e| panic!("{name} K = {k}: {e}"));
    eprintln!(
        "{name} K = {k}: {r:?} in {:.0} s",
        t.elapsed().as_secs_f64()
    );
    assert_eq!((r.board.as_str(), r.axes), (name, k));
    assert!(r.timing_met && r.fmax_mhz * 1e6 >= r.clock_hz, "{r:?}");
    let bits = std::fs::metadata(&r.bitstream).unwrap().len();
    // an ECP5 25F bitstream (compressed) and an UP5K one are some 100 kB
    assert!(bits > 50_000, "{} is {bits} bytes", r.bitstream.display());
    assert!(r.lut > 0 && r.lut <= r.lut_available && r.dsp > 0, "{r:?}");
    assert!(r.axes_at_100k_steps_per_s >= 2, "{r:?}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("report.json")).unwrap())
            .unwrap();
    assert_eq!(json["timing_met"], true);
}

#[test]
fn every_board_is_listed_here() {
    let names: Vec<&str> = BOARDS.iter().map(|b| b.name).collect();
    assert_eq!(
        names,
        ["ulx3s-25f", "ulx3s-25f-14", "ulx3s-85f", "icebreaker"]
    );
}

#[test]
fn ulx3s_25f_bitstream_meets_timing() {
    builds("ulx3s-25f");
}

#[test]
fn icebreaker_bitstream_meets_timing() {
    builds("icebreaker");
}
