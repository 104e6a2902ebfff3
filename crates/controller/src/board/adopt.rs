//! A homing the host before a restart left running on an adopted board. Its phases live
//! in the host that started it (each phase's end starts the next, the last re-references
//! the count), so a restarted host cannot finish it: the axis is halted where it is and
//! untrusted until homed, whatever it was before, and its fault says why.

use super::Axis;
use crate::axis::AxisState;
use crate::backend::{mechanics, BoardBackend};
use crate::config::BoardConfig;
use crate::error::CtlError;
use crate::store::Store;

/// Per axis of `config`: its stored moving marker is a homing's. Read before the axes are
/// opened, which rewrites the records of motions that ended while the host was down.
pub(super) fn stored_homings(store: &Store, config: &BoardConfig) -> Vec<bool> {
    config
        .axes
        .iter()
        .map(|ac| {
            store
                .axis(&ac.name)
                .ok()
                .flatten()
                .and_then(|r| r.moving)
                .is_some_and(|m| m.homing)
        })
        .collect()
}

/// Ends the homings `homings` marks on the adopted board: a phase still running is
/// halted (the board's `Stop`: its count stays exact), and each axis is untrusted, in
/// fault, and written down so.
pub(super) fn end_adopted_homings(
    axes: &mut [Axis],
    pins: &mut dyn BoardBackend,
    store: &Store,
    warnings: &mut Vec<String>,
    homings: &[bool],
) -> Result<(), CtlError> {
    for (i, ax) in axes.iter_mut().enumerate() {
        if !homings.get(i).copied().unwrap_or(false) {
            continue;
        }
        let mut why = "host_restarted: the host restarted mid-homing, which only the host \
                       that started it can finish"
            .to_string();
        if ax.motion.take().is_some() {
            match pins.stop(i, 0) {
                Ok(_) => why.push_str("; the axis was halted at once"),
                Err(e) => why.push_str(&format!("; halting the axis failed ({e})")),
            }
        }
        why.push_str("; untrusted until homed");
        eprintln!("warning: axis {}: {why}", ax.name);
        warnings.push(format!("axis {}: {why}", ax.name));
        ax.homed = false;
        ax.trusted = false;
        ax.marked = false;
        ax.marker = None;
        ax.state = AxisState::Fault;
        ax.fault = Some(why);
        store.put_axis(&ax.name, &ax.record(None, mechanics(&*pins, i)))?;
    }
    Ok(())
}
