//! One run of the TDM bench workload, for instruction counting under valgrind:
//! `tdm_probe rr|edf|gen [axes]` (16 axes by default; see benches/tdm.rs).
use multistep_core::tdm::{rate_move, Axis, Board, Policy, TdmConfig};
use multistep_core::EdgeGenerator;
fn main() {
    let mode = std::env::args().nth(1).unwrap_or_default();
    let k: usize = std::env::args()
        .nth(2)
        .map_or(16, |s| s.parse().expect("axes: a number"));
    let scale = 16.0 / k as f64;
    let mut axes: Vec<Axis> = (0..k)
        .map(|m| {
            let rate = scale * (20e3 + 2e3 * (m % 16) as f64);
            Axis::new(rate_move(rate, 0.4, 0.2, 0.4).unwrap(), 50e6).unwrap()
        })
        .collect();
    let mut s = 0u64;
    let policy = if mode == "edf" {
        Policy::EarliestDeadline
    } else {
        Policy::RoundRobin
    };
    if mode == "gen" {
        for a in &axes {
            for e in EdgeGenerator::new(a.profile().clone(), 50e6).unwrap() {
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
        assert_eq!(r.underruns, 0);
        assert_eq!(r.edges, 336_000);
    }
    println!("{s}");
}
