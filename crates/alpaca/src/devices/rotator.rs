//! Rotator: a periodic axis whose turn is 360 units (degrees), with Sync and Reverse, kept
//! inside the board config's travel (`mapping::rotator_path`) when it has one.

use super::{angle, is_moving, lock, val, Answer, Device};
use crate::errors::Fault;
use crate::mapping::{norm_deg, rotator_path, Travel, Turn};
use crate::params::Params;
use multistep_controller::protocol::Amount;
use multistep_controller::{AxisState, AxisStatus, Controller};
use std::collections::VecDeque;
use std::sync::Mutex;

/// Rotator state that is the device's, not the axis's; kept while the server runs.
#[derive(Default)]
pub(super) struct RotatorState {
    /// Sky angle minus mechanical angle, set by Sync (microsteps).
    sync_offset: i64,
    reverse: bool,
    /// Sky angle the last move was sent to.
    target: Option<f64>,
    /// The config's travel (None: free).
    travel: Option<Travel>,
    /// Relative moves of the path still to make, one after another.
    legs: VecDeque<i64>,
}

impl RotatorState {
    pub(super) fn new(travel: Option<Travel>) -> RotatorState {
        RotatorState {
            travel,
            ..RotatorState::default()
        }
    }
}

impl Device {
    pub(super) fn rotator(
        &self,
        ctl: &Controller,
        rotator: &Mutex<RotatorState>,
        m: &str,
        put: bool,
        p: &Params,
    ) -> Answer {
        let st = self.status(ctl)?;
        let s = self.settings(ctl)?;
        let t = Turn::new(s.period, s.steps_per_unit);
        let mut r = lock(rotator);
        let st = self.next_leg(ctl, &mut r, st)?;
        match (m, put) {
            ("canreverse", _) => val(true),
            ("ismoving", _) => val(moving(&st, &r)),
            ("mechanicalposition", _) => val(t.deg(mechanical(&t, &st, &r))),
            ("position", _) => val(t.deg(sky(&t, &st, &r))),
            ("targetposition", _) => val(r.target.unwrap_or_else(|| t.deg(sky(&t, &st, &r)))),
            ("reverse", false) => val(r.reverse),
            ("reverse", true) => {
                r.reverse = p.bool("Reverse")?;
                Ok(None)
            }
            ("stepsize", _) => val(360.0 / t.period as f64),
            ("halt", _) => {
                r.legs.clear();
                self.halt(ctl)
            }
            ("sync", _) => {
                let to = angle(p, "Position")?;
                r.sync_offset = t.steps(to) - mechanical(&t, &st, &r);
                r.target = Some(to);
                Ok(None)
            }
            ("move", _) => {
                let to = norm_deg(t.deg(sky(&t, &st, &r)) + p.f64("Position")?);
                let mech = t.steps(to) - r.sync_offset;
                self.rotate(ctl, &t, &st, &mut r, mech, to)
            }
            ("moveabsolute", _) => {
                let to = angle(p, "Position")?;
                let mech = t.steps(to) - r.sync_offset;
                self.rotate(ctl, &t, &st, &mut r, mech, to)
            }
            ("movemechanical", _) => {
                let to = angle(p, "Position")?;
                let sky = t.deg((t.steps(to) + r.sync_offset).rem_euclid(t.period));
                self.rotate(ctl, &t, &st, &mut r, t.steps(to), sky)
            }
            _ => Err(Fault::BadRequest(format!("unknown method {m}"))),
        }
    }

    /// A move of the axis to mechanical angle `mech` (steps): the short way when travel
    /// is free, else the way inside the travel; a target outside it is InvalidValue.
    fn rotate(
        &self,
        ctl: &Controller,
        t: &Turn,
        st: &AxisStatus,
        r: &mut RotatorState,
        mech: i64,
        sky: f64,
    ) -> Answer {
        let target = t.axis_target(mech, r.reverse);
        let mut legs: VecDeque<i64> = rotator_path(t, r.travel, st.position, target)
            .map_err(|e| Fault::invalid_value(e.to_string()))?
            .into();
        if let Some(d) = legs.pop_front() {
            self.move_by(ctl, d)?;
        }
        r.legs = legs;
        r.target = Some(sky);
        Ok(None)
    }

    /// A path's next leg, started once the last has ended (clients poll IsMoving or
    /// DeviceState); the axis's status after it.
    pub(super) fn next_leg(
        &self,
        ctl: &Controller,
        r: &mut RotatorState,
        st: AxisStatus,
    ) -> Result<AxisStatus, Fault> {
        if st.state == AxisState::Fault {
            r.legs.clear();
        }
        if is_moving(&st) {
            return Ok(st);
        }
        let Some(d) = r.legs.pop_front() else {
            return Ok(st);
        };
        if let Err(e) = self.move_by(ctl, d) {
            r.legs.clear();
            return Err(e);
        }
        self.status(ctl)
    }

    fn move_by(&self, ctl: &Controller, steps: i64) -> Result<(), Fault> {
        ctl.move_axis(
            &self.axis,
            Amount::Steps(steps),
            false,
            &multistep_controller::protocol::MoveOpts::default(),
        )?;
        Ok(())
    }
}

/// Moving, or legs of its path still to make.
pub(super) fn moving(st: &AxisStatus, r: &RotatorState) -> bool {
    is_moving(st) || !r.legs.is_empty()
}

pub(super) fn mechanical(t: &Turn, st: &AxisStatus, r: &RotatorState) -> i64 {
    t.mechanical(st.position, r.reverse)
}

pub(super) fn sky(t: &Turn, st: &AxisStatus, r: &RotatorState) -> i64 {
    t.sky(st.position, r.reverse, r.sync_offset)
}
