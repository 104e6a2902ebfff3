//! One run of a TDM workload, for instruction counting under valgrind:
//! `tdm_probe rr|edf|gen [16|64|skewed]`. 16 and 64 are the bench loads (benches/tdm.rs);
//! `skewed` is 64 axes, one at 100 k steps/s and 63 at 1.01–1.63 k steps/s, where the
//! fast axis's room tick comes before almost every other (the scheduler's hard case).
use multistep_core::tdm::{rate_move, Axis, Board, Policy, TdmConfig};
use multistep_core::EdgeGenerator;
fn main() {
    let mode = std::env::args().nth(1).unwrap_or_default();
    let load = std::env::args().nth(2).unwrap_or_else(|| "16".into());
    let rates: Vec<f64> = match load.as_str() {
        "skewed" => (0..64)
            .map(|m| if m == 0 { 100e3 } else { 1e3 + 10.0 * m as f64 })
            .collect(),
        k => {
            let k: usize = k.parse().expect("axes: 16, 64 or skewed");
            let scale = 16.0 / k as f64;
            (0..k)
                .map(|m| scale * (20e3 + 2e3 * (m % 16) as f64))
                .collect()
        }
    };
    let mut axes: Vec<Axis> = rates
        .iter()
        .map(|&rate| Axis::new(rate_move(rate, 0.4, 0.2, 0.4).unwrap(), 50e6).unwrap())
        .collect();
    let mut s = 0u64;
    let policy = if mode == "edf" {
        Policy::EarliestDeadline
    } else {
        Policy::RoundRobin
    };
    if mode == "gen" {
        for a in &axes {
            for e in EdgeGenerator::new(a.profile().unwrap().clone(), 50e6).unwrap() {
                s = s.wrapping_add(e);
            }
        }
    } else {
        let cfg = TdmConfig {
            fifo_depth: 4,
            policy,
            ..TdmConfig::default()
        };
        let r = Board::new(cfg, &mut axes)
            .unwrap()
            .run(|p| s = s.wrapping_add(p.rise ^ p.fall));
        eprintln!("edges {} underruns {}", r.edges, r.underruns);
    }
    println!("{s}");
}
