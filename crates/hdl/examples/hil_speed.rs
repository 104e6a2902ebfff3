//! Builds the Verilator model of a board and runs it idle: clock cycles per wall second.
//! `cargo run --release -p multistep-hdl --example hil_speed -- ulx3s-25f 4`
use multistep_hdl::boards::Board;
use multistep_hdl::verilator::{default_cache_dir, VerilatedBoard};
use multistep_hdl::BoardTop;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let b = Board::by_name(args.get(1).map_or("ulx3s-25f", String::as_str))?;
    let k: u32 = args.get(2).map_or(Ok(4), |s| s.parse())?;
    let top = BoardTop::new(b.params(k)?, b.baud);
    let t = std::time::Instant::now();
    let mut m = VerilatedBoard::new(&top, &default_cache_dir())?;
    println!("build/load {:.1} s", t.elapsed().as_secs_f64());
    let t = std::time::Instant::now();
    let n = m.run(5_000_000, 0);
    let s = t.elapsed().as_secs_f64();
    println!(
        "{n} cycles in {s:.2} s: {:.2} M cycles/s, {:?}",
        n as f64 / s / 1e6,
        m.outputs()
    );
    Ok(())
}
