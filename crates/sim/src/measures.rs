//! What a simulation reports: following error, lost steps and when the first loss happened.

use serde::Serialize;
use std::f64::consts::PI;

/// Running measures of one move. Errors are θ* − θ in the direction of the move (rad):
/// positive means the rotor lags.
#[derive(Clone, Debug)]
pub struct Measures {
    nr: f64,
    pub min_error: f64,
    pub max_error: f64,
    pub first_loss: Option<f64>,
    pub peak_speed: f64,
}

impl Measures {
    pub fn new(rotor_teeth: f64) -> Measures {
        Measures {
            nr: rotor_teeth,
            min_error: 0.0,
            max_error: 0.0,
            first_loss: None,
            peak_speed: 0.0,
        }
    }

    /// One sample at time `t`. A step is lost once |N_r·(θ* − θ)| > π: past two full steps the
    /// rotor is pulled into the next electrical cycle (DESIGN.md §4).
    #[inline]
    pub fn observe(&mut self, t: f64, err: f64, speed: f64) {
        self.min_error = self.min_error.min(err);
        self.max_error = self.max_error.max(err);
        self.peak_speed = self.peak_speed.max(speed.abs());
        if self.first_loss.is_none() && (self.nr * err).abs() > PI {
            self.first_loss = Some(t);
        }
    }

    pub fn peak_abs(&self) -> f64 {
        self.max_error.max(-self.min_error)
    }

    /// One electrical cycle = 4 full steps (rad of shaft angle).
    pub fn cycle(&self) -> f64 {
        2.0 * PI / self.nr
    }

    /// Whole electrical cycles the settled rotor is behind (negative: ahead).
    pub fn cycles_lost(&self, final_error: f64) -> i64 {
        (final_error / self.cycle()).round() as i64
    }

    /// Distance from the nearest equilibrium of the current vector (rad).
    pub fn deviation(&self, err: f64) -> f64 {
        err - (err / self.cycle()).round() * self.cycle()
    }
}

/// Energy accounts of a move in `rl` mode (J).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct EnergyBalance {
    /// ∫ v·i dt delivered by the driver.
    pub electrical_input_j: f64,
    /// ∫ R·i² dt.
    pub copper_loss_j: f64,
    /// ∫ (friction + iron loss + D_s·(ω − ω*) + T_L)·ω dt.
    pub mechanical_work_j: f64,
    /// Change of ½L·i² + ½J·ω² + detent potential.
    pub stored_change_j: f64,
}

impl EnergyBalance {
    /// Input minus everything it went to; zero up to integration error.
    pub fn residual(&self) -> f64 {
        self.electrical_input_j - self.copper_loss_j - self.mechanical_work_j - self.stored_change_j
    }
}
