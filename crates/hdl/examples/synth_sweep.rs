//! The resource sweep for docs/HDL.md: `cargo run --release -p multistep-hdl --example
//! synth_sweep -- xilinx 1 2 3 ... 16` prints one JSON row per K as it goes.
use multistep_hdl::report::{sweep, Baseline, Target};
use multistep_hdl::CoreParams;
fn main() {
    let mut args = std::env::args().skip(1);
    let target = match args.next().as_deref() {
        Some("ice40") => Target::Ice40,
        Some("ecp5") => Target::Ecp5,
        _ => Target::Xilinx,
    };
    let work = std::env::temp_dir().join("multistep-hdl-sweep");
    for k in args {
        let k: u32 = k.parse().expect("axis count");
        let t = std::time::Instant::now();
        let p = CoreParams { axes: k, ..Default::default() };
        let rows = sweep(&p, &[k], target, Baseline::Scaled, &work).expect("sweep");
        println!("{} {:.1}s", serde_json::to_string(&rows[0]).unwrap(), t.elapsed().as_secs_f64());
    }
}
