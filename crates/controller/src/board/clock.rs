//! Tracking and moves kept to host time on a board whose crystal is off
//! (crate::clock_rate): the host's readings of the board's tick counter are fitted, each
//! tracking axis is given its rate in board ticks, `rate·10^9/(10^9 + ppb)`, again
//! whenever the fit moves by [`RETUNE_PPB`], and a move's phase times are stretched to
//! the board's seconds (`Board::spec`).

use super::Board;
use crate::clock_rate::{board_rate, ClockEstimator, ClockFit, Reading, RETUNE_PPB};
use crate::domain::MoveOpts;
use crate::error::CtlError;
use crate::tracking::track_error;
use multistep_core::Rate;

/// The board's clock as the host sees it.
pub(crate) struct BoardClock {
    estimator: ClockEstimator,
    /// Rates are corrected (once there is a fit).
    correct: bool,
    /// The rate error (ppb) the trackers run on.
    applied: i64,
}

impl BoardClock {
    pub(crate) fn new(clock_hz: f64) -> BoardClock {
        BoardClock {
            estimator: ClockEstimator::new(clock_hz),
            correct: true,
            applied: 0,
        }
    }
}

/// What `status` says of the board's clock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockState {
    /// The fitted rate error (ppm; `None` before enough readings).
    pub ppm: Option<f64>,
    /// Tracking rates are corrected by it now.
    pub correcting: bool,
    /// The rate error (ppm) the trackers run on (0 while not correcting).
    pub applied_ppm: f64,
}

impl Board {
    /// Adds a host-stamped reading of the board's tick counter (see
    /// [`crate::clock_rate::Reading`]); once the fit moved by [`RETUNE_PPB`] from the
    /// rate error the trackers run on, every tracking axis gets its corrected rate.
    pub fn clock_reading(&mut self, r: Reading) -> Result<Option<ClockFit>, CtlError> {
        let fit = self.clock.estimator.add(r)?;
        self.retune();
        Ok(fit)
    }

    /// Whether tracking rates follow host time (`true`, the default) or the board's
    /// crystal.
    pub fn set_clock_correction(&mut self, on: bool) {
        self.clock.correct = on;
        self.retune();
    }

    /// The board's clock as fitted, and whether tracking is corrected by it.
    pub fn clock_state(&self) -> ClockState {
        let ppm = self.clock.estimator.fit().map(|f| f.ppm);
        ClockState {
            ppm,
            correcting: self.clock.correct && ppm.is_some(),
            applied_ppm: self.clock.applied as f64 / 1e3,
        }
    }

    /// Whether tracking is corrected, once the clock is fitted (`status`'s `clock_fix`).
    pub(super) fn clock_fix(&self) -> Option<bool> {
        let c = self.clock_state();
        c.ppm.map(|_| c.correcting)
    }

    /// Reads the board's tick counter through its backend, where it has one (an FPGA
    /// board's `Ticks`), into the fit; a counter that may have restarted starts the fit
    /// again. Returns the fit.
    pub fn read_clock(&mut self) -> Option<ClockFit> {
        let (r, restarted) = self.pins.tick_reading()?;
        if restarted {
            self.clock_restarted();
        }
        match self.clock_reading(r) {
            Ok(fit) => fit,
            // older than the last reading: the count went back, so it restarted
            Err(_) => {
                self.clock_restarted();
                self.clock_reading(r).ok().flatten()
            }
        }
    }

    /// The board's counter restarted (a reset board): its readings so far are forgotten.
    pub fn clock_restarted(&mut self) {
        self.clock.estimator.restart();
    }

    /// The clock a move's edges are played on ([`crate::backend::Launch::clock_hz`]): the
    /// board's; on a board whose crystal the host corrects, for a limits-mode move (`opts`
    /// resolved, without phase times), the board's ticks in one host second,
    /// `clock_hz·(1 + ppb·10⁻⁹)` to the whole Hz (0.02 ppm at 25 MHz, under the fit's own
    /// error), so the move keeps its limits in host seconds and lasts its host time. Phase
    /// times are stretched instead ([`Board::spec`]), so those moves play on the board's
    /// clock.
    pub fn play_clock(&self, opts: &MoveOpts) -> f64 {
        match self.move_time_scale() {
            Some(f) if !opts.has_phase_times() => (self.clock_hz * f).round(),
            _ => self.clock_hz,
        }
    }

    /// How many of this board's seconds one host second is (`1 + ε`), once moves are
    /// corrected; `None` while they run on the crystal (no fit, or correction off).
    pub(super) fn move_time_scale(&self) -> Option<f64> {
        (self.clock.applied != 0).then_some(1.0 + self.clock.applied as f64 * 1e-9)
    }

    /// `rate` (steps a host second) as the tracker on this board is given it.
    pub(super) fn tracker_rate(&self, rate: Rate) -> Result<Rate, CtlError> {
        board_rate(rate, self.clock.applied).map_err(track_error)
    }

    /// Gives the trackers the rate error fitted now, when it moved far enough from the one
    /// they run on.
    fn retune(&mut self) {
        let want = match self.clock.estimator.fit() {
            Some(f) if self.clock.correct => Some(f.ppb()),
            _ => None,
        };
        let applied = self.clock.applied;
        let moved = match want {
            Some(w) => (w - applied).abs() >= RETUNE_PPB,
            None => applied != 0,
        };
        if !moved {
            return;
        }
        self.clock.applied = want.unwrap_or(0);
        for i in 0..self.axes.len() {
            let Some(m) = self.axes[i].motion.as_ref() else {
                continue;
            };
            // a stop under way, or a reversal waiting for it, keeps its ramp
            let Some(host) = m
                .track
                .as_ref()
                .and_then(|t| t.cruising())
                .filter(|_| !m.stopping)
            else {
                continue;
            };
            let Ok(rate) = self.tracker_rate(host) else {
                continue;
            };
            if let Some(src) = self.pins.tracking().ok().and_then(|t| t.tracker(i)) {
                // a rate the tracker refuses leaves it on the one it has
                let _ = src.set_rate(rate);
            }
        }
    }
}
