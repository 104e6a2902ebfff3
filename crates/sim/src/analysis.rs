//! Closed-form steady-state limits of the motor and driver, the references the simulator is
//! tested against.

use crate::driver::DriverConfig;
use crate::motor::Motor;

/// Largest electromagnetic torque K_m·i_q at constant shaft speed ω (rad/s) with current
/// amplitude |i| ≤ I and phase-voltage amplitude |v| ≤ `v_max` (DESIGN.md §4 in the rotor
/// frame: v_d = R·i_d − ω_e·L·i_q, v_q = R·i_q + ω_e·L·i_d + K_m·ω, ω_e = N_r·ω).
///
/// The voltage limit is a disk in the (i_d, i_q) plane, centre −A⁻¹·(0, K_m·ω) and radius
/// v_max/|Z|, so the optimum is the top of one disk or a crossing point of the two circles.
/// Returns None when no current satisfies both (the back-EMF alone exceeds the supply).
pub fn max_torque(m: &Motor, current: f64, v_max: f64, omega: f64) -> Option<f64> {
    let (r, x) = (m.resistance, m.rotor_teeth as f64 * omega * m.inductance);
    let z2 = r * r + x * x;
    let e = m.km() * omega;
    let (cx, cy) = (-x * e / z2, -r * e / z2);
    let rho = v_max / z2.sqrt();
    let in_i = |px: f64, py: f64| px.hypot(py) <= current * (1.0 + 1e-12);
    let in_v = |px: f64, py: f64| (px - cx).hypot(py - cy) <= rho * (1.0 + 1e-12);
    let mut best: Option<f64> = None;
    let mut take = |iq: f64| best = Some(best.map_or(iq, |b: f64| b.max(iq)));
    if in_v(0.0, current) {
        take(current);
    }
    if in_i(cx, cy + rho) {
        take(cy + rho);
    }
    // Crossing points of |p| = I and |p − c| = ρ.
    let d = cx.hypot(cy);
    if d > 0.0 && d <= current + rho && d >= (current - rho).abs() {
        let a = (current * current - rho * rho + d * d) / (2.0 * d);
        let h = (current * current - a * a).max(0.0).sqrt();
        let (ux, uy) = (cx / d, cy / d);
        for s in [-1.0, 1.0] {
            let py = a * uy + s * h * ux;
            take(py);
        }
    }
    best.map(|iq| m.km() * iq)
}

/// The bound for this driver. A per-phase H-bridge clamped to ±V can apply a square wave,
/// whose fundamental has amplitude 4V/π: that, not V, bounds the steady-state fundamental.
pub fn pull_out_bound(m: &Motor, d: &DriverConfig, omega: f64) -> Option<f64> {
    max_torque(
        m,
        d.current,
        4.0 / std::f64::consts::PI * d.supply_voltage,
        omega,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn low_speed_bound_is_holding_torque_per_phase() {
        let m = Motor::load("57mm").unwrap();
        let t = max_torque(&m, m.rated_current, 24.0, 1e-3).unwrap();
        assert!((t - m.km() * m.rated_current).abs() < 1e-9);
    }

    /// Brute-force check of the closed form: a fine grid over the current disk.
    #[test]
    fn bound_matches_grid_search() {
        let m = Motor::load("42mm").unwrap();
        for omega in [50.0, 150.0, 300.0, 600.0] {
            let exact = max_torque(&m, 2.0, 24.0, omega);
            let (r, x) = (m.resistance, 50.0 * omega * m.inductance);
            let e = m.km() * omega;
            let mut best = f64::NEG_INFINITY;
            let n = 1000;
            for a in 0..n {
                for b in 0..n {
                    let id = -2.0 + 4.0 * a as f64 / n as f64;
                    let iq = -2.0 + 4.0 * b as f64 / n as f64;
                    let vd = r * id - x * iq;
                    let vq = r * iq + x * id + e;
                    if id.hypot(iq) <= 2.0 && vd.hypot(vq) <= 24.0 {
                        best = best.max(m.km() * iq);
                    }
                }
            }
            match exact {
                Some(t) => assert!(
                    (t - best).abs() < 0.01 * m.km() * 2.0,
                    "ω {omega}: {t} vs {best}"
                ),
                None => assert!(best == f64::NEG_INFINITY, "ω {omega}"),
            }
        }
    }
}
