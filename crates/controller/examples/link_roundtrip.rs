//! Round trip of one register read over a board's host link: `cargo run --release -p
//! multistep-controller --example link_roundtrip -- /dev/pts/N [READS]` against a board
//! (or `multistep board-sim`). Prints the mean, the fastest and the slowest read.

use multistep_hdl::link::{BoardReg, HostLink, Reg};
use std::time::{Duration, Instant};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dev = args.next().ok_or("usage: link_roundtrip DEVICE [READS]")?;
    let n: u32 = args.next().map_or(Ok(1000), |s| s.parse())?;
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
    let total: Duration = times.iter().sum();
    let us = |d: Duration| d.as_secs_f64() * 1e6;
    println!(
        "{n} reads, board of {} axes at {} Hz, {} baud: mean {:.0} µs, min {:.0} µs, max {:.0} µs",
        id.axes,
        id.clock_hz,
        id.baud,
        us(total / n.max(1)),
        us(*times.iter().min().unwrap_or(&Duration::ZERO)),
        us(*times.iter().max().unwrap_or(&Duration::ZERO)),
    );
    Ok(())
}
