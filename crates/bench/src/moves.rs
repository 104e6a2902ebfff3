//! The moves every implementation runs: limits-mode trapezoids from rest to rest at 50 MHz,
//! the form Austin, Eiderman and ramp-maker all take (vmax, amax, N). Each is chosen so
//! its phase times are whole ticks and its phases whole steps, so every implementation,
//! seed 000's segment registers included, can express exactly the same move.

use multistep_core::int::{IntClock, IntLimitsMove, IntProfile};
use multistep_core::{LimitsMove, Move, Order, PlanError, Profile};
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

/// seed 000's run (20/10/20 ms), a slow move, a fast long one, a long ramp and a triangle.
pub const MOVES: [BenchMove; 5] = [
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
];

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
            && self.vmax * self.vmax % (2 * self.amax) == 0
            && CLOCK_HZ * self.vmax % self.amax == 0
            && n * CLOCK_HZ % self.vmax == 0
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
