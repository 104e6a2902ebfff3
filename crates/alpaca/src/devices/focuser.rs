//! Focuser: an absolute focuser on a soft-limited axis; Position is the counted position.

use super::{is_moving, val, Answer, Device};
use crate::config::FocuserConfig;
use crate::errors::{code, Fault};
use crate::params::Params;
use multistep_controller::protocol::Amount;
use multistep_controller::{AxisStatus, Controller};

impl Device {
    pub(super) fn focuser(
        &self,
        ctl: &Controller,
        f: &FocuserConfig,
        m: &str,
        put: bool,
        p: &Params,
    ) -> Answer {
        match (m, put) {
            ("absolute", _) => val(true),
            ("ismoving", _) => val(is_moving(&self.status(ctl)?)),
            ("maxstep", _) | ("maxincrement", _) => val(self.max_step(ctl)?),
            ("position", _) => val(focuser_position(&self.status(ctl)?)?),
            ("stepsize", _) => val(f.microns_per_unit / self.settings(ctl)?.steps_per_unit),
            ("tempcomp", false) | ("tempcompavailable", _) => val(false),
            ("tempcomp", true) => {
                p.bool("TempComp")?;
                Err(Fault::not_implemented("temperature compensation"))
            }
            ("temperature", _) => Err(Fault::not_implemented("temperature")),
            ("halt", _) => self.halt(ctl),
            ("move", _) => {
                let to = p.i32("Position")?;
                let max = self.max_step(ctl)?;
                if !(0..=max).contains(&to) {
                    return Err(Fault::invalid_value(format!(
                        "Position {to} is outside 0..={max} (MaxStep)"
                    )));
                }
                self.move_to(ctl, Amount::Steps(to as i64))?;
                Ok(None)
            }
            _ => Err(Fault::BadRequest(format!("unknown method {m}"))),
        }
    }

    /// MaxStep: the axis's soft_max (checked at start; re-read since `set` may change it).
    fn max_step(&self, ctl: &Controller) -> Result<i32, Fault> {
        self.settings(ctl)?
            .soft_max
            .and_then(|m| i32::try_from(m).ok())
            .filter(|&m| m > 0)
            .ok_or_else(|| {
                Fault::device(
                    code::VALUE_NOT_SET,
                    format!("axis {} has no soft_max", self.axis),
                )
            })
    }
}

pub(super) fn focuser_position(st: &AxisStatus) -> Result<i32, Fault> {
    i32::try_from(st.position).map_err(|_| {
        Fault::device(
            code::DRIVER,
            format!("position {} does not fit Int32", st.position),
        )
    })
}
