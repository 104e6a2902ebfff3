//! Non-volatile memory of the board (seed 002 §2.2: every position change is stored and
//! read back at power-up), in a redb database inside `--data`.
//!
//! Records are JSON values keyed by name. Every write is its own durable transaction, so a
//! kill at any point leaves either the old or the new record.

use crate::axis::AxisSettings;
use crate::error::CtlError;
use crate::protocol::MoveOpts;
use redb::{Database, DatabaseError, ReadableTable, StorageError, TableDefinition};
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

const SETTINGS: TableDefinition<&str, &str> = TableDefinition::new("settings");
const AXES: TableDefinition<&str, &str> = TableDefinition::new("axes");
const PRESETS: TableDefinition<&str, &str> = TableDefinition::new("presets");
const NAMED: TableDefinition<&str, &str> = TableDefinition::new("named_positions");
/// Named tracking rates (seed 002's constant, fast and slow motion), as the rate's text.
const RATES: TableDefinition<&str, &str> = TableDefinition::new("rates");

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
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MovingMarker {
    pub from: i64,
    pub target: i64,
}

/// A named set of axis positions (seed 002: stored line-centre positions).
pub type NamedPosition = BTreeMap<String, i64>;

pub struct Store {
    db: Database,
    dir: PathBuf,
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

/// Opens the file and reads every record once, so damage shows now and not mid-run.
/// redb may panic on some damaged files; that is caught and reported as damage too.
fn try_open(path: &Path) -> Result<Store, Failure> {
    if std::fs::metadata(path).is_ok_and(|m| m.len() == 0) {
        return Err(Failure::Damaged("the file is empty (0 bytes)".into()));
    }
    let quiet = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let r = std::panic::catch_unwind(|| -> Result<Store, Failure> {
        let db = match Database::create(path) {
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
        let tx = db.begin_write().map_err(CtlError::from)?;
        for t in [SETTINGS, AXES, PRESETS, NAMED, RATES] {
            tx.open_table(t).map_err(CtlError::from)?;
        }
        tx.commit().map_err(CtlError::from)?;
        let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let store = Store { db, dir };
        for t in [SETTINGS, AXES, PRESETS, NAMED, RATES] {
            store.all::<serde_json::Value>(t)?;
        }
        Ok(store)
    });
    std::panic::set_hook(quiet);
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

impl Store {
    /// Opens (or creates) the board's database in `dir`. A damaged file is refused with
    /// one clear error, never opened as a new board.
    pub fn open(dir: &Path) -> Result<Store, CtlError> {
        Store::open_or_reset(dir, false).map(|(s, _)| s)
    }

    /// The board's data directory (the database's).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// As [`Store::open`]; with `reset`, a damaged file is renamed aside (the new name is
    /// returned) and a new, empty board database takes its place.
    pub fn open_or_reset(dir: &Path, reset: bool) -> Result<(Store, Option<PathBuf>), CtlError> {
        std::fs::create_dir_all(dir)
            .map_err(|e| CtlError::Store(format!("cannot create {}: {e}", dir.display())))?;
        let path = dir.join(DB_FILE);
        match try_open(&path) {
            Ok(s) => Ok((s, None)),
            Err(Failure::Other(e)) => Err(e),
            Err(Failure::Damaged(why)) if !reset => Err(CtlError::Store(format!(
                "the board database {} is damaged ({why}); nothing was changed. Restore it from a \
                 backup, or start with --reset-damaged-data to move it aside and begin a new board",
                path.display()
            ))),
            Err(Failure::Damaged(_)) => {
                let stamp = std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs());
                let aside = dir.join(format!("{DB_FILE}.damaged-{stamp}"));
                std::fs::rename(&path, &aside).map_err(|e| {
                    CtlError::Store(format!("cannot move {} aside: {e}", path.display()))
                })?;
                match try_open(&path) {
                    Ok(s) => Ok((s, Some(aside))),
                    Err(Failure::Other(e)) => Err(e),
                    Err(Failure::Damaged(why)) => Err(CtlError::Store(format!(
                        "a new database at {} failed: {why}",
                        path.display()
                    ))),
                }
            }
        }
    }

    fn get<T: DeserializeOwned>(
        &self,
        t: TableDefinition<&str, &str>,
        key: &str,
    ) -> Result<Option<T>, CtlError> {
        let tx = self.db.begin_read()?;
        let table = tx.open_table(t)?;
        let v = table.get(key)?;
        Ok(match v {
            Some(s) => Some(serde_json::from_str(s.value())?),
            None => None,
        })
    }

    fn all<T: DeserializeOwned>(
        &self,
        t: TableDefinition<&str, &str>,
    ) -> Result<BTreeMap<String, T>, CtlError> {
        let tx = self.db.begin_read()?;
        let table = tx.open_table(t)?;
        let mut out = BTreeMap::new();
        for row in table.iter()? {
            let (k, v) = row?;
            out.insert(k.value().to_string(), serde_json::from_str(v.value())?);
        }
        Ok(out)
    }

    fn put<T: Serialize>(
        &self,
        t: TableDefinition<&str, &str>,
        key: &str,
        v: &T,
    ) -> Result<(), CtlError> {
        let json = serde_json::to_string(v)?;
        let tx = self.db.begin_write()?;
        tx.open_table(t)?.insert(key, json.as_str())?;
        tx.commit()?;
        Ok(())
    }

    fn remove(&self, t: TableDefinition<&str, &str>, key: &str) -> Result<bool, CtlError> {
        let tx = self.db.begin_write()?;
        let found = tx.open_table(t)?.remove(key)?.is_some();
        tx.commit()?;
        Ok(found)
    }

    /// Replaces the simulated mechanics file (write, then rename: never half written).
    /// Not synced to disk: it only has to survive the process, not the machine.
    pub fn put_sim(&self, m: &BTreeMap<String, SimMechanics>) -> Result<(), CtlError> {
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
            moving: Some(MovingMarker { from: 1, target: 2 }),
            sim_position: 5,
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
