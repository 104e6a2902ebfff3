//! Non-volatile memory of the board (seed 002 §2.2: every position change is stored and
//! read back at power-up), in a redb database inside `--data`.
//!
//! Records are JSON values keyed by name. Every write is its own durable transaction, so a
//! kill at any point leaves either the old or the new record.
//!
//! Reads come from a copy of every committed record kept in memory, so they keep working
//! while the disk does not. A write that fails (a full disk, an I/O error) leaves the store
//! failing: the database is closed, and opened again before the next write and at most once
//! a second from [`Store::check`]; axis records whose writes failed are written then. Every
//! write first checks that `DIR/board.redb` is still the file opened (device and inode), and
//! again before it is acknowledged: a deleted or replaced database refuses writes
//! ([`CtlError::StoreGone`]) and is never recreated in place.

use crate::axis::AxisSettings;
use crate::domain::MoveOpts;
use crate::error::CtlError;
use redb::{
    Database, DatabaseError, ReadableTable, StorageBackend, StorageError, TableDefinition,
    TableHandle,
};
use serde::{de::DeserializeOwned, Serialize};
use std::cell::Cell;
use std::collections::BTreeMap;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, Once};
use std::time::{Duration, Instant};

mod db;
mod records;

pub use db::DB_FILE;
use db::{commit, identity, try_open, Failure, Op};
pub use records::*;

type Table = TableDefinition<'static, &'static str, &'static str>;

const SETTINGS: Table = TableDefinition::new("settings");
const AXES: Table = TableDefinition::new("axes");
const PRESETS: Table = TableDefinition::new("presets");
const NAMED: Table = TableDefinition::new("named_positions");
/// Named tracking rates (seed 002's constant, fast and slow motion), as the rate's text.
const RATES: Table = TableDefinition::new("rates");
/// The FPGA board's link session ([`LinkSession`]), under [`LINK_SESSION`].
const LINK: Table = TableDefinition::new("link");
/// Telescope mounts' sync offsets ([`MountRecord`]), keyed by the mount's polar axis.
const MOUNTS: Table = TableDefinition::new("mounts");
const TABLES: [Table; 7] = [SETTINGS, AXES, PRESETS, NAMED, RATES, LINK, MOUNTS];
const LINK_SESSION: &str = "session";

/// How often [`Store::check`] opens a failing database again.
pub const RETRY_PERIOD: Duration = Duration::from_secs(1);
/// How old the file check `status` and `info` report may be.
pub const HEALTH_CHECK_PERIOD: Duration = Duration::from_millis(50);

/// Whether writes reach the disk.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StoreHealth {
    Ok,
    /// The last write failed (why); the store tries again.
    Failing(String),
    /// The database file was deleted or replaced under the running board (what was found).
    Gone(String),
}

impl StoreHealth {
    /// `ok`, `failing` or `gone`: the `store` field of `status`.
    pub fn word(&self) -> &'static str {
        match self {
            StoreHealth::Ok => "ok",
            StoreHealth::Failing(_) => "failing",
            StoreHealth::Gone(_) => "gone",
        }
    }
}

impl std::fmt::Display for StoreHealth {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StoreHealth::Ok => f.write_str("ok"),
            StoreHealth::Failing(why) | StoreHealth::Gone(why) => {
                write!(f, "{}: {why}", self.word())
            }
        }
    }
}

/// Opens the database at a path: `true` creates it if missing (only at start-up).
type Opener = Box<dyn Fn(&Path, bool) -> Result<Database, DatabaseError> + Send + Sync>;

/// Every record of every table, as its JSON text.
type Mirror = BTreeMap<String, BTreeMap<String, String>>;

pub struct Store {
    dir: PathBuf,
    path: PathBuf,
    open: Opener,
    state: Mutex<State>,
}

struct State {
    /// `None` after a failed write: opened again before the next one.
    db: Option<Database>,
    /// Device and inode of the file opened.
    id: (u64, u64),
    mirror: Mirror,
    /// Axis records whose write failed: the board's latest word, written on recovery.
    unsaved: BTreeMap<String, String>,
    failing: Option<String>,
    gone: Option<String>,
    tried: Instant,
    /// When the file at the path was last compared with the one opened.
    checked: Option<Instant>,
}

impl State {
    fn health(&self) -> StoreHealth {
        match (&self.gone, &self.failing) {
            (Some(why), _) => StoreHealth::Gone(why.clone()),
            (None, Some(why)) => StoreHealth::Failing(why.clone()),
            (None, None) => StoreHealth::Ok,
        }
    }
}

impl Store {
    /// Opens (or creates) the board's database in `dir`. A damaged file is refused with
    /// one clear error, never opened as a new board.
    pub fn open(dir: &Path) -> Result<Store, CtlError> {
        Store::open_or_reset(dir, false).map(|(s, _)| s)
    }

    /// As [`Store::open`], the database file (`DIR/board.redb`, still the file checked
    /// for deletion) accessed through the backend `make` returns for its path; `make` is
    /// called again each time the store opens the database after a failure.
    pub fn open_with_backend<B: StorageBackend>(
        dir: &Path,
        make: impl Fn(&Path) -> std::io::Result<B> + Send + Sync + 'static,
    ) -> Result<Store, CtlError> {
        let open: Opener = Box::new(move |p, _| redb::Builder::new().create_with_backend(make(p)?));
        Store::open_with(dir, false, open).map(|(s, _)| s)
    }

    /// The board's data directory (the database's).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// As [`Store::open`]; with `reset`, a damaged file is renamed aside (the new name is
    /// returned) and a new, empty board database takes its place.
    pub fn open_or_reset(dir: &Path, reset: bool) -> Result<(Store, Option<PathBuf>), CtlError> {
        let open: Opener = Box::new(|p, create| {
            if create {
                Database::create(p)
            } else {
                Database::open(p)
            }
        });
        Store::open_with(dir, reset, open)
    }

    fn open_with(
        dir: &Path,
        reset: bool,
        open: Opener,
    ) -> Result<(Store, Option<PathBuf>), CtlError> {
        std::fs::create_dir_all(dir)
            .map_err(|e| CtlError::Store(format!("cannot create {}: {e}", dir.display())))?;
        let path = dir.join(DB_FILE);
        let (opened, aside) = match try_open(&path, &open, true) {
            Ok(o) => (o, None),
            Err(Failure::Other(e)) => return Err(e),
            Err(Failure::Damaged(why)) if !reset => {
                return Err(CtlError::Store(format!(
                "the board database {} is damaged ({why}); nothing was changed. Restore it from a \
                 backup, or start with --reset-damaged-data to move it aside and begin a new board",
                path.display()
            )))
            }
            Err(Failure::Damaged(_)) => {
                let stamp = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs());
                let aside = dir.join(format!("{DB_FILE}.damaged-{stamp}"));
                std::fs::rename(&path, &aside).map_err(|e| {
                    CtlError::Store(format!("cannot move {} aside: {e}", path.display()))
                })?;
                match try_open(&path, &open, true) {
                    Ok(o) => (o, Some(aside)),
                    Err(Failure::Other(e)) => return Err(e),
                    Err(Failure::Damaged(why)) => {
                        return Err(CtlError::Store(format!(
                            "a new database at {} failed: {why}",
                            path.display()
                        )))
                    }
                }
            }
        };
        let (db, mirror) = opened;
        let id = identity(&path)
            .map_err(|e| CtlError::Store(format!("cannot open {}: {e}", path.display())))?;
        let state = State {
            db: Some(db),
            id,
            mirror,
            unsaved: BTreeMap::new(),
            failing: None,
            gone: None,
            tried: Instant::now(),
            checked: None,
        };
        let store = Store {
            dir: dir.to_path_buf(),
            path,
            open,
            state: Mutex::new(state),
        };
        Ok((store, aside))
    }

    fn state(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Whether writes reach the disk, as last found.
    pub fn health(&self) -> StoreHealth {
        self.state().health()
    }

    /// Checks that the database file is still there (at most once per
    /// [`HEALTH_CHECK_PERIOD`]: `status` polled in a loop would otherwise spend a system
    /// call on it every time), and opens a failing database again (at most once per
    /// [`RETRY_PERIOD`]); the health then. Writes check the file every time.
    pub fn check(&self) -> StoreHealth {
        let mut st = self.state();
        if st
            .checked
            .is_some_and(|t| t.elapsed() < HEALTH_CHECK_PERIOD)
        {
            return st.health();
        }
        if self.check_file(&mut st).is_ok() && st.db.is_none() && st.tried.elapsed() >= RETRY_PERIOD
        {
            let _ = self.reopen(&mut st);
        }
        st.health()
    }

    /// Refuses when the file at the database's path is not the one opened.
    fn check_file(&self, st: &mut State) -> Result<(), CtlError> {
        st.checked = Some(Instant::now());
        let path = self.path.display();
        let why = match identity(&self.path) {
            Ok(id) if id == st.id => {
                if st.gone.take().is_some() {
                    eprintln!("warning: storage: {path} is back; writes go to it again");
                }
                return Ok(());
            }
            Ok(_) => format!("{path} was replaced by another file"),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                format!("{path} was deleted")
            }
            Err(e) => return Err(CtlError::Store(format!("cannot check {path}: {e}"))),
        };
        if st.gone.is_none() {
            eprintln!(
                "error: storage: {why} while the board ran; every write is refused until \
                 the board is restarted"
            );
        }
        st.gone = Some(why.clone());
        Err(CtlError::StoreGone(format!(
            "{why} (deleted or replaced while the board ran): nothing was stored. Restart \
             the board to go on from what the data directory holds now"
        )))
    }

    /// Opens a failing database again and writes the axis records that failed.
    fn reopen(&self, st: &mut State) -> Result<(), CtlError> {
        if st.db.is_some() {
            return Ok(());
        }
        st.tried = Instant::now();
        let db = match try_open(&self.path, &self.open, false) {
            Ok((db, _)) => db,
            Err(f) => {
                let why = f.reason();
                st.failing = Some(why.clone());
                return Err(CtlError::Store(format!(
                    "{} still cannot be written ({why}); nothing was stored",
                    self.path.display()
                )));
            }
        };
        let unsaved: Vec<(String, String)> = st.unsaved.clone().into_iter().collect();
        let ops: Vec<Op> = unsaved
            .iter()
            .map(|(k, v)| (AXES, k.as_str(), Some(v.as_str())))
            .collect();
        st.db = Some(db);
        self.write_ops(st, &ops).map(|_| ())
    }

    /// Commits `ops` on the open database; the copy in memory follows what was committed.
    fn write_ops(&self, st: &mut State, ops: &[Op]) -> Result<Vec<bool>, CtlError> {
        let Some(db) = st.db.as_ref() else {
            return Err(CtlError::Store("the database is closed".into()));
        };
        match commit(db, ops) {
            Ok(found) => {
                for &(t, key, value) in ops {
                    let rows = st.mirror.entry(t.name().to_string()).or_default();
                    match value {
                        Some(v) => rows.insert(key.to_string(), v.to_string()),
                        None => rows.remove(key),
                    };
                    if t.name() == AXES.name() {
                        st.unsaved.remove(key);
                    }
                }
                if let Some(why) = st.failing.take() {
                    eprintln!(
                        "warning: storage: {} is written again (it failed: {why})",
                        self.path.display()
                    );
                }
                Ok(found)
            }
            Err(e) => {
                // redb refuses every write after an I/O error until the file is opened
                // again: closed now, opened before the next write.
                st.db = None;
                st.tried = Instant::now();
                if st.failing.is_none() {
                    eprintln!(
                        "error: storage: writing to {} failed ({e}); the store tries again \
                         before each write",
                        self.path.display()
                    );
                }
                st.failing = Some(e.to_string());
                Err(CtlError::Store(format!(
                    "writing to {} failed ({e}); nothing was stored",
                    self.path.display()
                )))
            }
        }
    }

    /// One write, checked before (and, for a file deleted meanwhile, after) it commits.
    fn write(&self, t: Table, key: &str, value: Option<&str>) -> Result<bool, CtlError> {
        let mut st = self.state();
        if let (Some(v), true) = (value, t.name() == AXES.name()) {
            st.unsaved.insert(key.to_string(), v.to_string());
        }
        self.check_file(&mut st)?;
        self.reopen(&mut st)?;
        let found = self.write_ops(&mut st, &[(t, key, value)])?;
        self.check_file(&mut st)?;
        Ok(found[0])
    }

    fn get<T: DeserializeOwned>(&self, t: Table, key: &str) -> Result<Option<T>, CtlError> {
        let st = self.state();
        match st.mirror.get(t.name()).and_then(|rows| rows.get(key)) {
            Some(s) => Ok(Some(serde_json::from_str(s)?)),
            None => Ok(None),
        }
    }

    fn all<T: DeserializeOwned>(&self, t: Table) -> Result<BTreeMap<String, T>, CtlError> {
        let st = self.state();
        let mut out = BTreeMap::new();
        for (k, v) in st.mirror.get(t.name()).into_iter().flatten() {
            out.insert(k.clone(), serde_json::from_str(v)?);
        }
        Ok(out)
    }

    fn put<T: Serialize>(&self, t: Table, key: &str, v: &T) -> Result<(), CtlError> {
        let json = serde_json::to_string(v)?;
        self.write(t, key, Some(&json)).map(|_| ())
    }

    fn remove(&self, t: Table, key: &str) -> Result<bool, CtlError> {
        self.write(t, key, None)
    }

    /// Replaces the simulated mechanics file (write, then rename: never half written).
    /// Not synced to disk: it only has to survive the process, not the machine.
    pub fn put_sim(&self, m: &BTreeMap<String, SimMechanics>) -> Result<(), CtlError> {
        self.check_file(&mut self.state())?;
        let tmp = self.dir.join(format!("{SIM_FILE}.tmp"));
        let json = serde_json::to_string(m)?;
        std::fs::write(&tmp, json)
            .and_then(|_| std::fs::rename(&tmp, self.dir.join(SIM_FILE)))
            .map_err(|e| CtlError::Store(format!("{SIM_FILE}: {e}")))
    }

    /// The simulated mechanics file; empty if missing or unreadable (then the mechanics
    /// come back where their move started).
    pub fn sim(&self) -> BTreeMap<String, SimMechanics> {
        std::fs::read_to_string(self.dir.join(SIM_FILE))
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_default()
    }

    pub fn settings(&self, axis: &str) -> Result<Option<AxisSettings>, CtlError> {
        self.get(SETTINGS, axis)
    }
    pub fn put_settings(&self, axis: &str, s: &AxisSettings) -> Result<(), CtlError> {
        self.put(SETTINGS, axis, s)
    }
    pub fn axis(&self, axis: &str) -> Result<Option<AxisRecord>, CtlError> {
        self.get(AXES, axis)
    }
    pub fn put_axis(&self, axis: &str, r: &AxisRecord) -> Result<(), CtlError> {
        self.put(AXES, axis, r)
    }
    pub fn presets(&self) -> Result<BTreeMap<String, MoveOpts>, CtlError> {
        self.all(PRESETS)
    }
    pub fn preset(&self, name: &str) -> Result<Option<MoveOpts>, CtlError> {
        self.get(PRESETS, name)
    }
    pub fn put_preset(&self, name: &str, o: &MoveOpts) -> Result<(), CtlError> {
        self.put(PRESETS, name, o)
    }
    pub fn named(&self) -> Result<BTreeMap<String, NamedPosition>, CtlError> {
        self.all(NAMED)
    }
    pub fn named_position(&self, name: &str) -> Result<Option<NamedPosition>, CtlError> {
        self.get(NAMED, name)
    }
    pub fn put_named(&self, name: &str, p: &NamedPosition) -> Result<(), CtlError> {
        self.put(NAMED, name, p)
    }
    pub fn forget_named(&self, name: &str) -> Result<bool, CtlError> {
        self.remove(NAMED, name)
    }
    pub fn rates(&self) -> Result<BTreeMap<String, String>, CtlError> {
        self.all(RATES)
    }
    pub fn rate(&self, name: &str) -> Result<Option<String>, CtlError> {
        self.get(RATES, name)
    }
    pub fn put_rate(&self, name: &str, rate: &str) -> Result<(), CtlError> {
        self.put(RATES, name, &rate)
    }
    pub fn mount(&self, key: &str) -> Result<Option<MountRecord>, CtlError> {
        self.get(MOUNTS, key)
    }
    pub fn put_mount(&self, key: &str, r: &MountRecord) -> Result<(), CtlError> {
        self.put(MOUNTS, key, r)
    }
    pub fn link_session(&self) -> Result<Option<LinkSession>, CtlError> {
        self.get(LINK, LINK_SESSION)
    }
    pub fn put_link_session(&self, s: &LinkSession) -> Result<(), CtlError> {
        self.put(LINK, LINK_SESSION, s)
    }
}

#[cfg(test)]
mod tests;
