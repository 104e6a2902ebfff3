//! Aggregate edges/s through the TDM engine on one core: 16 axes (the figure the goal names) and
//! 64 (the most a board holds) carrying the same edges.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use multistep_core::tdm::{rate_move, Axis, Board, Policy, TdmConfig};
use multistep_core::EdgeGenerator;

const F: f64 = 50e6;

/// k different trapezoids of 0.4/0.2/0.4 s; with 16 axes the cruise speeds are 20–50 k
/// steps/s, with more they are scaled by 16/k, so every board carries 336 000 edges at the
/// same calculator load (46 %) with no underrun at depth 4.
fn axes(k: usize) -> Vec<Axis> {
    let scale = 16.0 / k as f64;
    (0..k)
        .map(|m| {
            let rate = scale * (20e3 + 2e3 * (m % 16) as f64);
            Axis::new(rate_move(rate, 0.4, 0.2, 0.4).unwrap(), F).unwrap()
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    for k in [16, 64] {
        let mut axes = axes(k);
        let edges: u64 = axes.iter().map(|a| a.profile().unwrap().steps()).sum();
        let mut g = c.benchmark_group(format!("tdm_{k}_axes"));
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
                    for e in EdgeGenerator::new(a.profile().unwrap().clone(), F).unwrap() {
                        sum = sum.wrapping_add(e);
                    }
                }
                black_box(sum)
            })
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
