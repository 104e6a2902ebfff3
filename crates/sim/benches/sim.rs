//! Simulated seconds per wall second, one axis, `rl` mode, dt = 1 µs. Throughput is reported
//! in "elements" = simulated microseconds: elements/s ÷ 10⁶ is simulated s per wall s.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use multistep_core::DEFAULT_CLOCK_HZ;
use multistep_sim::experiments::phase_move;
use multistep_sim::{simulate_profile, Motor, SimConfig};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("simulate_rl_dt1us");
    g.sample_size(20);
    // (label, motor, microsteps, load inertia, steps, accel, cruise, decel)
    let cases = [
        (
            "42mm_16us_5rev_0.3s",
            "42mm",
            16,
            0.0,
            16_000u64,
            0.1,
            0.1,
            0.1,
        ),
        (
            "57mm_256us_810deg_0.1s",
            "57mm",
            256,
            1.78e-5,
            115_200,
            0.04,
            0.02,
            0.04,
        ),
    ];
    for (label, name, micro, jl, steps, ta, tb, tc) in cases {
        let mut m = Motor::load(name).unwrap();
        m.load_inertia = jl;
        let mut cfg = SimConfig::for_motor(&m);
        cfg.driver.microsteps = micro;
        let profile = phase_move("trapezoid", steps, [ta, tb, tc]).unwrap();
        let r = simulate_profile(&m, &cfg, profile.clone(), DEFAULT_CLOCK_HZ, 1.0).unwrap();
        assert_eq!(r.lost_steps, 0);
        g.throughput(Throughput::Elements((r.simulated_s * 1e6).round() as u64));
        g.bench_function(label, |b| {
            b.iter(|| {
                simulate_profile(&m, &cfg, black_box(profile.clone()), DEFAULT_CLOCK_HZ, 1.0)
                    .unwrap()
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
