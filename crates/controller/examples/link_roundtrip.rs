//! Round trip of one register read over a board's host link: `cargo run --release -p
//! multistep-controller --example link_roundtrip -- /dev/pts/N [READS]` against a board
//! (or `multistep board-sim`). Prints the mean, the fastest and the slowest read, and the
//! time to load one trapezoid move.

use multistep_link::{self as link, BoardReg, HostLink, Reg};
use std::time::{Duration, Instant};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dev = args.next().ok_or("usage: link_roundtrip DEVICE [READS]")?;
    let n: u32 = args.next().map_or(Ok(1000), |s| s.parse())?.max(1);
    let port = serialport::new(&dev, 3_000_000)
        .timeout(Duration::from_secs(2))
        .open()?;
    let mut link = HostLink::new(port);
    let id = link.build_id()?;
    let mut times = Vec::with_capacity(n as usize);
    for _ in 0..n {
        let t = Instant::now();
        link.read(Reg::Board(BoardReg::Session))?;
        times.push(t.elapsed());
    }
    // Loading a trapezoid into axis 0 (3 pieces: 55 writes), not started.
    let mv = multistep_core::MoveSpec {
        steps: Some(1200),
        params: multistep_core::MoveParams {
            vmax: Some(4000.0),
            amax: Some(40000.0),
            ..Default::default()
        },
        ..Default::default()
    }
    .resolve()?;
    let ip = link::int_profile(&mv, u64::from(id.clock_hz))?;
    let params = multistep_link::CoreParams::from(&id);
    let m = multistep_link::AxisMove::from_profile(&ip, true, &params)?;
    let writes = link::move_writes(&params, 0, &m, 0)?;
    let t = Instant::now();
    link.write_all(&writes)?;
    let load = t.elapsed();
    let total: Duration = times.iter().sum();
    let us = |d: Duration| d.as_secs_f64() * 1e6;
    times.sort();
    let q = |f: f64| us(times[((times.len() - 1) as f64 * f) as usize]);
    println!(
        "{n} reads, board of {} axes at {} Hz, {} baud: mean {:.0} µs, min {:.0}, p50 {:.0}, p99 {:.0}, max {:.0} µs",
        id.axes,
        id.clock_hz,
        id.baud,
        us(total / n.max(1)),
        q(0.0),
        q(0.5),
        q(0.99),
        q(1.0),
    );
    println!(
        "loading a 3-piece trapezoid ({} writes): {:.1} ms",
        writes.len(),
        load.as_secs_f64() * 1e3
    );
    Ok(())
}
