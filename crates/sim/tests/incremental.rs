//! The incremental integrator (edges fed one at a time, as hardware in the loop does)
//! against the batch run on the same move: the same trajectory, grid point by grid point.

use multistep_core::{EdgeGenerator, MoveSpec};
use multistep_sim::integrate::Incremental;
use multistep_sim::{simulate_edges, DriverMode, Motor, SimConfig};

const CLOCK: f64 = 50e6;

fn edges() -> Vec<u64> {
    let p = MoveSpec {
        steps: Some(3200),
        params: multistep_core::MoveParams {
            accel_time: Some(0.02),
            cruise_time: Some(0.01),
            decel_time: Some(0.02),
            ..Default::default()
        },
        ..Default::default()
    }
    .plan()
    .unwrap();
    EdgeGenerator::new(p, CLOCK).unwrap().collect()
}

#[test]
fn incremental_equals_batch_on_a_move() {
    let motor = Motor::load("42mm").unwrap();
    let e = edges();
    for mode in [DriverMode::Ideal, DriverMode::Rl] {
        for dir in [1.0, -1.0] {
            let mut cfg = SimConfig::for_motor(&motor);
            cfg.driver.mode = mode;
            cfg.trace_interval = Some(cfg.dt);
            let batch = simulate_edges(&motor, &cfg, e.iter().copied(), CLOCK, dir).unwrap();
            let mut inc = Incremental::new(&motor, &cfg, CLOCK).unwrap();
            inc.trace = Some(Vec::new());
            for &t in &e {
                // the world looks at the rotor between edges, as the loop does
                inc.advance_to(t.saturating_sub(1));
                inc.edge(t, dir > 0.0).unwrap();
            }
            let tr = inc.trace.take().unwrap();
            // committed up to the last edge but one (the last waits for its successor)
            let last = e[e.len() - 2] as f64 / CLOCK;
            assert!(
                tr.last().unwrap().0 > last - 2.0 * cfg.dt,
                "committed up to the last edge: {:?} of {last}",
                tr.last()
            );
            assert!(tr.len() > 40_000);
            for (i, (t, th)) in tr.iter().enumerate() {
                let row = &batch.trace[i];
                assert_eq!(*t, row.t, "{mode:?} {dir}: grid point {i}");
                assert_eq!(
                    th.to_degrees(),
                    row.actual_deg,
                    "{mode:?} {dir}: rotor at t = {t}"
                );
            }
            assert_eq!(inc.commanded(), dir as i64 * e.len() as i64);
            // after the move the rotor settles where the batch run settles
            inc.advance_to(*e.last().unwrap() + (0.05 * CLOCK) as u64);
            let settled = inc.rotor_microsteps() * dir;
            let want =
                e.len() as f64 - batch.final_error_deg / motor.microstep_angle(16).to_degrees();
            // the batch run stops once within its settle tolerance
            let tol = cfg.settle_tolerance * f64::from(cfg.driver.microsteps);
            assert!((settled - want).abs() < tol, "{settled} vs {want}");
            assert!(
                (settled - e.len() as f64).abs() < 0.05,
                "at rest on the command"
            );
        }
    }
}

#[test]
fn backwards_edges_are_refused() {
    let motor = Motor::load("42mm").unwrap();
    let cfg = SimConfig::for_motor(&motor);
    let mut inc = Incremental::new(&motor, &cfg, CLOCK).unwrap();
    inc.edge(1000, true).unwrap();
    assert!(inc.edge(999, true).is_err());
}
