//! Non-volatile memory of the board (seed 002 §2.2: every position change is stored and
//! read back at power-up), in a redb database inside `--data`.
//!
//! Records are JSON values keyed by name. Every write is its own durable transaction, so a
//! kill at any point leaves either the old or the new record.

use crate::axis::AxisSettings;
use crate::error::CtlError;
use crate::protocol::MoveOpts;
use redb::{Database, ReadableTable, TableDefinition};
use serde::{de::DeserializeOwned, Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

const SETTINGS: TableDefinition<&str, &str> = TableDefinition::new("settings");
const AXES: TableDefinition<&str, &str> = TableDefinition::new("axes");
const PRESETS: TableDefinition<&str, &str> = TableDefinition::new("presets");
const NAMED: TableDefinition<&str, &str> = TableDefinition::new("named_positions");

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
}

impl Store {
    pub fn open(dir: &Path) -> Result<Store, CtlError> {
        std::fs::create_dir_all(dir)
            .map_err(|e| CtlError::Store(format!("cannot create {}: {e}", dir.display())))?;
        let db = Database::create(dir.join("board.redb"))?;
        let tx = db.begin_write()?;
        for t in [SETTINGS, AXES, PRESETS, NAMED] {
            tx.open_table(t)?;
        }
        tx.commit()?;
        Ok(Store { db })
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
}

#[cfg(test)]
mod tests {
    use super::*;

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
                    vmax: Some(9.0),
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
        assert_eq!(s.preset("fast").unwrap().unwrap().vmax, Some(9.0));
        assert_eq!(s.named_position("line").unwrap().unwrap()["X"], 7);
        assert!(s.forget_named("line").unwrap());
        assert!(s.named().unwrap().is_empty());
    }
}
