//! Edges per second for every family (phase mode), segment mode and limits mode, one core.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use multistep_core::{EdgeGenerator, Family, LimitsMove, Move, Order, PhaseMove, Profile, Segment};

const STEPS: u64 = 1_000_000;

fn phase(family: Family) -> Profile {
    Profile::phase(&PhaseMove {
        steps: STEPS,
        accel_time: 2.0,
        cruise_time: 6.0,
        decel_time: 2.0,
        start_speed: 0.0,
        end_speed: 0.0,
        family,
    })
    .unwrap()
}

fn run(p: &Profile) -> u64 {
    let mut acc = 0u64;
    for e in EdgeGenerator::new(p.clone(), 50e6).unwrap() {
        acc = acc.wrapping_add(e);
    }
    acc
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("edges");
    g.throughput(Throughput::Elements(STEPS));
    g.sample_size(20);
    let cases: Vec<(&str, Profile)> = vec![
        ("trapezoid", phase(Family::Trapezoid)),
        (
            "trapezoid-no-cruise",
            Profile::phase(&PhaseMove {
                steps: STEPS,
                accel_time: 5.0,
                cruise_time: 0.0,
                decel_time: 5.0,
                start_speed: 0.0,
                end_speed: 0.0,
                family: Family::Trapezoid,
            })
            .unwrap(),
        ),
        ("parabolic", phase(Family::Parabolic)),
        ("exponential", phase(Family::Exponential { rho: 0.25 })),
        ("sine", phase(Family::Sine)),
        ("scurve", phase(Family::SCurve { phi: 0.5 })),
        ("scurve4", phase(Family::SCurve4 { phi: 0.5, psi: 0.5 })),
        (
            "segments",
            Profile::segments(&[
                Segment {
                    v0: 0.0,
                    duration: 2.0,
                    steps: 100_000,
                },
                Segment {
                    v0: 100_000.0,
                    duration: 8.0,
                    steps: 800_000,
                },
                Segment {
                    v0: 100_000.0,
                    duration: 2.0,
                    steps: 100_000,
                },
            ])
            .unwrap(),
        ),
        (
            "scurve4-limits",
            Profile::plan(&Move::Limits(LimitsMove {
                steps: STEPS,
                order: Order::SCurve4,
                vmax: 1.2e5,
                amax: 1e5,
                jmax: Some(1e5),
                smax: Some(1e6),
                start_speed: 0.0,
                end_speed: 0.0,
            }))
            .unwrap(),
        ),
    ];
    for (name, p) in &cases {
        g.bench_function(*name, |b| b.iter(|| black_box(run(black_box(p)))));
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
