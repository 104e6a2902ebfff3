//! The `multistep bench` comparison as a criterion group: every implementation generating
//! the edges of the same moves (throughput in edges).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use multistep_bench::compare::{drive, Fold};
use multistep_bench::{Impl, Options, MOVES};
use std::hint::black_box;

fn compare(c: &mut Criterion) {
    let opts = Options::quick();
    // seed 000's run and the triangle: short enough for criterion's sample counts
    for m in [MOVES[0], MOVES[4]] {
        let mut g = c.benchmark_group(format!("compare/{}", m.name));
        g.throughput(Throughput::Elements(m.steps));
        for imp in Impl::ALL {
            g.bench_with_input(BenchmarkId::from_parameter(imp.name()), &m, |b, m| {
                b.iter(|| {
                    let mut f = Fold::default();
                    drive(imp, black_box(m), &opts, &mut f);
                    black_box(f.0)
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, compare);
criterion_main!(benches);
