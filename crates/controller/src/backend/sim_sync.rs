//! The simulated boards' SYNC line (docs/CONTROLLER.md, "Groups across boards"): a file
//! that simulated boards on one machine share. A fall is the wall-clock instant written
//! into it; a board with an armed group starts it on the tick of that instant (the serve
//! processes' ticks follow the wall clock, scaled by their time scale).

use crate::error::CtlError;
use std::io::Read;
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

/// Most bytes of the line's file that are read: a fall is one decimal number of
/// nanoseconds (a u128 has at most 39 digits), so a longer file is not a fall.
const MAX_FALL_BYTES: u64 = 64;

/// Checks a simulated SYNC line's path at start-up: `fire` replaces that file (temp file
/// and rename) and every poll of an armed group reads it, so it must be a regular file
/// (or none yet) in an existing directory, outside the board's data directory `data`.
pub fn check_line_path(path: &Path, data: &Path) -> Result<(), CtlError> {
    let bad = |why: String| {
        CtlError::Setting(format!(
            "board.sync_line '{}' {why}; it must name a regular file (or one not yet there) in \
             an existing directory outside the board's data directory",
            path.display()
        ))
    };
    if path.as_os_str().is_empty() {
        return Err(bad("is empty".into()));
    }
    let Some(name) = path.file_name() else {
        return Err(bad("names no file".into()));
    };
    let parent = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let dir = parent
        .canonicalize()
        .ok()
        .filter(|d| d.is_dir())
        .ok_or_else(|| {
            bad(format!(
                "is in {}, which is not a directory",
                parent.display()
            ))
        })?;
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => return Err(bad("is a directory".into())),
        Ok(m) if !m.is_file() => return Err(bad("is not a regular file (a device?)".into())),
        Ok(_) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(bad(format!("cannot be read ({e})"))),
    }
    let data = data
        .canonicalize()
        .map_err(|e| CtlError::Io(format!("{}: {e}", data.display())))?;
    // Through symlinks too: the file replaced, or the one read, must not be the board's.
    let real = path.canonicalize().unwrap_or_else(|_| dir.join(name));
    if dir.starts_with(&data) || real.starts_with(&data) {
        return Err(bad(format!(
            "is inside the board's data directory {}",
            data.display()
        )));
    }
    Ok(())
}

/// The instant of the line's last fall, if its file holds one.
fn read_fall(path: &Path) -> Option<u128> {
    // Only a regular file: opening a pipe would block, reading a device may never end.
    if !std::fs::metadata(path).ok()?.is_file() {
        return None;
    }
    let mut text = String::new();
    std::fs::File::open(path)
        .ok()?
        .take(MAX_FALL_BYTES + 1)
        .read_to_string(&mut text)
        .ok()?;
    if text.len() as u64 > MAX_FALL_BYTES {
        return None;
    }
    text.trim().parse().ok()
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
        let fall = read_fall(&self.path)?;
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

    #[test]
    fn a_line_path_must_be_a_regular_file_in_a_directory_outside_the_data() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        std::fs::create_dir_all(data.join("sub")).unwrap();
        std::fs::write(data.join("board.redb"), "db").unwrap();
        let shared = dir.path().join("shared");
        std::fs::write(&shared, "1").unwrap();
        let refused = [
            (PathBuf::new(), "is empty"),
            (PathBuf::from("/"), "names no file"),
            (dir.path().to_path_buf(), "is a directory"),
            (PathBuf::from("/dev/null"), "not a regular file"),
            (PathBuf::from("/dev/zero"), "not a regular file"),
            (dir.path().join("no/such/line"), "not a directory"),
            (shared.join("line"), "not a directory"),
            (data.join("board.redb"), "inside the board's data directory"),
            (data.join("sub/line"), "inside the board's data directory"),
            (
                data.join("sub/../line"),
                "inside the board's data directory",
            ),
        ];
        for (path, why) in refused {
            let e = check_line_path(&path, &data).unwrap_err();
            assert_eq!(e.code(), 9, "{path:?}");
            let msg = e.to_string();
            assert!(msg.contains(why) && !msg.contains('\n'), "{path:?}: {msg}");
        }
        // A symlink outside whose target is the board's database.
        let link = dir.path().join("link");
        std::os::unix::fs::symlink(data.join("board.redb"), &link).unwrap();
        assert!(check_line_path(&link, &data).is_err());
        for ok in [shared, dir.path().join("new-line")] {
            check_line_path(&ok, &data).unwrap();
        }
        assert_eq!(std::fs::read(data.join("board.redb")).unwrap(), b"db");
    }

    #[test]
    fn an_overlong_or_malformed_line_file_is_no_fall() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sync");
        let mut a = SimSyncLine::new(&path, 1e6);
        a.arm(vec![(0, ())], 0);
        let later = (wall_ns() + 1_000_000).to_string();
        // A valid instant padded past the limit, then text: neither is a fall.
        std::fs::write(&path, format!("{later}{}", " ".repeat(1 << 20))).unwrap();
        assert!(a.take_fired(10).is_none());
        std::fs::write(&path, "soon").unwrap();
        assert!(a.take_fired(10).is_none());
        assert!(a.is_armed());
        // Within the limit it is one.
        std::fs::write(&path, format!("{later}\n")).unwrap();
        assert!(a.take_fired(10).is_some());
    }
}
