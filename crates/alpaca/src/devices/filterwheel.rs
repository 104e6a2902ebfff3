//! FilterWheel: slots are named positions of the axis; Position is −1 while it moves.

use super::{is_moving, val, Answer, Device};
use crate::config::FilterWheelConfig;
use crate::errors::Fault;
use crate::mapping::slot_at;
use crate::params::Params;
use multistep_controller::protocol::Amount;
use multistep_controller::{AxisStatus, Controller, CtlError};

impl Device {
    pub(super) fn filterwheel(
        &self,
        ctl: &Controller,
        w: &FilterWheelConfig,
        m: &str,
        put: bool,
        p: &Params,
    ) -> Answer {
        match (m, put) {
            ("names", _) => val(w.slots.iter().map(|s| &s.name).collect::<Vec<_>>()),
            ("focusoffsets", _) => val(w.slots.iter().map(|s| s.focus_offset).collect::<Vec<_>>()),
            ("position", false) => {
                let st = self.status(ctl)?;
                val(self.wheel_position(ctl, w, &st)?)
            }
            ("position", true) => {
                let slot = p.i32("Position")?;
                let n = w.slots.len();
                if !(0..n as i64).contains(&(slot as i64)) {
                    return Err(Fault::invalid_value(format!(
                        "Position {slot} is not a slot (0..={})",
                        n - 1
                    )));
                }
                let at = self.slot_position(ctl, w, slot as usize)?;
                self.move_to(ctl, Amount::Steps(at))?;
                Ok(None)
            }
            _ => Err(Fault::BadRequest(format!("unknown method {m}"))),
        }
    }

    /// The slot the axis stands on; −1 while moving or between slots.
    pub(super) fn wheel_position(
        &self,
        ctl: &Controller,
        w: &FilterWheelConfig,
        st: &AxisStatus,
    ) -> Result<i32, Fault> {
        if is_moving(st) {
            return Ok(-1);
        }
        let period = self.settings(ctl)?.period;
        // A slot without a saved position cannot be where the wheel is.
        let at: Vec<Option<i64>> = (0..w.slots.len())
            .map(|i| self.slot_position(ctl, w, i).ok())
            .collect();
        Ok(slot_at(&at, period, st.position).map_or(-1, |i| i as i32))
    }

    fn slot_position(
        &self,
        ctl: &Controller,
        w: &FilterWheelConfig,
        i: usize,
    ) -> Result<i64, Fault> {
        let slot = &w.slots[i];
        if let Some(at) = slot.position {
            return Ok(at);
        }
        let named = ctl.with_board(|b, _| b.named_positions())?;
        named
            .get(&slot.name)
            .and_then(|p| p.get(&self.axis))
            .copied()
            .ok_or_else(|| {
                Fault::from(CtlError::UnknownName {
                    what: "position (save it with 'save NAME AXIS')",
                    name: format!("{} for axis {}", slot.name, self.axis),
                })
            })
    }
}
