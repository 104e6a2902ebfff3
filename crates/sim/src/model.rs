//! The two-phase hybrid stepper's equations (DESIGN.md §4, seed 001 eqs. (1)–(8) in the
//! standard two-phase form) as the right-hand side of an ODE.

use crate::driver::{DriverConfig, DriverMode, PiLoop};
use crate::motor::Motor;

/// Indices of the state vector.
pub const TH: usize = 0; // rotor angle θ (rad)
pub const OM: usize = 1; // rotor speed ω (rad/s)
pub const IA: usize = 2; // phase currents (A)
pub const IB: usize = 3;
pub const ZA: usize = 4; // PI integrators (V)
pub const ZB: usize = 5;
pub const E_IN: usize = 6; // electrical energy in from the driver (J)
pub const E_CU: usize = 7; // copper loss R·i² (J)
pub const E_MECH: usize = 8; // work done by friction, iron loss, D_s and load (J)
pub const NSTATE: usize = 9;

pub type State = [f64; NSTATE];

/// Below this speed Coulomb and hysteresis drag are linear in ω instead of sign(ω), so the
/// right-hand side stays Lipschitz and RK4 does not chatter at rest (rad/s).
pub const COULOMB_SMOOTHING: f64 = 0.05;

/// What the driver holds constant between two edges.
#[derive(Clone, Copy, Debug, Default)]
pub struct Command {
    pub ia_ref: f64,
    pub ib_ref: f64,
    /// ω* (rad/s), for the oscillation damping D_s·(ω − ω*).
    pub omega_ref: f64,
}

/// Motor + driver constants, premultiplied for the inner loop.
#[derive(Clone, Copy, Debug)]
pub struct Plant {
    pub nr: f64,
    pub km: f64,
    pub r: f64,
    pub l: f64,
    pub j: f64,
    inv_j: f64,
    inv_l: f64,
    pub td: f64,
    /// Viscous B plus eddy iron loss: linear drag (N·m·s/rad).
    pub b_lin: f64,
    /// Coulomb plus hysteresis iron loss: constant drag (N·m).
    pub t_dry: f64,
    pub ds: f64,
    /// Load torque with the sign that opposes the move (N·m).
    pub tl: f64,
    pub pi: PiLoop,
    pub mode: DriverMode,
    pub current: f64,
}

impl Plant {
    /// `direction` is +1 or −1: a load torque opposes the move.
    pub fn new(m: &Motor, d: &DriverConfig, direction: f64) -> Plant {
        Plant {
            nr: m.rotor_teeth as f64,
            km: m.km(),
            r: m.resistance,
            l: m.inductance,
            j: m.inertia(),
            inv_j: 1.0 / m.inertia(),
            inv_l: 1.0 / m.inductance,
            td: m.detent_torque,
            b_lin: m.viscous_friction + m.iron_loss_eddy,
            t_dry: m.coulomb_friction + m.iron_loss_hysteresis,
            ds: m.oscillation_damping(d.current),
            tl: m.load_torque * direction.signum(),
            pi: PiLoop::new(m.resistance, m.inductance, d),
            mode: d.mode,
            current: d.current,
        }
    }

    /// Drag torques that are not the load: B·ω + dry friction (smoothed sign).
    #[inline(always)]
    fn drag(&self, w: f64) -> f64 {
        self.b_lin * w + self.t_dry * (w / COULOMB_SMOOTHING).clamp(-1.0, 1.0)
    }

    /// Phase voltages the driver applies in state `x` (0 in ideal mode).
    #[inline(always)]
    pub fn voltages(&self, x: &State, u: &Command) -> (f64, f64, f64, f64) {
        let (va, dza) = self.pi.voltage(u.ia_ref - x[IA], x[ZA]);
        let (vb, dzb) = self.pi.voltage(u.ib_ref - x[IB], x[ZB]);
        (va, vb, dza, dzb)
    }

    /// dx/dt. In ideal mode the currents are the references and only θ, ω move.
    #[inline(always)]
    pub fn rhs<const IDEAL: bool>(&self, x: &State, u: &Command) -> State {
        let (s, c) = (self.nr * x[TH]).sin_cos();
        self.rhs_at::<IDEAL>(x, u, s, c)
    }

    /// dx/dt given sin and cos of the electrical angle N_r·θ of `x`.
    #[inline(always)]
    pub fn rhs_at<const IDEAL: bool>(&self, x: &State, u: &Command, s: f64, c: f64) -> State {
        let w = x[OM];
        let (ia, ib) = if IDEAL {
            (u.ia_ref, u.ib_ref)
        } else {
            (x[IA], x[IB])
        };
        // sin(4φ) = 2·sin(2φ)·cos(2φ) from sin φ, cos φ: no second transcendental call.
        let sin4 = 4.0 * s * c * (c * c - s * s);
        let te = self.km * (ib * c - ia * s) - self.td * sin4;
        let drag = self.drag(w);
        let damp = self.ds * (w - u.omega_ref);
        let mut dx = [0.0; NSTATE];
        dx[TH] = w;
        dx[OM] = (te - drag - damp - self.tl) * self.inv_j;
        dx[E_MECH] = (drag + damp + self.tl) * w;
        if !IDEAL {
            // back-EMF e_A = −K_m·ω·sin(N_r θ), e_B = K_m·ω·cos(N_r θ)
            let (ea, eb) = (-self.km * w * s, self.km * w * c);
            let (va, vb, dza, dzb) = self.voltages(x, u);
            dx[IA] = (va - self.r * ia - ea) * self.inv_l;
            dx[IB] = (vb - self.r * ib - eb) * self.inv_l;
            dx[ZA] = dza;
            dx[ZB] = dzb;
            dx[E_IN] = va * ia + vb * ib;
            dx[E_CU] = self.r * (ia * ia + ib * ib);
        }
        dx
    }

    /// Energy held in the state: ½L·i² + ½J·ω² + detent potential (J). The detent torque
    /// −T_d·sin(4N_r θ) is −dU/dθ with U = −T_d·cos(4N_r θ)/(4N_r).
    pub fn stored_energy(&self, x: &State) -> f64 {
        0.5 * self.l * (x[IA] * x[IA] + x[IB] * x[IB]) + 0.5 * self.j * x[OM] * x[OM]
            - self.td * (4.0 * self.nr * x[TH]).cos() / (4.0 * self.nr)
    }
}

/// sin and cos of φ + δ from those of φ. For |δ| < 0.02 the angle-addition formula with
/// Taylor terms through δ⁷ is exact to f64 rounding (next term δ⁸/8! < 10⁻¹⁸) and avoids a
/// transcendental call; RK4's inner stages move the electrical angle by far less than that.
#[inline(always)]
pub fn sin_cos_shifted(s: f64, c: f64, phi: f64, delta: f64) -> (f64, f64) {
    if delta.abs() >= 0.02 {
        return (phi + delta).sin_cos();
    }
    let d2 = delta * delta;
    let cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0 - d2 * (1.0 / 720.0)));
    let sd = delta * (1.0 - d2 * (1.0 / 6.0 - d2 * (1.0 / 120.0 - d2 * (1.0 / 5040.0))));
    (s * cd + c * sd, c * cd - s * sd)
}

#[cfg(test)]
mod tests {
    use super::sin_cos_shifted;

    #[test]
    fn shifted_sin_cos_matches_libm() {
        for k in 0..2000 {
            let phi = -50.0 + 0.0517 * k as f64;
            let delta = -0.03 + 3e-5 * k as f64;
            let (s, c) = phi.sin_cos();
            let (s1, c1) = sin_cos_shifted(s, c, phi, delta);
            let (s2, c2) = (phi + delta).sin_cos();
            assert!(
                (s1 - s2).abs() < 1e-14 && (c1 - c2).abs() < 1e-14,
                "{phi} {delta}"
            );
        }
    }
}
