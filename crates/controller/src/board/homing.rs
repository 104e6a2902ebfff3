//! Homing (seed 002 §2.3, with the usual back-off and slow re-approach): the same state
//! machine on every backend. Each phase is a move that the backend stops at a sensor edge
//! ([`crate::backend::Launch::stop_on_sensor`]); the edge's latched count re-references
//! the axis.

use super::{Board, Motion, Purpose};
use crate::axis::AxisState;
use crate::error::CtlError;
use multistep_core::int::IntProfile;
use multistep_core::{MoveParams, MoveSpec, Profile};

/// Phases of homing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum HomePhase {
    /// Started on the sensor: leave it against the homing direction.
    Clear,
    /// Fast search towards the sensor.
    Seek,
    /// Back off past the edge found by the seek.
    Backoff,
    /// Slow re-approach: this edge becomes the home position.
    Approach,
    /// With backlash: past home against the homing direction by the backlash, so that the
    /// last move onto home is in the homing direction and leaves the slack on its side.
    Park,
}

impl HomePhase {
    /// The sensor level whose edge ends this phase's move.
    pub(super) fn stop_on_sensor(self) -> Option<bool> {
        match self {
            HomePhase::Clear => Some(false),
            HomePhase::Seek | HomePhase::Approach => Some(true),
            HomePhase::Backoff | HomePhase::Park => None,
        }
    }
}

impl Board {
    /// Starts homing axis `i` at `now`.
    pub fn home(&mut self, axis: &str, now: u64) -> Result<(), CtlError> {
        self.advance(now);
        let i = self.index(axis)?;
        self.check_can_move(i)?;
        let s = self.axes[i].settings.clone();
        let h = s.home_dir as i64;
        self.axes[i].homed = false;
        self.pins.resync_sensor(i, self.now);
        let start = self.energize_for_motion([i])?;
        let (phase, dir) = if self.pins.sensor(i) {
            (HomePhase::Clear, -h)
        } else {
            (HomePhase::Seek, h)
        };
        self.home_move(i, phase, dir, s.home_search, s.home_speed, start)
    }

    /// A homing move: `steps` at `speed` (at most vmax), accelerating at amax; with the
    /// backend's own plan of it.
    fn home_profile(
        &self,
        i: usize,
        steps: u64,
        speed: f64,
    ) -> Result<(Profile, Option<IntProfile>), CtlError> {
        let s = &self.axes[i].settings;
        let spec = MoveSpec {
            steps: Some(steps),
            params: MoveParams {
                vmax: Some(speed.min(s.vmax)),
                amax: Some(s.amax),
                ..MoveParams::default()
            },
            ..MoveSpec::default()
        };
        Ok((
            spec.plan_on_clock(self.clock_hz)?,
            self.datapath(&spec, self.clock_hz)?,
        ))
    }

    fn home_move(
        &mut self,
        i: usize,
        phase: HomePhase,
        dir: i64,
        steps: u64,
        speed: f64,
        start: u64,
    ) -> Result<(), CtlError> {
        let (p, dp) = self.home_profile(i, steps.max(1), speed)?;
        self.launch(i, p, dp, dir, Purpose::Home(phase), start)?;
        self.axes[i].state = AxisState::Homing;
        Ok(())
    }

    pub(super) fn next_home_phase(
        &mut self,
        i: usize,
        phase: HomePhase,
        m: &Motion,
        end: u64,
    ) -> Result<(), CtlError> {
        let ax = &self.axes[i];
        let s = ax.settings.clone();
        let h = s.home_dir as i64;
        let fail = |why: &str| CtlError::Homing {
            axis: ax.name.clone(),
            why: why.to_string(),
        };
        match phase {
            HomePhase::Clear => {
                if m.edge.is_none() || self.pins.sensor(i) {
                    return Err(fail("could not leave the sensor"));
                }
                self.home_move(i, HomePhase::Seek, h, s.home_search, s.home_speed, end)
            }
            HomePhase::Seek => {
                let Some(edge) = m.edge else {
                    return Err(fail("sensor not found within home_search steps"));
                };
                // motor counts both; the slack is crossed as well, so that the
                // re-approach meets the edge with it taken up towards home_dir
                let over = (self.pins.count(i) - edge.count_at_start).unsigned_abs();
                self.home_move(
                    i,
                    HomePhase::Backoff,
                    -h,
                    over + s.home_backoff + s.backlash,
                    s.home_speed,
                    end,
                )
            }
            HomePhase::Backoff => {
                if self.pins.sensor(i) {
                    return Err(fail("sensor still active after backing off"));
                }
                let reach = 2 * s.home_backoff + 16 + 2 * s.backlash;
                self.home_move(
                    i,
                    HomePhase::Approach,
                    h,
                    reach,
                    s.effective_slow_speed(),
                    end,
                )
            }
            HomePhase::Approach => {
                let Some(edge) = m.edge else {
                    return Err(fail("sensor lost on the slow re-approach"));
                };
                // The edge is home: re-reference the load's count, then park on it.
                let b = s.backlash as i64;
                let slack = super::slack_after(m.slack0, edge.count_at_start - m.motor0, b);
                self.rebase(i, s.home_offset - (edge.count_at_start - slack), false)?;
                let ax = &mut self.axes[i];
                ax.homed = true;
                ax.trusted = true;
                ax.drift = None;
                let back = s.home_offset - ax.count;
                if b > 0 && back.signum() == -h {
                    let steps = ax.motor_steps(back - h * b);
                    return self.home_move(i, HomePhase::Park, -h, steps, s.home_speed, end);
                }
                self.park(i, back, end)
            }
            HomePhase::Park => {
                let back = s.home_offset - ax.count;
                self.park(i, back, end)
            }
        }
    }

    /// The last move of homing: `back` steps onto home.
    fn park(&mut self, i: usize, back: i64, end: u64) -> Result<(), CtlError> {
        if back != 0 {
            let steps = self.axes[i].motor_steps(back);
            let speed = self.axes[i].settings.home_speed;
            let (p, dp) = self.home_profile(i, steps, speed)?;
            self.launch(i, p, dp, back.signum(), Purpose::Move, end)?;
        }
        Ok(())
    }
}
