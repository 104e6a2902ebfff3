//! Motor parameters (DESIGN.md §4) and the motor library: TOML files shipped in `motors/`,
//! embedded in the binary so they are found by name, or a user's own file.

use crate::error::SimError;
use serde::Deserialize;
use std::f64::consts::SQRT_2;

/// Highest supply voltage (V): stepper drivers run from 5 V to a few hundred volts of
/// rectified mains, so more than this can only be a mistake.
pub const MAX_SUPPLY_VOLTAGE: f64 = 1000.0;

/// Highest load torque, as a multiple of the holding torque. A load above the holding
/// torque already drags the rotor backwards (a stall to study); ten times it is not a
/// motor sized for its load.
pub const MAX_LOAD_TORQUE_RATIO: f64 = 10.0;

/// One two-phase hybrid stepper motor with its load, SI units throughout.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Motor {
    pub name: String,
    #[serde(default)]
    pub description: String,
    /// N_r (50 for a 1.8° motor).
    #[serde(default = "default_teeth")]
    pub rotor_teeth: u32,
    /// Holding torque with both phases at rated current (N·m).
    pub holding_torque: f64,
    /// Rated phase current, the driver's current amplitude I (A).
    pub rated_current: f64,
    /// Phase resistance R (Ω).
    pub resistance: f64,
    /// Phase inductance L (H).
    pub inductance: f64,
    /// Rotor inertia (kg·m²).
    pub rotor_inertia: f64,
    /// Detent torque amplitude T_d (N·m).
    #[serde(default)]
    pub detent_torque: f64,
    /// Viscous friction B (N·m·s/rad).
    #[serde(default)]
    pub viscous_friction: f64,
    /// Coulomb friction (N·m).
    #[serde(default)]
    pub coulomb_friction: f64,
    /// Iron loss, hysteresis part: a drag torque independent of speed (N·m).
    #[serde(default)]
    pub iron_loss_hysteresis: f64,
    /// Iron loss, eddy-current part: a drag torque proportional to speed (N·m·s/rad).
    #[serde(default)]
    pub iron_loss_eddy: f64,
    /// Damping ratio ζ of the rotor oscillation; sets D_s (DESIGN.md §4).
    #[serde(default = "default_zeta")]
    pub damping_ratio: f64,
    /// Load inertia on the shaft (kg·m²).
    #[serde(default)]
    pub load_inertia: f64,
    /// Constant load torque T_L opposing the move (N·m), 0 to [`MAX_LOAD_TORQUE_RATIO`] ×
    /// `holding_torque`.
    #[serde(default)]
    pub load_torque: f64,
    /// Default driver supply (V), up to [`MAX_SUPPLY_VOLTAGE`].
    #[serde(default = "default_supply")]
    pub supply_voltage: f64,
    /// Default driver microsteps per full step.
    #[serde(default = "default_microsteps")]
    pub microsteps: u32,
}

fn default_teeth() -> u32 {
    50
}
fn default_zeta() -> f64 {
    0.1
}
fn default_supply() -> f64 {
    24.0
}
fn default_microsteps() -> u32 {
    16
}

/// The shipped motor files, by name.
pub const LIBRARY: [(&str, &str); 3] = [
    ("57mm", include_str!("../motors/57mm.toml")),
    ("42mm", include_str!("../motors/42mm.toml")),
    ("20mm", include_str!("../motors/20mm.toml")),
];

impl Motor {
    /// A motor of the library by name, or else the TOML file at that path.
    pub fn load(name_or_file: &str) -> Result<Motor, SimError> {
        if let Some((_, text)) = LIBRARY.iter().find(|(n, _)| *n == name_or_file) {
            return Motor::from_toml(text, name_or_file);
        }
        match std::fs::read_to_string(name_or_file) {
            Ok(text) => Motor::from_toml(&text, name_or_file),
            Err(e) => Err(SimError::UnknownMotor {
                name: name_or_file.to_string(),
                known: LIBRARY.map(|(n, _)| n).join(", "),
                io: e.to_string(),
            }),
        }
    }

    /// Parses and checks one motor file; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<Motor, SimError> {
        let m: Motor = toml::from_str(text).map_err(|e| SimError::MotorFile {
            file: origin.to_string(),
            msg: e.to_string().trim_end().replace('\n', " "),
        })?;
        m.validate()?;
        Ok(m)
    }

    /// Every value in its physical range; the error names the field.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |field, value: f64, why: &str| SimError::BadField {
            motor: self.name.clone(),
            field,
            value,
            why: why.to_string(),
        };
        let positive = [
            ("holding_torque", self.holding_torque),
            ("rated_current", self.rated_current),
            ("resistance", self.resistance),
            ("inductance", self.inductance),
            ("rotor_inertia", self.rotor_inertia),
            ("supply_voltage", self.supply_voltage),
        ];
        for (f, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(f, v, "must be a finite number > 0"));
            }
        }
        let non_negative = [
            ("detent_torque", self.detent_torque),
            ("viscous_friction", self.viscous_friction),
            ("coulomb_friction", self.coulomb_friction),
            ("iron_loss_hysteresis", self.iron_loss_hysteresis),
            ("iron_loss_eddy", self.iron_loss_eddy),
            ("load_inertia", self.load_inertia),
            ("load_torque", self.load_torque),
            ("damping_ratio", self.damping_ratio),
        ];
        for (f, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(f, v, "must be a finite number ≥ 0"));
            }
        }
        if self.supply_voltage > MAX_SUPPLY_VOLTAGE {
            return Err(bad(
                "supply_voltage",
                self.supply_voltage,
                &format!("must be at most {MAX_SUPPLY_VOLTAGE} V"),
            ));
        }
        let max_load = MAX_LOAD_TORQUE_RATIO * self.holding_torque;
        if self.load_torque > max_load {
            return Err(bad(
                "load_torque",
                self.load_torque,
                &format!(
                    "must be at most {MAX_LOAD_TORQUE_RATIO} × holding_torque = {:.4} N·m",
                    multistep_core::Num(max_load)
                ),
            ));
        }
        if self.rotor_teeth == 0 {
            return Err(bad("rotor_teeth", 0.0, "must be ≥ 1"));
        }
        if self.microsteps == 0 {
            return Err(bad("microsteps", 0.0, "must be ≥ 1"));
        }
        if self.detent_torque >= self.km() * self.rated_current {
            return Err(bad(
                "detent_torque",
                self.detent_torque,
                "must be below holding_torque/√2 (the torque amplitude K_m·I at rated_current), \
                 or the rotor has no single equilibrium",
            ));
        }
        Ok(())
    }

    /// K_m = T_hold / (√2·I_rated): holding torque is rated with both phases on (DESIGN.md §4).
    pub fn km(&self) -> f64 {
        self.holding_torque / (SQRT_2 * self.rated_current)
    }

    /// Total inertia J = rotor + load.
    pub fn inertia(&self) -> f64 {
        self.rotor_inertia + self.load_inertia
    }

    /// Small-signal stiffness at rest with ideal current I: d/dθ of K_m·I·sin(N_r·Δθ), plus
    /// the detent's 4N_r·T_d (seed 001 eq. (7) linearised).
    pub fn stiffness(&self, current: f64) -> f64 {
        let nr = self.rotor_teeth as f64;
        nr * self.km() * current + 4.0 * nr * self.detent_torque
    }

    /// Undamped natural frequency of the rotor oscillation, ω_n = √(k/J) (rad/s).
    pub fn natural_frequency(&self, current: f64) -> f64 {
        (self.stiffness(current) / self.inertia()).sqrt()
    }

    /// Damping the motor has on its own, linearised: viscous + eddy-current iron loss.
    fn intrinsic_damping(&self) -> f64 {
        self.viscous_friction + self.iron_loss_eddy
    }

    /// D_s such that the total linear damping gives `damping_ratio` (never negative).
    pub fn oscillation_damping(&self, current: f64) -> f64 {
        let critical = 2.0 * (self.stiffness(current) * self.inertia()).sqrt();
        (self.damping_ratio * critical - self.intrinsic_damping()).max(0.0)
    }

    /// The damping ratio the simulation actually has: ζ = (B + k_e + D_s) / (2√(kJ)).
    pub fn effective_damping_ratio(&self, current: f64) -> f64 {
        let critical = 2.0 * (self.stiffness(current) * self.inertia()).sqrt();
        (self.intrinsic_damping() + self.oscillation_damping(current)) / critical
    }

    /// One microstep in radians of shaft angle for `microsteps` per full step.
    pub fn microstep_angle(&self, microsteps: u32) -> f64 {
        // A full step is a quarter of an electrical cycle: 2π / (4·N_r).
        std::f64::consts::TAU / (4.0 * self.rotor_teeth as f64 * microsteps as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::strategy::Strategy;

    #[test]
    fn library_motors_load_with_their_datasheet_values() {
        let m = Motor::load("57mm").unwrap();
        assert_eq!(m.holding_torque, 1.26);
        assert_eq!(m.inductance, 2.5e-3);
        let m = Motor::load("42mm").unwrap();
        assert_eq!(m.rotor_inertia, 8.2e-6);
        let m = Motor::load("20mm").unwrap();
        assert_eq!(m.load_inertia, 6.7e-7);
        assert_eq!(m.microsteps, 16);
        // 1.8° full step: 1/256 of it in radians.
        let step = Motor::load("57mm").unwrap().microstep_angle(256);
        assert!((step - 1.8f64.to_radians() / 256.0).abs() < 1e-15);
    }

    #[test]
    fn bad_files_name_the_field() {
        let base = LIBRARY[0].1;
        let missing = base.replace("resistance = 0.9\n", "");
        let e = Motor::from_toml(&missing, "x.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("resistance"), "{e}");
        let negative = base.replace("inductance = 2.5e-3", "inductance = -1.0");
        let e = Motor::from_toml(&negative, "x.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`inductance`"), "{e}");
        let typo = base.replace("rotor_inertia", "rotor_inertai");
        let e = Motor::from_toml(&typo, "x.toml").unwrap_err().to_string();
        assert!(e.contains("rotor_inertai"), "{e}");
        let wrong_type = base.replace("rated_current = 2.8", "rated_current = \"2.8 A\"");
        let e = Motor::from_toml(&wrong_type, "x.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("rated_current"), "{e}");
        let e = Motor::load("no-such-motor").unwrap_err().to_string();
        assert!(e.contains("57mm"), "{e}");
    }

    proptest::proptest! {
        /// Any value in any numeric field: the file loads, or the error names that field.
        #[test]
        fn any_numeric_field_value_loads_or_names_the_field(
            field_index in 0usize..9,
            value in proptest::prop_oneof![
                proptest::num::f64::ANY.prop_map(|v| format!("{v:e}")),
                proptest::strategy::Just("nan".to_string()),
                proptest::strategy::Just("-inf".to_string()),
                proptest::strategy::Just("\"x\"".to_string()),
            ],
        ) {
            let fields = ["holding_torque", "rated_current", "resistance", "inductance",
                "rotor_inertia", "detent_torque", "viscous_friction", "load_inertia", "damping_ratio"];
            let field = fields[field_index];
            let text: String = LIBRARY[1].1.lines().map(|l| {
                if l.starts_with(&format!("{field} =")) { format!("{field} = {value}") } else { l.to_string() }
            }).collect::<Vec<_>>().join("\n");
            match Motor::from_toml(&text, "p.toml") {
                Ok(m) => proptest::prop_assert!(m.validate().is_ok()),
                Err(e) => proptest::prop_assert!(e.to_string().contains(field), "{}", e),
            }
        }
    }

    #[test]
    fn oscillation_damping_gives_the_requested_ratio() {
        let m = Motor::load("57mm").unwrap();
        let z = m.effective_damping_ratio(m.rated_current);
        assert!((z - 0.2).abs() < 1e-12, "{z}");
    }
}
