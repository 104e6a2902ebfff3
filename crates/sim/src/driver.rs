//! The microstepping current-controlled driver (DESIGN.md §4): sinusoidal current references
//! from the commanded microstep angle, and a PI current loop per phase whose output voltage is
//! clamped to the supply (`rl` mode) — or currents that follow the references (`ideal`).

use crate::error::SimError;
use crate::motor::MAX_SUPPLY_VOLTAGE;
use serde::Serialize;

/// How phase currents are produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DriverMode {
    /// PI current loop through the phase R-L circuit, voltage clamped to ±supply.
    Rl,
    /// i = i*: seed 001 eq. (7), T_e = K_m·I·sin(N_r(θ* − θ)).
    Ideal,
}

impl std::str::FromStr for DriverMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "rl" => Ok(DriverMode::Rl),
            "ideal" => Ok(DriverMode::Ideal),
            o => Err(format!("unknown driver mode '{o}' (rl or ideal)")),
        }
    }
}

/// Default current-loop bandwidth: a few kHz is what chopper drivers reach at 20–40 kHz PWM.
pub const DEFAULT_BANDWIDTH_HZ: f64 = 5_000.0;

/// Driver settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DriverConfig {
    pub mode: DriverMode,
    /// Supply voltage, the clamp of each phase voltage (V), up to [`MAX_SUPPLY_VOLTAGE`].
    pub supply_voltage: f64,
    /// Current amplitude I of the references (A).
    pub current: f64,
    /// Microsteps per full step.
    pub microsteps: u32,
    /// Closed-loop bandwidth of the PI current loop (Hz).
    pub bandwidth_hz: f64,
}

impl DriverConfig {
    /// The motor's defaults: rated current, its file's supply and microsteps, `rl` mode.
    pub fn for_motor(m: &crate::Motor) -> DriverConfig {
        DriverConfig {
            mode: DriverMode::Rl,
            supply_voltage: m.supply_voltage,
            current: m.rated_current,
            microsteps: m.microsteps,
            bandwidth_hz: DEFAULT_BANDWIDTH_HZ,
        }
    }

    /// Every setting in its range; the error names the setting.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |field, value, why: &str| {
            Err(SimError::BadSetting {
                field,
                value,
                why: why.to_string(),
            })
        };
        if !(self.supply_voltage.is_finite() && self.supply_voltage > 0.0) {
            return bad("supply", self.supply_voltage, "must be > 0");
        }
        if self.supply_voltage > MAX_SUPPLY_VOLTAGE {
            return bad(
                "supply",
                self.supply_voltage,
                &format!("must be at most {MAX_SUPPLY_VOLTAGE} V"),
            );
        }
        if !(self.current.is_finite() && self.current > 0.0) {
            return bad("current", self.current, "must be > 0");
        }
        if self.microsteps == 0 || self.microsteps > 1 << 16 {
            return bad("microsteps", self.microsteps as f64, "must be 1…65536");
        }
        if !(self.bandwidth_hz.is_finite() && self.bandwidth_hz > 0.0) {
            return bad("bandwidth", self.bandwidth_hz, "must be > 0");
        }
        Ok(())
    }
}

/// PI gains by pole-zero cancellation of the phase's R-L pole: K_p = L·ω_c, K_i = R·ω_c gives
/// a first-order closed loop of bandwidth ω_c while the voltage is not clamped.
#[derive(Clone, Copy, Debug)]
pub struct PiLoop {
    pub kp: f64,
    pub ki: f64,
    pub vmax: f64,
}

impl PiLoop {
    pub fn new(resistance: f64, inductance: f64, cfg: &DriverConfig) -> PiLoop {
        let wc = std::f64::consts::TAU * cfg.bandwidth_hz;
        PiLoop {
            kp: inductance * wc,
            ki: resistance * wc,
            vmax: cfg.supply_voltage,
        }
    }

    /// Phase voltage and the integrator's rate for current error `err` and integrator `z` (V).
    /// Anti-windup: the integrator holds while the clamp is active and the error pushes further.
    #[inline(always)]
    pub fn voltage(&self, err: f64, z: f64) -> (f64, f64) {
        let v = self.kp * err + z;
        if v > self.vmax {
            (self.vmax, if err > 0.0 { 0.0 } else { self.ki * err })
        } else if v < -self.vmax {
            (-self.vmax, if err < 0.0 { 0.0 } else { self.ki * err })
        } else {
            (v, self.ki * err)
        }
    }
}

/// The driver's sine table: (I·cos, I·sin) of the electrical angle of every microstep of one
/// electrical cycle (4 full steps), like the current table of a real microstepping driver.
/// The references at microstep n are entry n mod 4M, the same values sin_cos gives for
/// N_r·θ* = n·2π/(4M), without a transcendental call per edge.
#[derive(Clone, Debug)]
pub struct SineTable {
    entries: Vec<(f64, f64)>,
}

impl SineTable {
    pub fn new(current: f64, microsteps: u32) -> SineTable {
        let n = 4 * microsteps as usize;
        let entries = (0..n)
            .map(|k| {
                let (s, c) = (std::f64::consts::TAU * k as f64 / n as f64).sin_cos();
                (current * c, current * s)
            })
            .collect();
        SineTable { entries }
    }

    /// (i_A*, i_B*) after `count` microsteps in direction `dir` (±1).
    #[inline]
    pub fn at(&self, count: u64, dir: f64) -> (f64, f64) {
        let n = self.entries.len() as u64;
        let k = count % n;
        let k = if dir < 0.0 { (n - k) % n } else { k };
        self.entries[k as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::SineTable;

    #[test]
    fn sine_table_is_the_reference_in_both_directions() {
        let (i, m) = (2.8, 256u32);
        let t = SineTable::new(i, m);
        let step = std::f64::consts::TAU / (4.0 * m as f64);
        for count in [0u64, 1, 255, 256, 1023, 1024, 1025, 115_200, 1 << 40] {
            for dir in [1.0, -1.0] {
                let phase = dir * (count % 1024) as f64 * step;
                let (a, b) = t.at(count, dir);
                assert!((a - i * phase.cos()).abs() < 1e-14, "{count} {dir}");
                assert!((b - i * phase.sin()).abs() < 1e-14, "{count} {dir}");
            }
        }
    }
}
