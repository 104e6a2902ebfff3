//! The simulator against exact references: energy conservation, the closed-form pull-out
//! bound, dt convergence, the damping ratio it claims, and moves that must or must not lose.

use multistep_core::{EdgeGenerator, Profile, Segment, DEFAULT_CLOCK_HZ};
use multistep_sim::analysis::pull_out_bound;
use multistep_sim::experiments::phase_move;
use multistep_sim::{simulate_edges, simulate_profile, DriverMode, Motor, SimConfig, SimResult};
use proptest::prelude::*;

fn phases(family: &str, steps: u64, ta: f64, tb: f64, tc: f64) -> Profile {
    phase_move(family, steps, [ta, tb, tc]).unwrap()
}

fn run(m: &Motor, cfg: &SimConfig, p: Profile) -> SimResult {
    simulate_profile(m, cfg, p, DEFAULT_CLOCK_HZ, 1.0).unwrap()
}

/// 57 mm motor, 256 microsteps: seed 001's setup without load.
fn seed001() -> (Motor, SimConfig) {
    let m = Motor::load("57mm").unwrap();
    let mut cfg = SimConfig::for_motor(&m);
    cfg.driver.microsteps = 256;
    (m, cfg)
}

#[test]
fn energy_balances_over_a_move() {
    let m = Motor::load("42mm").unwrap();
    let cfg = SimConfig::for_motor(&m);
    // 10 revolutions in 0.3 s: back-EMF reaches about 60 % of the supply, the loop saturates.
    let r = run(&m, &cfg, phases("trapezoid", 32000, 0.1, 0.1, 0.1));
    assert_eq!(r.lost_steps, 0);
    let e = r.energy.unwrap();
    assert!(e.electrical_input_j > 0.5, "{e:?}");
    assert!(e.mechanical_work_j > 0.05, "{e:?}");
    let rel = e.residual().abs() / e.electrical_input_j;
    assert!(rel < 1e-6, "energy residual {} of {:?}", rel, e);
}

/// Largest load torque the motor carries at constant shaft speed `omega` (rad/s) after a slow
/// ramp, by bisection; plus the drag the motor itself needs there.
fn simulated_pull_out(m: &Motor, cfg: &SimConfig, omega: f64, upper: f64) -> (f64, f64) {
    let micro = m.microstep_angle(cfg.driver.microsteps);
    let v = omega / micro; // steps/s
    let n1 = (v * 0.1).round() as u64; // ramp of 0.2 s
    let n2 = (v * 0.1).round() as u64; // 0.1 s at speed
    let segs = [
        Segment {
            v0: 0.0,
            duration: 2.0 * n1 as f64 / v,
            steps: n1,
        },
        Segment {
            v0: v,
            duration: n2 as f64 / v,
            steps: n2,
        },
    ];
    let profile = Profile::segments(&segs).unwrap();
    let mut cfg = cfg.clone();
    cfg.stop_at_first_loss = true;
    let carries = |t: f64| {
        let mut mm = m.clone();
        mm.load_torque = t;
        let gen = EdgeGenerator::new(profile.clone(), DEFAULT_CLOCK_HZ).unwrap();
        !simulate_edges(&mm, &cfg, gen, DEFAULT_CLOCK_HZ, 1.0)
            .unwrap()
            .lost
    };
    let (mut lo, mut hi) = (0.0, upper);
    assert!(carries(lo), "no load at ω = {omega}");
    assert!(!carries(hi), "carries {hi} N·m at ω = {omega}");
    while hi - lo > 0.003 * upper {
        let mid = 0.5 * (lo + hi);
        if carries(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let drag = (m.viscous_friction + m.iron_loss_eddy) * omega
        + m.coulomb_friction
        + m.iron_loss_hysteresis;
    (lo, drag)
}

#[test]
fn pull_out_torque_is_below_the_analytic_bound_and_close_at_low_speed() {
    let m = Motor::load("42mm").unwrap();
    let cfg = SimConfig::for_motor(&m);
    let hold = m.km() * cfg.driver.current;
    for (k, rev_per_s) in [1.0, 5.0, 10.0, 15.0].into_iter().enumerate() {
        let omega = std::f64::consts::TAU * rev_per_s;
        let bound = pull_out_bound(&m, &cfg.driver, omega).unwrap();
        let (load, drag) = simulated_pull_out(&m, &cfg, omega, 1.3 * hold);
        let electromagnetic = load + drag;
        // Detent ripple (T_d) can add to the electromagnetic torque at some rotor angles only.
        assert!(
            electromagnetic <= bound + m.detent_torque,
            "ω {omega}: {electromagnetic} > bound {bound}"
        );
        if k == 0 {
            assert!(
                electromagnetic >= 0.9 * bound,
                "ω {omega}: {electromagnetic} ≪ bound {bound}"
            );
        }
        eprintln!("ω {omega:7.2} rad/s: simulated pull-out {electromagnetic:.4} N·m, bound {bound:.4} N·m");
    }
}

#[test]
fn halving_dt_converges() {
    // Two edges per µs at top speed: every RK4 step is split at several edges.
    let (mut m, mut cfg) = seed001();
    m.load_inertia = 1.5e-5;
    cfg.trace_interval = Some(1e-4);
    let p = phases("parabolic", 128_000, 0.04, 0.02, 0.04);
    let runs: Vec<SimResult> = [1e-6, 0.5e-6, 0.25e-6]
        .iter()
        .map(|&dt| {
            cfg.dt = dt;
            run(&m, &cfg, p.clone())
        })
        .collect();
    // Largest difference of the following-error history (sampled every 100 µs) between runs.
    let diff = |a: &SimResult, b: &SimResult| {
        let n = a.trace.len().min(b.trace.len());
        assert!(n > 900);
        a.trace[..n]
            .iter()
            .zip(&b.trace[..n])
            .fold(0.0f64, |w, (x, y)| {
                assert!((x.t - y.t).abs() < 1e-12);
                w.max((x.error_deg - y.error_deg).abs())
            })
    };
    let (d1, d2) = (diff(&runs[0], &runs[1]), diff(&runs[1], &runs[2]));
    eprintln!("following-error difference: dt 1 vs 0.5 µs {d1:.2e}°, 0.5 vs 0.25 µs {d2:.2e}°");
    assert!(runs.iter().all(|r| r.lost_steps == 0));
    // 10⁻⁴° is 1/30 000 of the peak error; and the error shrinks as dt does.
    assert!(d1 < 1e-4, "{d1}");
    assert!(d2 < 0.5 * d1, "{d2} vs {d1}");
}

#[test]
fn the_damping_ratio_reported_is_the_one_simulated() {
    // One microstep in ideal mode: a small, linear free oscillation; log decrement gives ζ.
    let mut m = Motor::load("42mm").unwrap();
    m.coulomb_friction = 0.0;
    m.iron_loss_hysteresis = 0.0;
    let mut cfg = SimConfig::for_motor(&m);
    cfg.driver.mode = DriverMode::Ideal;
    cfg.trace_interval = Some(1e-6);
    cfg.settle_max = Some(0.03);
    cfg.settle_tolerance = 1e-6;
    let r = simulate_edges(&m, &cfg, [1000u64].into_iter(), DEFAULT_CLOCK_HZ, 1.0).unwrap();
    // Peaks of |error| after the step (local maxima of the deviation).
    // Deviation from the final equilibrium (the detent shifts it a little off θ*).
    let rest = r.trace.last().unwrap().error_deg;
    let e: Vec<f64> = r.trace.iter().map(|x| x.error_deg - rest).collect();
    let peaks: Vec<f64> = (1..e.len() - 1)
        .filter(|&k| {
            e[k].abs() > e[k - 1].abs() && e[k].abs() >= e[k + 1].abs() && e[k].abs() > 1e-9
        })
        .map(|k| e[k].abs())
        .collect();
    assert!(peaks.len() >= 4, "{peaks:?}");
    // Half-period decrement: ln(x_k / x_{k+1}) = π·ζ/√(1 − ζ²).
    let d = (peaks[1] / peaks[2]).ln();
    let zeta = d / (std::f64::consts::PI.powi(2) + d * d).sqrt();
    assert!(
        (zeta - r.damping_ratio).abs() < 0.01,
        "measured {zeta}, reported {}",
        r.damping_ratio
    );
}

#[test]
fn a_move_far_outside_the_envelope_loses_steps() {
    let (m, cfg) = seed001();
    // 2000° in 100 ms on the unloaded motor: peak 33 000 °/s, far past where back-EMF
    // leaves any torque.
    let r = run(
        &m,
        &cfg,
        phases("trapezoid", 2000 * 256 * 10 / 18, 0.04, 0.02, 0.04),
    );
    assert!(r.lost && r.lost_steps != 0, "{r:?}");
    assert_eq!(r.lost_steps % (4 * 256), 0);
    assert!(r.first_loss_s.unwrap() < 0.1);
}

#[test]
fn a_move_well_inside_the_envelope_loses_nothing() {
    let (m, cfg) = seed001();
    let r = run(
        &m,
        &cfg,
        phases("trapezoid", 360 * 256 * 10 / 18, 0.04, 0.02, 0.04),
    );
    assert!(
        !r.lost && r.lost_steps == 0 && r.first_loss_s.is_none(),
        "{r:?}"
    );
    assert!(r.final_error_deg.abs() < 0.1, "{}", r.final_error_deg);
    assert!(r.peak_following_error_deg < 3.6);
}

#[test]
fn unstable_dt_is_refused_with_the_mode_named() {
    let m = Motor::load("57mm").unwrap();
    let mut cfg = SimConfig::for_motor(&m);
    cfg.dt = 2e-4;
    let e = simulate_edges(&m, &cfg, [10u64].into_iter(), DEFAULT_CLOCK_HZ, 1.0).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("current loop") && msg.contains("dt ≤"),
        "{msg}"
    );
    cfg.driver.mode = DriverMode::Ideal;
    assert!(simulate_edges(&m, &cfg, [10u64].into_iter(), DEFAULT_CLOCK_HZ, 1.0).is_ok());
}

#[test]
fn backwards_edges_are_an_error() {
    let m = Motor::load("42mm").unwrap();
    let cfg = SimConfig::for_motor(&m);
    let e = simulate_edges(&m, &cfg, [100u64, 50].into_iter(), DEFAULT_CLOCK_HZ, 1.0);
    assert!(e.unwrap_err().to_string().contains("backwards"));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// The model is odd in θ (no load torque): a reversed move is the exact mirror.
    #[test]
    fn reversed_moves_mirror(steps in 50u64..3000, ta in 0.01f64..0.05, tb in 0.0f64..0.02) {
        let m = Motor::load("42mm").unwrap();
        let cfg = SimConfig::for_motor(&m);
        let p = phases("scurve", steps, ta, tb, ta);
        let f = simulate_profile(&m, &cfg, p.clone(), DEFAULT_CLOCK_HZ, 1.0).unwrap();
        let b = simulate_profile(&m, &cfg, p, DEFAULT_CLOCK_HZ, -1.0).unwrap();
        prop_assert_eq!(f.steps, steps);
        prop_assert_eq!(f.lost_steps, b.lost_steps);
        prop_assert!((f.max_following_error_deg - b.max_following_error_deg).abs() < 1e-9);
        prop_assert!((f.final_error_deg - b.final_error_deg).abs() < 1e-9);
    }
}
