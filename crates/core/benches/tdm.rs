//! Aggregate edges/s through the TDM engine: 16 axes on one core.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use multistep_core::tdm::{rate_move, Axis, Board, Policy, TdmConfig};
use multistep_core::EdgeGenerator;

const F: f64 = 50e6;
const AXES: usize = 16;

/// 16 different trapezoids (20/10/20 ms scaled by 20×, so 0.4/0.2/0.4 s), cruise speeds
/// 20–50 k steps/s: about 0.5 M edges in all, no underrun at depth 4.
fn axes() -> Vec<Axis> {
    (0..AXES)
        .map(|m| {
            let rate = 20e3 + 2e3 * m as f64;
            Axis::new(rate_move(rate, 0.4, 0.2, 0.4).unwrap(), F).unwrap()
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let mut axes = axes();
    let edges: u64 = axes.iter().map(|a| a.profile().steps()).sum();
    let mut g = c.benchmark_group("tdm_16_axes");
    g.throughput(Throughput::Elements(edges));
    g.sample_size(20);
    for policy in [Policy::RoundRobin, Policy::EarliestDeadline] {
        let cfg = TdmConfig {
            fifo_depth: 4,
            policy,
            ..TdmConfig::default()
        };
        g.bench_function(policy.name(), |b| {
            b.iter(|| {
                let mut sum = 0u64;
                let r = Board::new(cfg, &mut axes)
                    .unwrap()
                    .run(|p| sum = sum.wrapping_add(p.rise ^ p.fall));
                assert_eq!(r.underruns, 0);
                black_box(sum)
            })
        });
    }
    // the same edges from the generators alone: what the engine adds on top
    g.bench_function("generators_only", |b| {
        b.iter(|| {
            let mut sum = 0u64;
            for a in &axes {
                for e in EdgeGenerator::new(a.profile().clone(), F).unwrap() {
                    sum = sum.wrapping_add(e);
                }
            }
            black_box(sum)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
