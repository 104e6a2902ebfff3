//! The moves every implementation runs: limits-mode trapezoids from rest to rest at 50 MHz,
//! the form Austin, Eiderman and ramp-maker all take (vmax, amax, N). Each is chosen so
//! its phase times are whole ticks and its phases whole steps, so every implementation,
//! seed 000's segment registers included, can express exactly the same move.

use multistep_core::int::{IntClock, IntLimitsMove, IntProfile};
use multistep_core::{Family, LimitsMove, Move, Order, PhaseMove, PlanError, Profile};
use serde::Serialize;

/// Seed 000's clock.
pub const CLOCK_HZ: u64 = 50_000_000;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct BenchMove {
    pub name: &'static str,
    pub steps: u64,
    /// steps/s and steps/s².
    pub vmax: u64,
    pub amax: u64,
}

/// seed 000's run (20/10/20 ms), a slow move, a fast long one, a long ramp, a triangle, and
/// a cruise at 32 000 steps/s: 1562.5 ticks a step, every other step on an exact half tick
/// (ramps of 0.125 s, so the float profile's times are exact too).
pub const MOVES: [BenchMove; 6] = [
    BenchMove {
        name: "seed000-2400",
        steps: 2_400,
        vmax: 80_000,
        amax: 4_000_000,
    },
    BenchMove {
        name: "slow-5k",
        steps: 5_000,
        vmax: 2_000,
        amax: 8_000,
    },
    BenchMove {
        name: "fast-1M",
        steps: 1_000_000,
        vmax: 200_000,
        amax: 2_000_000,
    },
    BenchMove {
        name: "long-ramp-400k",
        steps: 400_000,
        vmax: 100_000,
        amax: 50_000,
    },
    BenchMove {
        name: "triangle-20k",
        steps: 20_000,
        vmax: 100_000,
        amax: 500_000,
    },
    BenchMove {
        name: "half-tick-1M",
        steps: 1_000_000,
        vmax: 32_000,
        amax: 256_000,
    },
];

/// A phase-mode move of one velocity family (only multistep plans these), from rest to
/// rest at 50 MHz, planned on the clock as `multistep plan` plans it: 10⁶ steps in 2 s
/// accelerating, 6 s cruising, 2 s decelerating, or 2·10⁵ steps all on ramps (1/0/1 s:
/// the dearest edges of each family).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FamilyMove {
    pub name: &'static str,
    #[serde(skip)]
    pub family: Family,
    pub steps: u64,
    /// Accel, cruise and decel times (s).
    #[serde(skip)]
    pub times: [f64; 3],
}

/// 10⁶ steps in 2/6/2 s (`ramps` false) or 2·10⁵ in 1/0/1 s.
const fn family(name: &'static str, family: Family, ramps: bool) -> FamilyMove {
    let (steps, times) = if ramps {
        (200_000, [1.0, 0.0, 1.0])
    } else {
        (1_000_000, [2.0, 6.0, 2.0])
    };
    FamilyMove {
        name,
        family,
        steps,
        times,
    }
}

/// One move per family with a long cruise, and one all on ramps.
pub const FAMILY_MOVES: [FamilyMove; 12] = [
    family("trapezoid-2/6/2", Family::Trapezoid, false),
    family("parabolic-2/6/2", Family::Parabolic, false),
    family(
        "exponential-2/6/2",
        Family::Exponential { rho: 0.25 },
        false,
    ),
    family("sine-2/6/2", Family::Sine, false),
    family("scurve-2/6/2", Family::SCurve { phi: 0.5 }, false),
    family(
        "scurve4-2/6/2",
        Family::SCurve4 { phi: 0.5, psi: 0.5 },
        false,
    ),
    family("trapezoid-1/0/1", Family::Trapezoid, true),
    family("parabolic-1/0/1", Family::Parabolic, true),
    family("exponential-1/0/1", Family::Exponential { rho: 0.25 }, true),
    family("sine-1/0/1", Family::Sine, true),
    family("scurve-1/0/1", Family::SCurve { phi: 0.5 }, true),
    family(
        "scurve4-1/0/1",
        Family::SCurve4 { phi: 0.5, psi: 0.5 },
        true,
    ),
];

impl FamilyMove {
    pub fn profile(&self) -> Result<Profile, PlanError> {
        let [accel_time, cruise_time, decel_time] = self.times;
        let m = PhaseMove {
            steps: self.steps,
            accel_time,
            cruise_time,
            decel_time,
            start_speed: 0.0,
            end_speed: 0.0,
            family: self.family,
        };
        Profile::plan_on_clock(&Move::Phase(m), CLOCK_HZ as f64)
    }
}

impl BenchMove {
    /// Steps of the accel phase (= decel phase): vmax²/(2·amax).
    pub fn ramp_steps(&self) -> u64 {
        self.vmax * self.vmax / (2 * self.amax)
    }

    /// Accel phase in ticks: f·vmax/amax.
    pub fn ramp_ticks(&self) -> u64 {
        CLOCK_HZ * self.vmax / self.amax
    }

    /// Cruise steps and ticks.
    pub fn cruise(&self) -> (u64, u64) {
        let n = self.steps - 2 * self.ramp_steps();
        (n, n * CLOCK_HZ / self.vmax)
    }

    /// Whether the move's phases are whole ticks and whole steps (all of [`MOVES`] are).
    pub fn is_whole(&self) -> bool {
        let (n, t) = self.cruise();
        2 * self.ramp_steps() <= self.steps
            && (self.vmax * self.vmax).is_multiple_of(2 * self.amax)
            && (CLOCK_HZ * self.vmax).is_multiple_of(self.amax)
            && (n * CLOCK_HZ).is_multiple_of(self.vmax)
            && (t > 0 || n == 0)
    }

    pub fn float_profile(&self) -> Result<Profile, PlanError> {
        Profile::plan(&Move::Limits(LimitsMove {
            steps: self.steps,
            order: Order::Trapezoid,
            vmax: self.vmax as f64,
            amax: self.amax as f64,
            jmax: None,
            smax: None,
            start_speed: 0.0,
            end_speed: 0.0,
        }))
    }

    pub fn int_profile(&self) -> Result<IntProfile, multistep_core::int::IntError> {
        IntProfile::limits(
            &IntLimitsMove {
                steps: self.steps,
                vmax: self.vmax,
                amax: self.amax,
                start_speed: 0,
                end_speed: 0,
            },
            IntClock::hz(CLOCK_HZ),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_move_is_whole_ticks_and_steps() {
        for m in MOVES {
            assert!(m.is_whole(), "{m:?}");
            let p = m.int_profile().unwrap();
            // the integer planner did not need to round: total ticks = 2·Ta + cruise
            assert_eq!(p.end_tick(), 2 * m.ramp_ticks() + m.cruise().1, "{m:?}");
            let f = m.float_profile().unwrap();
            assert!((f.duration() * CLOCK_HZ as f64 - p.end_tick() as f64).abs() < 1e-6);
        }
    }
}
