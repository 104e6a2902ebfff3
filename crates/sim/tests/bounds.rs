//! Inputs the simulator cannot give a meaningful answer for: out-of-range motor and driver
//! values, a run that diverges, and work past the limit are typed errors, never a result.

use multistep_core::{LimitsMove, Profile, DEFAULT_CLOCK_HZ};
use multistep_sim::integrate::{MAX_RK4_STEPS, MIN_DT};
use multistep_sim::motor::{MAX_LOAD_TORQUE_RATIO, MAX_SUPPLY_VOLTAGE};
use multistep_sim::{simulate_profile, Motor, SimConfig, SimError};
use std::time::Instant;

fn trapezoid(steps: u64, vmax: f64, amax: f64) -> Profile {
    Profile::limits(&LimitsMove::trapezoid(steps, vmax, amax)).unwrap()
}

fn simulate(m: &Motor, cfg: &SimConfig, p: Profile) -> Result<multistep_sim::SimResult, SimError> {
    simulate_profile(m, cfg, p, DEFAULT_CLOCK_HZ, 1.0)
}

#[test]
fn load_torque_and_supply_have_upper_bounds() {
    let m = Motor::load("42mm").unwrap();
    let mut heavy = m.clone();
    heavy.load_torque = MAX_LOAD_TORQUE_RATIO * m.holding_torque;
    assert!(heavy.validate().is_ok());
    for t in [heavy.load_torque * 1.001, 1e200, 1e308] {
        heavy.load_torque = t;
        let e = heavy.validate().unwrap_err().to_string();
        assert!(
            e.contains("`load_torque`") && e.contains("10 × holding_torque = 5.9000 N·m"),
            "{e}"
        );
        // a huge value is written compactly, not as hundreds of digits
        assert!(e.len() < 200, "{e}");
    }
    let mut hot = m.clone();
    hot.supply_voltage = MAX_SUPPLY_VOLTAGE;
    assert!(hot.validate().is_ok());
    hot.supply_voltage = 1e308;
    let e = hot.validate().unwrap_err().to_string();
    assert!(
        e.contains("`supply_voltage` = 1e308") && e.contains("1000 V"),
        "{e}"
    );

    let mut cfg = SimConfig::for_motor(&m);
    cfg.driver.supply_voltage = 1e308;
    let e = simulate(&m, &cfg, trapezoid(100, 1000.0, 10_000.0)).unwrap_err();
    assert!(
        matches!(
            e,
            SimError::BadSetting {
                field: "supply",
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn every_library_motor_is_within_the_bounds() {
    for (name, _) in multistep_sim::motor::LIBRARY {
        let m = Motor::load(name).unwrap();
        assert!(m.supply_voltage <= MAX_SUPPLY_VOLTAGE, "{name}");
        assert!(
            m.load_torque <= MAX_LOAD_TORQUE_RATIO * m.holding_torque,
            "{name}"
        );
    }
}

#[test]
fn a_runaway_rotor_is_a_divergence_not_a_result() {
    // 5 N·m against a 0.59 N·m motor with no damping: the rotor accelerates backwards
    // without bound until RK4 can no longer follow it.
    let mut m = Motor::load("42mm").unwrap();
    m.load_torque = 5.0;
    m.damping_ratio = 0.0;
    let cfg = SimConfig::for_motor(&m);
    let e = simulate(&m, &cfg, trapezoid(1000, 1000.0, 10_000.0)).unwrap_err();
    match &e {
        SimError::Diverged { t, what } => {
            assert!(*t > 0.0 && *t < 1.2, "{e}");
            assert!(what.contains("rad/s") && what.contains("2√2"), "{e}");
        }
        other => panic!("expected a divergence, got {other}"),
    }
    assert!(
        e.to_string().starts_with("the simulation diverged at t = "),
        "{e}"
    );
    // The same load with the motor's damping is a stall with a finite answer.
    m.damping_ratio = 0.2;
    let r = simulate(&m, &cfg, trapezoid(1000, 1000.0, 10_000.0)).unwrap();
    assert!(r.lost && r.lost_steps > 0 && r.final_error_deg.is_finite());
}

#[test]
fn dt_below_its_range_is_refused() {
    let m = Motor::load("42mm").unwrap();
    let mut cfg = SimConfig::for_motor(&m);
    for dt in [1e-300, MIN_DT / 2.0, 0.0, f64::NAN] {
        cfg.dt = dt;
        let e = simulate(&m, &cfg, trapezoid(100, 1000.0, 10_000.0)).unwrap_err();
        assert!(
            e.to_string().contains("`dt`") && e.to_string().contains("at least 1e-9 s"),
            "{e}"
        );
    }
    cfg.dt = MIN_DT;
    // 1 ns is allowed: a short move at it is about 10⁷ steps, within the limit
    assert!(multistep_sim::integrate::check_work(&m, &cfg, 0.001, 10).is_ok());
}

#[test]
fn too_much_work_is_refused_before_it_starts() {
    let m = Motor::load("42mm").unwrap();
    let cfg = SimConfig::for_motor(&m);
    let started = Instant::now();
    for p in [
        trapezoid(1000, 1e-3, 1e-3),
        trapezoid(100_000_000, 1000.0, 10_000.0),
    ] {
        let e = simulate(&m, &cfg, p).unwrap_err();
        match &e {
            SimError::TooMuchWork { steps, max, .. } => {
                assert!(*steps > MAX_RK4_STEPS && *max == MAX_RK4_STEPS)
            }
            other => panic!("expected too much work, got {other}"),
        }
        let msg = e.to_string();
        assert!(msg.contains("5e8") && msg.contains("larger dt"), "{msg}");
    }
    assert!(started.elapsed().as_secs_f64() < 1.0);
    // 499 s of move: just under the limit at dt = 1 µs
    let settle = multistep_sim::integrate::settle_max(&m, &cfg);
    let w = multistep_sim::integrate::check_work(&m, &cfg, 499.0, 1000).unwrap();
    assert!((w - (499.0 + settle) * 1e6 - 1000.0).abs() < 2.0, "{w}");
    assert!(multistep_sim::integrate::check_work(&m, &cfg, 500.0, 1000).is_err());
}
