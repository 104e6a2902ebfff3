//! One run of one tracker, for timing and instruction counting under valgrind:
//! `track_probe ramp|scurve|cruise float|int|tdm-float|tdm-int|none [STEPS]` (`tdm-*`: the
//! tracker as the one axis of a TDM board, run to just past its last edge; `cruise` only).
//! `ramp`: from rest towards 2·10⁵ steps/s at amax 2·10⁴ steps/s² (10⁶ ramp steps, all
//! taken from the ramp); `scurve`: the same with jmax 2·10³ steps/s³ (two constant-jerk
//! pieces of 10 s: 333 333 steps in the first, from rest, 1 666 667 in the second, which
//! starts at 10 s); `cruise`: 31999.9 steps/s from that speed (no ramp), at 50 MHz. `none` sets up and stops: its
//! count is the fixed cost to subtract. Prints the edges' checksum and edges/s.
use multistep_core::int::IntTracker;
use multistep_core::tdm::{Axis, Board, TdmConfig};
use multistep_core::{Rate, TrackLimits, Tracker};
use std::time::Instant;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let case = a.get(1).map_or("cruise", |s| s.as_str());
    let imp = a.get(2).map_or("int", |s| s.as_str());
    let steps: u64 = a.get(3).map_or(1_000_000, |s| s.parse().unwrap());
    let limits = TrackLimits {
        amax: 2e4,
        jmax: (case == "scurve").then_some(2e3),
    };
    let (start, rate) = match case {
        "ramp" | "scurve" => (0.0, Rate::new(200_000, 1).unwrap()),
        _ => (31999.9, Rate::parse("31999.9").unwrap()),
    };
    let t = Instant::now();
    let sum = match imp {
        "float" => Tracker::new(50e6, limits, start, rate)
            .unwrap()
            .take(steps as usize)
            .fold(0u64, u64::wrapping_add),
        "int" => IntTracker::new(50e6, limits, start, rate)
            .unwrap()
            .take(steps as usize)
            .fold(0u64, u64::wrapping_add),
        "tdm-float" | "tdm-int" => {
            let axis = if imp == "tdm-int" {
                Axis::tracking_int(IntTracker::new(50e6, limits, start, rate).unwrap())
            } else {
                Axis::tracking(Tracker::new(50e6, limits, start, rate).unwrap())
            };
            // past the last edge of the cruise case (no ramp): half a step's margin
            let until = ((steps as f64 + 0.5) / rate.to_f64() * 50e6) as u64;
            let mut axes = [axis.unwrap()];
            let (mut sum, mut n) = (0u64, 0u64);
            Board::new(TdmConfig::default(), &mut axes)
                .unwrap()
                .run_tracking(until, &mut [], |p| {
                    if p.step <= steps {
                        sum = sum.wrapping_add(p.rise);
                        n += 1;
                    }
                })
                .unwrap();
            assert_eq!(n, steps);
            sum
        }
        _ => 0,
    };
    let s = t.elapsed().as_secs_f64();
    println!(
        "{case} {imp} {steps} edges: checksum {sum}, {:.1} M edges/s",
        steps as f64 / s / 1e6
    );
}
