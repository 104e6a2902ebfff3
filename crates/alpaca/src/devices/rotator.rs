//! Rotator: a periodic axis whose turn is 360 units (degrees), with Sync and Reverse.

use super::{angle, is_moving, lock, norm_deg, val, Answer, Device};
use crate::errors::Fault;
use crate::params::Params;
use multistep_controller::protocol::Amount;
use multistep_controller::{AxisSettings, AxisStatus, Controller};
use std::sync::Mutex;

/// Rotator state that is the device's, not the axis's; kept while the server runs.
#[derive(Default)]
pub(super) struct RotatorState {
    /// Sky angle minus mechanical angle, set by Sync (microsteps).
    sync_offset: i64,
    reverse: bool,
    /// Sky angle the last move was sent to.
    target: Option<f64>,
}

impl Device {
    pub(super) fn rotator(
        &self,
        ctl: &Controller,
        r: &Mutex<RotatorState>,
        m: &str,
        put: bool,
        p: &Params,
    ) -> Answer {
        let st = self.status(ctl)?;
        let t = Turn::of(&self.settings(ctl)?);
        let mut r = lock(r);
        match (m, put) {
            ("canreverse", _) => val(true),
            ("ismoving", _) => val(is_moving(&st)),
            ("mechanicalposition", _) => val(t.deg(t.mechanical(&st, &r))),
            ("position", _) => val(t.deg(t.sky(&st, &r))),
            ("targetposition", _) => val(r.target.unwrap_or_else(|| t.deg(t.sky(&st, &r)))),
            ("reverse", false) => val(r.reverse),
            ("reverse", true) => {
                r.reverse = p.bool("Reverse")?;
                Ok(None)
            }
            ("stepsize", _) => val(360.0 / t.period as f64),
            ("halt", _) => self.halt(ctl),
            ("sync", _) => {
                let to = angle(p, "Position")?;
                r.sync_offset = t.steps(to) - t.mechanical(&st, &r);
                r.target = Some(to);
                Ok(None)
            }
            ("move", _) => {
                let to = norm_deg(t.deg(t.sky(&st, &r)) + p.f64("Position")?);
                let mech = t.steps(to) - r.sync_offset;
                self.rotate(ctl, &t, &mut r, mech, to)
            }
            ("moveabsolute", _) => {
                let to = angle(p, "Position")?;
                let mech = t.steps(to) - r.sync_offset;
                self.rotate(ctl, &t, &mut r, mech, to)
            }
            ("movemechanical", _) => {
                let to = angle(p, "Position")?;
                let sky = t.deg((t.steps(to) + r.sync_offset).rem_euclid(t.period));
                self.rotate(ctl, &t, &mut r, t.steps(to), sky)
            }
            _ => Err(Fault::BadRequest(format!("unknown method {m}"))),
        }
    }

    /// An absolute move of the axis to mechanical angle `mech` (steps): the controller
    /// takes the shortest way round, as for every periodic axis.
    fn rotate(
        &self,
        ctl: &Controller,
        t: &Turn,
        r: &mut RotatorState,
        mech: i64,
        sky: f64,
    ) -> Answer {
        let axis = if r.reverse { -mech } else { mech };
        self.move_to(ctl, Amount::Steps(axis.rem_euclid(t.period)))?;
        r.target = Some(sky);
        Ok(None)
    }
}

/// One turn of a rotator axis. Angles are kept in microsteps (sync offset included), so
/// what is read back is exactly a step's angle.
pub(super) struct Turn {
    period: i64,
    steps_per_degree: f64,
}

impl Turn {
    pub(super) fn of(s: &AxisSettings) -> Turn {
        Turn {
            period: s.period.map_or(1, |p| p.max(1) as i64),
            steps_per_degree: s.steps_per_unit,
        }
    }
    /// `deg` (any angle) as microsteps in [0, period).
    pub(super) fn steps(&self, deg: f64) -> i64 {
        ((deg * self.steps_per_degree).round() as i64).rem_euclid(self.period)
    }
    /// Microsteps in [0, period) as degrees in [0, 360).
    pub(super) fn deg(&self, steps: i64) -> f64 {
        norm_deg(steps as f64 / self.steps_per_degree)
    }
    /// The mechanical angle (steps) as the device reports it, reversed or not.
    pub(super) fn mechanical(&self, st: &AxisStatus, r: &RotatorState) -> i64 {
        let sense = if r.reverse { -1 } else { 1 };
        (sense * st.position).rem_euclid(self.period)
    }
    pub(super) fn sky(&self, st: &AxisStatus, r: &RotatorState) -> i64 {
        (self.mechanical(st, r) + r.sync_offset).rem_euclid(self.period)
    }
}
