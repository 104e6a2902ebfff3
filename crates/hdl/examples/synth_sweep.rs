//! The resource sweep for docs/HDL.md: `cargo run --release -p multistep-hdl --example
//! synth_sweep -- xilinx 1 2 4 8 16` prints one JSON row per K as it goes (the baseline
//! is one synthesized single-axis core times K, `Baseline::Scaled`).
use multistep_hdl::report::{synthesize, Row, Target};
use multistep_hdl::{Arch, CoreParams, Design};
fn main() {
    let mut args = std::env::args().skip(1);
    let target = match args.next().as_deref() {
        Some("ice40") => Target::Ice40,
        Some("ecp5") => Target::Ecp5,
        _ => Target::Xilinx,
    };
    let work = std::env::temp_dir().join("multistep-hdl-sweep");
    let one = Design::new(
        &CoreParams {
            axes: 1,
            ..Default::default()
        },
        Arch::Independent,
    )
    .unwrap();
    let single = synthesize(&one, target, &work.join("indep-1")).expect("yosys");
    for k in args {
        let k: u32 = k.parse().expect("axis count");
        let t = std::time::Instant::now();
        let d = Design::new(
            &CoreParams {
                axes: k,
                ..Default::default()
            },
            Arch::Tdm,
        )
        .unwrap();
        let tdm = synthesize(&d, target, &work.join(format!("tdm-{k}"))).expect("yosys");
        let row = Row {
            axes: k,
            tdm,
            independent: single.times(u64::from(k)),
        };
        println!(
            "{} {:.1}s",
            serde_json::to_string(&row).unwrap(),
            t.elapsed().as_secs_f64()
        );
    }
}
