//! Rotator: a periodic axis whose turn is 360 units (degrees), with Sync and Reverse.

use super::{angle, is_moving, lock, val, Answer, Device};
use crate::errors::Fault;
use crate::mapping::{norm_deg, Turn};
use crate::params::Params;
use multistep_controller::protocol::Amount;
use multistep_controller::{AxisStatus, Controller};
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
        let s = self.settings(ctl)?;
        let t = Turn::new(s.period, s.steps_per_unit);
        let mut r = lock(r);
        match (m, put) {
            ("canreverse", _) => val(true),
            ("ismoving", _) => val(is_moving(&st)),
            ("mechanicalposition", _) => val(t.deg(mechanical(&t, &st, &r))),
            ("position", _) => val(t.deg(sky(&t, &st, &r))),
            ("targetposition", _) => val(r.target.unwrap_or_else(|| t.deg(sky(&t, &st, &r)))),
            ("reverse", false) => val(r.reverse),
            ("reverse", true) => {
                r.reverse = p.bool("Reverse")?;
                Ok(None)
            }
            ("stepsize", _) => val(360.0 / t.period as f64),
            ("halt", _) => self.halt(ctl),
            ("sync", _) => {
                let to = angle(p, "Position")?;
                r.sync_offset = t.steps(to) - mechanical(&t, &st, &r);
                r.target = Some(to);
                Ok(None)
            }
            ("move", _) => {
                let to = norm_deg(t.deg(sky(&t, &st, &r)) + p.f64("Position")?);
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
        self.move_to(ctl, Amount::Steps(t.axis_target(mech, r.reverse)))?;
        r.target = Some(sky);
        Ok(None)
    }
}

pub(super) fn mechanical(t: &Turn, st: &AxisStatus, r: &RotatorState) -> i64 {
    t.mechanical(st.position, r.reverse)
}

pub(super) fn sky(t: &Turn, st: &AxisStatus, r: &RotatorState) -> i64 {
    t.sky(st.position, r.reverse, r.sync_offset)
}
