//! How fast the tracker streams: 24 h at the sidereal rate of a 4,000,000-microstep mount
//! and 1 h at 31,999.9 steps/s, at 50 MHz. Prints edges/s and simulated seconds per second.
//! `cargo run --release -p multistep-core --example track_speed [SECONDS_SCALE]`

use multistep_core::{Rate, TrackLimits, Tracker};
use std::time::Instant;

fn run(name: &str, rate: Rate, amax: f64, seconds: f64) {
    let f = 50e6;
    let limits = TrackLimits { amax, jmax: None };
    let mut tr = Tracker::new(f, limits, 0.0, rate).unwrap();
    let end = (seconds * f) as u64;
    let t0 = Instant::now();
    let (mut n, mut sum) = (0u64, 0u64);
    for e in &mut tr {
        if e > end {
            break;
        }
        n += 1;
        sum = sum.wrapping_add(e);
    }
    let wall = t0.elapsed().as_secs_f64();
    println!(
        "{name}: {n} edges in {wall:.3} s wall: {:.3e} edges/s, {:.3e} simulated s per s (checksum {sum})",
        n as f64 / wall,
        seconds / wall
    );
}

fn main() {
    let scale: f64 = std::env::args().nth(1).map_or(1.0, |s| s.parse().unwrap());
    run(
        "sidereal 24 h",
        Rate::new(15041, 324).unwrap(),
        200.0,
        86400.0 * scale,
    );
    run(
        "31999.9 steps/s 1 h",
        Rate::new(319_999, 10).unwrap(),
        64_000.0,
        3600.0 * scale,
    );
}
