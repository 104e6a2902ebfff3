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
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::cell::Cell;
use std::collections::BTreeMap;
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, Once};
use std::time::{Duration, Instant};

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

/// What survives a power cycle of one axis.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AxisRecord {
    pub position: i64,
    pub homed: bool,
    pub trusted: bool,
    /// Written before motion starts, cleared when it ends: present at start-up means the
    /// board died mid-move and the position is not known.
    pub moving: Option<MovingMarker>,
    /// Simulation only: the mechanical position (the simulated world, kept with the board).
    pub sim_position: i64,
    /// Motor minus load position (0 … the axis's backlash): which side the slack is taken
    /// up on (see [`crate::axis::AxisSettings::backlash`]).
    #[serde(default)]
    pub slack: i64,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MovingMarker {
    pub from: i64,
    pub target: i64,
    /// The motion is a homing (any phase, or the park after it): a host restarted while
    /// it runs cannot finish it.
    #[serde(default)]
    pub homing: bool,
}

/// What a restarted host needs to adopt the FPGA board it left running: the token it
/// wrote to the board's `Session` register, and what of each axis's motion lives only in
/// the host.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LinkSession {
    pub token: u32,
    /// Per axis: what the host adds to the board's `Position` while the axis runs.
    pub offsets: Vec<i64>,
    /// Axes whose motion the host streams (it cannot go on without the host).
    pub streamed: u32,
    /// Axes of a group armed for the SYNC line.
    pub armed: u32,
    /// An offset being folded into an idle axis's `Position` register: kept before the
    /// register is written, so a host killed between the two knows which it holds.
    #[serde(default)]
    pub folding: Option<Fold>,
}

/// An idle axis's offset on its way into the board's counter ([`LinkSession::folding`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Fold {
    pub axis: usize,
    /// The `Position` register before the fold (after it: this plus the offset).
    pub register: u32,
    pub offset: i64,
}

/// What a telescope mount keeps across restarts beside its park position.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MountRecord {
    /// Degrees added to each axis's counted angle by sync, [polar, dec].
    pub sync: [f64; 2],
}

/// A named set of axis positions (seed 002: stored line-centre positions).
pub type NamedPosition = BTreeMap<String, i64>;

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

/// Where the simulated mechanics of a moving axis were lately (a file beside the database,
/// rewritten often while axes move): after a crash they come back there, as a real axis's
/// mechanics stay where they stopped. Tied to the moving marker it was written under.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimMechanics {
    pub from: i64,
    pub target: i64,
    pub sim_position: i64,
}

/// The file of [`SimMechanics`] records.
pub const SIM_FILE: &str = "sim-mechanics.json";

thread_local! {
    /// Set while this thread opens a database: redb's panics there are reported as damage.
    static QUIET: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f`, catching a panic; its message is not printed. The process's panic hook is
/// wrapped once (the hook before keeps every other panic), never swapped per call.
fn quietly<R>(f: impl FnOnce() -> R) -> std::thread::Result<R> {
    static WRAP: Once = Once::new();
    WRAP.call_once(|| {
        let before = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.try_with(Cell::get).unwrap_or(false) {
                before(info);
            }
        }));
    });
    QUIET.with(|q| q.set(true));
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    QUIET.with(|q| q.set(false));
    r
}

/// Opens the file and reads every record once, so damage shows now and not mid-run.
/// redb may panic on some damaged files; that is caught and reported as damage too.
fn try_open(path: &Path, open: &Opener, create: bool) -> Result<(Database, Mirror), Failure> {
    if std::fs::metadata(path).is_ok_and(|m| m.len() == 0) {
        return Err(Failure::Damaged("the file is empty (0 bytes)".into()));
    }
    let r = quietly(|| -> Result<(Database, Mirror), Failure> {
        let db = match open(path, create) {
            Ok(db) => db,
            Err(DatabaseError::DatabaseAlreadyOpen) => {
                return Err(Failure::Other(CtlError::Store(format!(
                    "{} is in use by another process",
                    path.display()
                ))))
            }
            Err(DatabaseError::UpgradeRequired(v)) => {
                return Err(Failure::Other(CtlError::Store(format!(
                    "{} is in redb file format {v}, which needs an upgrade",
                    path.display()
                ))))
            }
            // A short or unreadable file is damage; other I/O (permissions, disk) is not.
            Err(DatabaseError::Storage(StorageError::Io(e)))
                if !matches!(
                    e.kind(),
                    std::io::ErrorKind::UnexpectedEof | std::io::ErrorKind::InvalidData
                ) =>
            {
                return Err(Failure::Other(CtlError::Store(format!(
                    "cannot open {}: {e}",
                    path.display()
                ))))
            }
            Err(e) => return Err(Failure::Damaged(e.to_string())),
        };
        // Writing the tables proves the file writable; reading them all shows damage now.
        let tx = db.begin_write().map_err(CtlError::from)?;
        for t in TABLES {
            tx.open_table(t).map_err(CtlError::from)?;
        }
        tx.commit().map_err(CtlError::from)?;
        let mut mirror = Mirror::new();
        let tx = db.begin_read().map_err(CtlError::from)?;
        for t in TABLES {
            let table = tx.open_table(t).map_err(CtlError::from)?;
            let rows = mirror.entry(t.name().to_string()).or_default();
            for row in table.iter().map_err(CtlError::from)? {
                let (k, v) = row.map_err(CtlError::from)?;
                serde_json::from_str::<serde_json::Value>(v.value()).map_err(CtlError::from)?;
                rows.insert(k.value().to_string(), v.value().to_string());
            }
        }
        drop(tx);
        Ok((db, mirror))
    });
    match r {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "the database library gave up reading it".into());
            Err(Failure::Damaged(msg))
        }
    }
}

/// Device and inode of the file at `path` now.
fn identity(path: &Path) -> std::io::Result<(u64, u64)> {
    std::fs::metadata(path).map(|m| (m.dev(), m.ino()))
}

/// The database file inside a board's data directory.
pub const DB_FILE: &str = "board.redb";

/// Why opening failed: a damaged file (which a fresh start may move aside) or not.
enum Failure {
    Damaged(String),
    Other(CtlError),
}

impl From<CtlError> for Failure {
    fn from(e: CtlError) -> Self {
        Failure::Damaged(e.to_string())
    }
}

impl Failure {
    fn reason(self) -> String {
        match self {
            Failure::Damaged(why) => why,
            Failure::Other(e) => e.to_string(),
        }
    }
}

/// One write: a record put (`Some`) or removed (`None`).
type Op<'a> = (Table, &'a str, Option<&'a str>);

/// Commits `ops` in one transaction; for each, whether its key was there before.
fn commit(db: &Database, ops: &[Op]) -> Result<Vec<bool>, String> {
    let tx = db.begin_write().map_err(|e| e.to_string())?;
    let mut found = Vec::with_capacity(ops.len());
    for &(t, key, value) in ops {
        let mut table = tx.open_table(t).map_err(|e| e.to_string())?;
        let old = match value {
            Some(v) => table.insert(key, v),
            None => table.remove(key),
        };
        found.push(old.map_err(|e| e.to_string())?.is_some());
    }
    tx.commit().map_err(|e| e.to_string())?;
    Ok(found)
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

    /// Checks that the database file is still there, and opens a failing database again
    /// (at most once per [`RETRY_PERIOD`]); the health then.
    pub fn check(&self) -> StoreHealth {
        let mut st = self.state();
        if self.check_file(&mut st).is_ok() && st.db.is_none() && st.tried.elapsed() >= RETRY_PERIOD
        {
            let _ = self.reopen(&mut st);
        }
        st.health()
    }

    /// Refuses when the file at the database's path is not the one opened.
    fn check_file(&self, st: &mut State) -> Result<(), CtlError> {
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
mod tests {
    use super::*;
    use multistep_core::MoveParams;

    #[test]
    fn records_survive_reopening() {
        let dir = tempfile::tempdir().unwrap();
        let rec = AxisRecord {
            position: -1234,
            homed: true,
            trusted: true,
            moving: Some(MovingMarker {
                from: 1,
                target: 2,
                homing: false,
            }),
            sim_position: 5,
            slack: 3,
        };
        {
            let s = Store::open(dir.path()).unwrap();
            s.put_axis("X", &rec).unwrap();
            let set = AxisSettings {
                vmax: 1234.5,
                ..AxisSettings::default()
            };
            s.put_settings("X", &set).unwrap();
            s.put_preset(
                "fast",
                &MoveOpts {
                    params: MoveParams {
                        vmax: Some(9.0),
                        ..MoveParams::default()
                    },
                    ..Default::default()
                },
            )
            .unwrap();
            s.put_named("line", &NamedPosition::from([("X".to_string(), 7)]))
                .unwrap();
        }
        let s = Store::open(dir.path()).unwrap();
        assert_eq!(s.axis("X").unwrap(), Some(rec));
        assert_eq!(s.axis("Y").unwrap(), None);
        assert_eq!(s.settings("X").unwrap().unwrap().vmax, 1234.5);
        assert_eq!(s.preset("fast").unwrap().unwrap().params.vmax, Some(9.0));
        assert_eq!(s.named_position("line").unwrap().unwrap()["X"], 7);
        assert!(s.forget_named("line").unwrap());
        assert!(s.named().unwrap().is_empty());
    }

    #[test]
    fn the_link_session_survives_reopening() {
        let dir = tempfile::tempdir().unwrap();
        let kept = LinkSession {
            token: 0xDEAD_BEEF,
            offsets: vec![0, -3600],
            streamed: 0b10,
            armed: 0b01,
            folding: None,
        };
        {
            let s = Store::open(dir.path()).unwrap();
            assert_eq!(s.link_session().unwrap(), None, "a new board has none");
            s.put_link_session(&kept).unwrap();
        }
        let s = Store::open(dir.path()).unwrap();
        assert_eq!(s.link_session().unwrap(), Some(kept));
    }

    #[test]
    fn presets_stored_field_by_field_still_load() {
        // The JSON of a preset as stored before the values had one definition in the core.
        let old = r#"{"preset":null,"profile":"scurve","vmax":9.5,"amax":100.0,"jmax":null,"smax":null,"accel_time":null,"cruise_time":null,"decel_time":null,"start_speed":null,"end_speed":2.0,"rho":null,"phi":0.25,"psi":null}"#;
        let dir = tempfile::tempdir().unwrap();
        let s = Store::open(dir.path()).unwrap();
        let raw: serde_json::Value = serde_json::from_str(old).unwrap();
        s.put(PRESETS, "old", &raw).unwrap();
        let want = MoveOpts {
            preset: None,
            profile: Some("scurve".into()),
            params: MoveParams {
                vmax: Some(9.5),
                amax: Some(100.0),
                end_speed: Some(2.0),
                phi: Some(0.25),
                ..MoveParams::default()
            },
        };
        assert_eq!(s.preset("old").unwrap(), Some(want.clone()));
        // Written now, it reads back, and its keys are the old ones.
        s.put_preset("new", &want).unwrap();
        assert_eq!(s.preset("new").unwrap(), Some(want.clone()));
        let written: serde_json::Value =
            serde_json::from_str(&serde_json::to_string(&want).unwrap()).unwrap();
        assert_eq!(written, raw);
        // A key no version knows is still refused.
        let bad = r#"{"vmax":1.0,"vmx":2.0}"#;
        assert!(serde_json::from_str::<MoveOpts>(bad).is_err());
    }

    #[test]
    fn a_file_that_is_not_a_database_is_damaged_and_a_reset_moves_it_aside() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(DB_FILE);
        std::fs::write(&path, "hello world garbage").unwrap();
        let msg = Store::open(dir.path()).err().unwrap().to_string();
        assert!(
            msg.contains("is damaged") && msg.contains("--reset-damaged-data"),
            "{msg}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"hello world garbage");
        let (s, aside) = Store::open_or_reset(dir.path(), true).unwrap();
        assert_eq!(
            std::fs::read(aside.unwrap()).unwrap(),
            b"hello world garbage"
        );
        assert!(s.presets().unwrap().is_empty());
        assert_eq!(s.axis("X").unwrap(), None);
    }
}
