//! `track`: open-ended motion at an exact rate on one axis, rate changes while it runs,
//! reversal through a controlled stop, soft limits, periodic wrap, jog leases, and the
//! named rates (seed 002's constant, fast and slow motion).

use super::{Board, Purpose};
use crate::axis::{AxisState, MAX_POSITION};
use crate::domain::{RateArg, SignedRate, TrackOpts};
use crate::error::CtlError;
use crate::tracking::{in_steps, TrackSource};
use multistep_core::{Rate, TrackLimits};
use std::collections::BTreeMap;

/// What a tracking motion is asked to do.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TrackState {
    /// The rate asked for (steps/s): its magnitude, and whether it runs backwards.
    negative: bool,
    rate: Rate,
    /// A reversal: once the stop under way ends, track this rate the other way.
    then: Option<Rate>,
    /// The tick at which a jog lease lapses (the axis then stops).
    lease: Option<u64>,
    /// The ramps' acceleration and jerk, chosen when tracking started.
    limits: TrackLimits,
}

impl TrackState {
    /// The rate (steps a host second) of a motion that runs on at it: none while a
    /// reversal waits for its stop.
    pub(super) fn cruising(&self) -> Option<Rate> {
        (self.then.is_none() && !self.rate.is_zero()).then_some(self.rate)
    }

    /// The rate as status shows it (signed steps/s).
    pub(crate) fn signed_rate(&self) -> f64 {
        let v = self.rate.to_f64();
        if self.negative {
            -v
        } else {
            v
        }
    }
}

impl Board {
    /// `track AXIS RATE`: from rest, ramps to the rate and runs at it until stopped; on a
    /// tracking axis, changes the rate (through a controlled stop when the sign changes).
    /// `lease_ticks`: the axis stops unless the command comes again within that many
    /// ticks. Returns the rate in steps/s (signed).
    pub fn track(
        &mut self,
        axis: &str,
        rate: &RateArg,
        opts: &TrackOpts,
        lease_ticks: Option<u64>,
        now: u64,
    ) -> Result<f64, CtlError> {
        self.advance(now);
        let i = self.index(axis)?;
        if self.estopped {
            return Err(CtlError::EStopped);
        }
        self.pins.tracking()?;
        let want = self.rate_value(rate)?;
        let s = &self.axes[i].settings;
        let steps = in_steps(want, s.steps_per_unit)?;
        let negative = want.negative && !steps.is_zero();
        let name = &self.axes[i].name;
        let v = steps.to_f64();
        if v > s.vmax * (1.0 + 1e-12) {
            return Err(CtlError::TooFast(format!(
                "axis {name}: {v} steps/s is above vmax {}",
                s.vmax
            )));
        }
        let accel = opts.amax.unwrap_or(s.amax);
        if accel > s.amax * (1.0 + 1e-12) {
            return Err(CtlError::TooFast(format!(
                "axis {name}: amax={accel} steps/s² is above the axis's amax {}",
                s.amax
            )));
        }
        // From the command's arrival: the board's clock lags it when the service is behind
        // (its work budget), and a lease counted from there lapses as the board catches up.
        let lease = lease_ticks.map(|l| now.max(self.now).saturating_add(l));
        let signed = if negative { -v } else { v };
        let tracking = self.axes[i]
            .motion
            .as_ref()
            .is_some_and(|m| m.track.is_some());
        if tracking {
            self.change_rate(i, negative, steps, opts.amax, lease)?;
            return Ok(signed);
        }
        self.check_can_move(i)?;
        if steps.is_zero() {
            return Ok(0.0);
        }
        let limits = TrackLimits {
            amax: accel,
            jmax: s.jmax,
        };
        let at = self.now;
        self.start_tracking(i, negative, steps, limits, lease, at)?;
        Ok(signed)
    }

    fn start_tracking(
        &mut self,
        i: usize,
        negative: bool,
        rate: Rate,
        limits: TrackLimits,
        lease: Option<u64>,
        at: u64,
    ) -> Result<(), CtlError> {
        let dir = if negative { -1 } else { 1 };
        let ready = self.energize_for_motion([i])?.max(at);
        // the tracker runs in board ticks, at the rate that keeps host time
        let src = TrackSource::new(self.clock_hz, limits, self.tracker_rate(rate)?, ready)?;
        self.check_room(i, dir, src.stop_steps_bound())?;
        // The tracker is the step source the backend runs; its open end counts no steps.
        self.launch_source(i, 0, dir, Purpose::Move, ready)?;
        if let Err(e) = self.pins.start_source(i, Box::new(src), dir, ready) {
            self.unlaunch(&[i]);
            return Err(e);
        }
        // Each step is looked at only where a soft limit lies ahead.
        let watch = self.room(i, dir).is_some() && self.limit_ahead(i, dir).is_some();
        if let Ok(t) = self.pins.tracking() {
            t.watch_steps(i, watch);
        }
        let ax = &mut self.axes[i];
        ax.state = AxisState::Tracking;
        if let Some(m) = ax.motion.as_mut() {
            m.track = Some(TrackState {
                negative,
                rate,
                then: None,
                lease,
                limits,
            });
        }
        Ok(())
    }

    /// Steps left before the soft limit in direction `dir` (`None` on a periodic axis).
    fn room(&self, i: usize, dir: i64) -> Option<i64> {
        let ax = &self.axes[i];
        if ax.settings.period.is_some() {
            return None;
        }
        let s = &ax.settings;
        // in motor steps: the slack still to take up that way moves no load
        Some(if dir > 0 {
            s.soft_max.unwrap_or(MAX_POSITION).min(MAX_POSITION) - ax.count + ax.backlash()
                - ax.slack
        } else {
            ax.count - s.soft_min.unwrap_or(-MAX_POSITION).max(-MAX_POSITION) + ax.slack
        })
    }

    /// Refuses a rate whose ramp and stop (`bound` steps at most) would not fit before the
    /// soft limit: a stop during an S-curve ramp waits for the ramp's end.
    fn check_room(&self, i: usize, dir: i64, bound: u64) -> Result<(), CtlError> {
        match self.room(i, dir) {
            Some(room) if room <= bound as i64 => {
                let ax = &self.axes[i];
                let s = &ax.settings;
                let max = MAX_POSITION;
                Err(CtlError::OutOfLimits {
                    axis: ax.name.clone(),
                    target: ax.count as i128 + dir as i128 * bound as i128,
                    min: s.soft_min.unwrap_or(-max).max(-max).to_string(),
                    max: s.soft_max.unwrap_or(max).min(max).to_string(),
                })
            }
            _ => Ok(()),
        }
    }

    fn change_rate(
        &mut self,
        i: usize,
        negative: bool,
        rate: Rate,
        accel: Option<f64>,
        lease: Option<u64>,
    ) -> Result<(), CtlError> {
        let board = self.tracker_rate(rate)?;
        let ax = &mut self.axes[i];
        let name = ax.name.clone();
        let Some(m) = ax.motion.as_mut() else {
            return Ok(());
        };
        let dir = m.dir;
        let Ok(tracking) = self.pins.tracking() else {
            return Ok(());
        };
        let ahead = tracking.steps_ahead(i);
        let Some(src) = tracking.tracker(i) else {
            return Ok(());
        };
        if accel.is_some_and(|a| a != src.limits().amax) {
            return Err(CtlError::syntax(format!(
                "axis {name} is tracking with amax={}: amax is chosen when tracking starts",
                src.limits().amax
            )));
        }
        let Some(t) = m.track.as_mut() else {
            return Ok(());
        };
        let same = t.negative == negative && t.rate == rate;
        if same && (t.then.is_some() || !m.stopping || rate.is_zero()) {
            // The same command again (a jog's renewal): only the lease is new, the
            // stream goes on untouched.
            t.lease = lease;
            return Ok(());
        }
        // a stream at rest may already be closed by the backend: a new rate starts a new
        // one once this one ends, as a reversal does
        let forward = (!src.at_rest() && (dir < 0) == negative) || rate.is_zero();
        let step_rate = if forward { board } else { Rate::ZERO };
        // a reversal's rate is checked now, not when the stop ends
        src.check_rate(board)?;
        // one step may be taken already (the board looks one edge ahead)
        let bound = (src.stop_bound_after(step_rate)? + 1).saturating_add(ahead);
        self.check_room(i, dir, bound)?;
        let ax = &mut self.axes[i];
        let Some(m) = ax.motion.as_mut() else {
            return Ok(());
        };
        let (Some(src), Some(t)) = (
            self.pins.tracking().ok().and_then(|t| t.tracker(i)),
            m.track.as_mut(),
        ) else {
            return Ok(());
        };
        src.set_rate(step_rate)?;
        *t = TrackState {
            negative,
            rate,
            then: (!forward).then_some(rate),
            lease,
            limits: t.limits,
        };
        m.stopping = step_rate.is_zero();
        ax.state = if rate.is_zero() {
            AxisState::Moving
        } else {
            AxisState::Tracking
        };
        Ok(())
    }

    /// A controlled stop of a tracking axis (its tracker's own ramp to rest); false when
    /// the axis is not tracking.
    pub(super) fn stop_tracking(&mut self, i: usize) -> bool {
        let ax = &mut self.axes[i];
        let Some(m) = ax.motion.as_mut() else {
            return false;
        };
        let Some(t) = m.track.as_mut() else {
            return false;
        };
        if let Some(src) = self.pins.tracking().ok().and_then(|t| t.tracker(i)) {
            // A stop is always plannable: the tracker plans it from the speed it has.
            let _ = src.set_rate(Rate::ZERO);
        }
        *t = TrackState {
            rate: Rate::ZERO,
            then: None,
            lease: None,
            ..*t
        };
        m.stopping = true;
        ax.state = AxisState::Moving;
        true
    }

    /// The soft limit in direction `dir` of axis `i`, if it has one.
    fn limit_ahead(&self, i: usize, dir: i64) -> Option<i64> {
        let s = &self.axes[i].settings;
        match dir {
            1 => s.soft_max,
            _ => s.soft_min,
        }
    }

    /// After a step (or a sensor edge) of a tracking axis that is not periodic: a stop
    /// starts while the soft limit ahead is still farther than the stop.
    pub(super) fn track_step(&mut self, i: usize) {
        let Some(m) = self.axes[i].motion.as_ref() else {
            return;
        };
        // without a soft limit ahead, ±1e15 microsteps are centuries away at any rate
        if m.track.is_none() || m.stopping || self.limit_ahead(i, m.dir).is_none() {
            return;
        }
        let dir = m.dir;
        let bound = self
            .pins
            .tracking()
            .ok()
            .and_then(|t| t.tracker(i))
            .map_or(0, |s| s.stop_steps_bound());
        // a board's stream is coded ahead of its count: the stop begins after that
        let ahead = self.pins.tracking().map_or(0, |t| t.steps_ahead(i));
        let bound = bound.saturating_add(ahead);
        if self
            .room(i, dir)
            .is_some_and(|room| room <= bound.min(i64::MAX as u64) as i64)
        {
            self.stop_tracking(i);
        }
    }

    /// A tracking periodic axis's count wraps into `[0, period)` (the same place, renamed).
    pub(super) fn track_wrap(&mut self, i: usize) {
        if self.axes[i]
            .motion
            .as_ref()
            .is_some_and(|m| m.track.is_some())
        {
            self.wrap_into_period(i);
        }
    }

    /// The earliest tick at which a running jog lease lapses.
    pub(super) fn next_lease(&self) -> Option<u64> {
        self.axes
            .iter()
            .filter_map(|a| a.motion.as_ref())
            .filter(|m| !m.stopping)
            .filter_map(|m| m.track.as_ref()?.lease)
            .min()
    }

    /// Stops the tracking axes whose jog lease lapsed by now; false when none did.
    pub(super) fn stop_lapsed_leases(&mut self) -> bool {
        let now = self.now;
        let lapsed: Vec<usize> = (0..self.axes.len())
            .filter(|&i| {
                let m = self.axes[i].motion.as_ref().filter(|m| !m.stopping);
                m.and_then(|m| m.track?.lease).is_some_and(|l| l <= now)
            })
            .collect();
        for &i in &lapsed {
            self.stop_tracking(i);
        }
        !lapsed.is_empty()
    }

    /// A tracking motion came to rest at `end`: a reversal goes on the other way, a rate
    /// asked for as it came to rest goes on the same way.
    pub(super) fn track_ended(&mut self, i: usize, t: TrackState, _dir: i64, end: u64) {
        let Some(rate) = t.then else { return };
        if let Err(e) = self.start_tracking(i, t.negative, rate, t.limits, t.lease, end) {
            let ax = &mut self.axes[i];
            ax.state = AxisState::Fault;
            ax.fault = Some(format!("tracking on after the stop: {e}"));
        }
    }

    /// A rate as given, or the stored rate of that name.
    fn rate_value(&self, rate: &RateArg) -> Result<SignedRate, CtlError> {
        match rate {
            RateArg::Value(r) => Ok(*r),
            RateArg::Preset(name) => {
                let text = self
                    .store
                    .rate(name)?
                    .ok_or_else(|| CtlError::UnknownName {
                        what: "rate",
                        name: name.clone(),
                    })?;
                SignedRate::parse(&text)
                    .ok_or_else(|| CtlError::Store(format!("stored rate {name}: '{text}'")))?
            }
        }
    }

    /// `rate NAME VALUE`: stores a named rate.
    pub fn set_rate_preset(&mut self, name: &str, rate: &SignedRate) -> Result<(), CtlError> {
        let text = rate.to_string();
        self.durably(|st| st.put_rate(name, &text))
    }

    /// Every named rate, as its text.
    pub fn rate_presets(&self) -> Result<BTreeMap<String, String>, CtlError> {
        self.store.rates()
    }
}
