//! How fast the bench's consumer can take edges at all: the cruise-heavy moves' edges,
//! precomputed into a slice, folded by the same chunk timer `multistep bench` uses, beside
//! multistep-float, multistep-int and seed 000's replica taking turns with it. An
//! implementation cannot run faster than the slice.
//!
//! `cargo run --release -p multistep-bench --example consumer_ceiling [SECONDS]`

use multistep_bench::compare::{drive, ChunkTimer, Impl, Options, Sink};
use multistep_bench::moves::MOVES;
use std::hint::black_box;
use std::time::{Duration, Instant};

fn main() {
    let secs: f64 = match std::env::args().nth(1).map(|s| s.parse()) {
        None => 3.0,
        Some(Ok(s)) if s > 0.0 && s < 3600.0 => s,
        Some(_) => {
            eprintln!("error: SECONDS must be a number of seconds in (0, 3600)");
            std::process::exit(2);
        }
    };
    let opts = Options::full();
    let imps = [Impl::Float, Impl::Int, Impl::Seed000];
    println!("move           multistep-float  multistep-int  seed000  slice (edges/s)");
    for name in ["slow-5k", "fast-1M", "half-tick-1M"] {
        let Some(m) = MOVES.iter().find(|m| m.name == name) else {
            continue;
        };
        let mut slice = Vec::new();
        drive(Impl::Int, m, &opts, &mut slice);
        let mut timers: [ChunkTimer; 4] = Default::default();
        let start = Instant::now();
        let mut rounds = 0;
        while start.elapsed() < Duration::from_secs_f64(secs) || rounds < 3 {
            for (k, t) in timers.iter_mut().enumerate() {
                t.start();
                match imps.get(k) {
                    Some(&imp) => drive(imp, black_box(m), &opts, t),
                    None => t.take(black_box(&slice).iter().copied()),
                }
                black_box(t.fold);
            }
            rounds += 1;
        }
        let rate = |t: &ChunkTimer| m.steps as f64 / t.total();
        println!(
            "{name:<14} {:>15.3e}  {:>13.3e}  {:>7.3e}  {:.3e}",
            rate(&timers[0]),
            rate(&timers[1]),
            rate(&timers[2]),
            rate(&timers[3])
        );
    }
}
