//! Runs one long move through the edge generator (for profiling: `perf stat`, callgrind).
use multistep_core::{EdgeGenerator, Family, PhaseMove, Profile};
fn main() {
    let fam = match std::env::args().nth(1).as_deref() {
        Some("scurve4") => Family::SCurve4 { phi: 0.5, psi: 0.5 },
        Some("sine") => Family::Sine,
        _ => Family::Trapezoid,
    };
    let p = Profile::phase(&PhaseMove {
        steps: 10_000_000,
        accel_time: 20.0,
        cruise_time: 60.0,
        decel_time: 20.0,
        start_speed: 0.0,
        end_speed: 0.0,
        family: fam,
    })
    .unwrap();
    let t = std::time::Instant::now();
    let mut g = EdgeGenerator::new(p, 50e6).unwrap();
    let s: u64 = (&mut g).fold(0u64, |a, e| a.wrapping_add(e));
    let dt = t.elapsed().as_secs_f64();
    println!(
        "{s} {:.1} M edges/s settled={}",
        1e7 / dt / 1e6,
        g.settled_count()
    );
}
