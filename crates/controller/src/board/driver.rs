//! The driver's ENABLE line (seed 002's "offline" signal): energized before motion, with
//! a settling time; released on command or after a time at rest. A released motor may be
//! turned by hand, so its count is no longer vouched for unless the axis holds its
//! position without current (`release_keeps_position`).

use super::Board;
use crate::axis::AxisState;
use crate::error::CtlError;

/// One axis's driver.
#[derive(Clone, Copy, Debug)]
pub(super) struct Driver {
    /// The ENABLE line is active.
    pub enabled: bool,
    /// First tick at which the energized driver may step.
    pub ready_at: u64,
    /// Tick at which the axis came to rest.
    pub idle_since: u64,
}

impl Default for Driver {
    /// Energized: a board holds its motors from power-up, as before it went down.
    fn default() -> Self {
        Driver {
            enabled: true,
            ready_at: 0,
            idle_since: 0,
        }
    }
}

impl Board {
    /// Energizes the drivers of `axes` that are released (through the backend); returns
    /// the first tick at which all of them may step (now, or later by `enable_settle`).
    pub(super) fn energize_for_motion(
        &mut self,
        axes: impl IntoIterator<Item = usize>,
    ) -> Result<u64, CtlError> {
        let now = self.now;
        let mut ready = now;
        for i in axes {
            let ax = &mut self.axes[i];
            if !ax.driver.enabled {
                self.pins.set_enabled(i, true)?;
                ax.driver.enabled = true;
                ax.driver.ready_at = now + settle_ticks(ax.settings.enable_settle, self.clock_hz);
            }
            ready = ready.max(ax.driver.ready_at);
        }
        Ok(ready)
    }

    /// `energize AXIS`: the driver holds the motor from now (the first step waits for
    /// `enable_settle`).
    pub fn energize(&mut self, axis: &str, now: u64) -> Result<(), CtlError> {
        self.advance(now);
        let i = self.index(axis)?;
        self.energize_for_motion([i])?;
        self.axes[i].driver.idle_since = self.now;
        Ok(())
    }

    /// `release AXIS`: de-energizes an axis at rest.
    pub fn release(&mut self, axis: &str, now: u64) -> Result<(), CtlError> {
        self.advance(now);
        let i = self.index(axis)?;
        self.check_at_rest(i)?;
        self.release_axis(i)
    }

    fn release_axis(&mut self, i: usize) -> Result<(), CtlError> {
        let ax = &mut self.axes[i];
        if !ax.driver.enabled {
            return Ok(());
        }
        self.pins.set_enabled(i, false)?;
        ax.driver.enabled = false;
        if !ax.settings.release_keeps_position {
            ax.trusted = false;
            self.persist(i);
        }
        Ok(())
    }

    /// Whether an energized axis at rest waits for its `idle_release`.
    pub(super) fn release_pending(&self) -> bool {
        self.axes
            .iter()
            .any(|a| a.motion.is_none() && a.driver.enabled && a.settings.idle_release.is_some())
    }

    /// Releases the axes that have rested `idle_release` seconds by now.
    pub(super) fn release_idle(&mut self) {
        for i in 0..self.axes.len() {
            let ax = &self.axes[i];
            let Some(after) = ax.settings.idle_release else {
                continue;
            };
            let idle =
                ax.motion.is_none() && matches!(ax.state, AxisState::Idle | AxisState::Fault);
            let since = ax.driver.idle_since.max(ax.driver.ready_at);
            if idle
                && ax.driver.enabled
                && self.now >= since.saturating_add(settle_ticks(after, self.clock_hz))
            {
                if let Err(e) = self.release_axis(i) {
                    if self.warnings.len() < 100 {
                        self.warnings
                            .push(format!("axis {}: release: {e}", self.axes[i].name));
                    }
                }
            }
        }
    }
}

/// Seconds as whole board ticks, rounded up (a driver never gets less than asked for).
fn settle_ticks(seconds: f64, clock_hz: f64) -> u64 {
    (seconds * clock_hz).ceil().clamp(0.0, 1e18) as u64
}
