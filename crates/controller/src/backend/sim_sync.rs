//! The simulated boards' SYNC line (docs/CONTROLLER.md, "Groups across boards"): a file
//! that simulated boards on one machine share. A fall is the wall-clock instant written
//! into it; a board with an armed group starts it on the tick of that instant (the serve
//! processes' ticks follow the wall clock, scaled by their time scale).

use crate::error::CtlError;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// One board's end of the line; `M` is what an armed member holds (its move).
pub struct SimSyncLine<M> {
    path: PathBuf,
    /// Board ticks per wall-clock second (the clock times the service's time scale).
    ticks_per_second: f64,
    armed: Option<Armed<M>>,
    /// The board's tick at the last fall it saw.
    last_fall: Option<u64>,
}

/// A group waiting for the line's fall.
struct Armed<M> {
    wall_ns: u128,
    tick: u64,
    /// Each member's axis and move; a member stopped before the fall is taken out.
    moves: Vec<(usize, M)>,
}

fn wall_ns() -> u128 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos())
}

impl<M> SimSyncLine<M> {
    pub fn new(path: &Path, ticks_per_second: f64) -> SimSyncLine<M> {
        SimSyncLine {
            path: path.to_path_buf(),
            ticks_per_second,
            armed: None,
            last_fall: None,
        }
    }

    pub fn is_armed(&self) -> bool {
        self.armed.is_some()
    }

    /// Arms a group at `now` (the caller refuses a second one).
    pub fn arm(&mut self, moves: Vec<(usize, M)>, now: u64) {
        self.armed = Some(Armed {
            wall_ns: wall_ns(),
            tick: now,
            moves,
        });
    }

    /// Takes `axis` out of the armed group (it was stopped); `None` takes every axis.
    pub fn disarm(&mut self, axis: Option<usize>) {
        if let Some(a) = self.armed.as_mut() {
            a.moves.retain(|(i, _)| axis.is_some_and(|x| x != *i));
            if a.moves.is_empty() {
                self.armed = None;
            }
        }
    }

    /// Pulls the line low: writes the instant (a whole new file, so a reader never sees
    /// half of one).
    pub fn fire(&self) -> Result<(), CtlError> {
        let tmp = self
            .path
            .with_extension(format!("{}.tmp", std::process::id()));
        let io = |e: std::io::Error| CtlError::Io(format!("{}: {e}", self.path.display()));
        std::fs::write(&tmp, wall_ns().to_string()).map_err(io)?;
        std::fs::rename(&tmp, &self.path).map_err(io)
    }

    /// At `now`: when the line fell after the group was armed, the group's tick (the
    /// fall's, never before the arming) and its moves.
    pub fn take_fired(&mut self, now: u64) -> Option<(u64, Vec<(usize, M)>)> {
        let a = self.armed.as_ref()?;
        let fall: u128 = std::fs::read_to_string(&self.path)
            .ok()?
            .trim()
            .parse()
            .ok()?;
        if fall < a.wall_ns {
            return None;
        }
        let ago = wall_ns().saturating_sub(fall) as f64 * 1e-9 * self.ticks_per_second;
        let tick = now.saturating_sub(ago as u64).max(a.tick);
        self.last_fall = Some(tick);
        self.armed.take().map(|a| (tick, a.moves))
    }

    /// The count latched at the last fall (the board's tick, 32 bits as on the board).
    pub fn last_fall(&self) -> u32 {
        self.last_fall.unwrap_or(0) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fall_starts_a_group_armed_before_it_on_its_own_tick() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sync");
        let mut a = SimSyncLine::new(&path, 1e6);
        let b = SimSyncLine::<()>::new(&path, 1e6);
        // a fall before the arming does not count
        b.fire().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(2));
        a.arm(vec![(0, ()), (1, ())], 1000);
        assert!(a.take_fired(2000).is_none());
        a.disarm(Some(1));
        std::thread::sleep(std::time::Duration::from_millis(2));
        b.fire().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        let (tick, moves) = a.take_fired(1_000_000).unwrap();
        assert_eq!(moves.len(), 1, "the stopped member is out");
        // the fall was 20 ms (20 000 ticks) or a little more ago
        assert!((900_000..=980_000).contains(&tick), "{tick}");
        assert_eq!(a.last_fall(), tick as u32);
        assert!(!a.is_armed());
    }
}
