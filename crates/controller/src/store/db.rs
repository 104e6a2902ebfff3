//! The database file: opening it (redb's panics on a damaged file caught and reported as
//! damage), its identity on disk, and one transaction of writes.

use super::*;

thread_local! {
    /// Set while this thread opens a database: redb's panics there are reported as damage.
    static QUIET: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f`, catching a panic; its message is not printed. The process's panic hook is
/// wrapped once (the hook before keeps every other panic), never swapped per call.
pub(super) fn quietly<R>(f: impl FnOnce() -> R) -> std::thread::Result<R> {
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
pub(super) fn try_open(
    path: &Path,
    open: &Opener,
    create: bool,
) -> Result<(Database, Mirror), Failure> {
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
pub(super) fn identity(path: &Path) -> std::io::Result<(u64, u64)> {
    std::fs::metadata(path).map(|m| (m.dev(), m.ino()))
}

/// The database file inside a board's data directory.
pub const DB_FILE: &str = "board.redb";

/// Why opening failed: a damaged file (which a fresh start may move aside) or not.
pub(super) enum Failure {
    Damaged(String),
    Other(CtlError),
}

impl From<CtlError> for Failure {
    fn from(e: CtlError) -> Self {
        Failure::Damaged(e.to_string())
    }
}

impl Failure {
    pub(super) fn reason(self) -> String {
        match self {
            Failure::Damaged(why) => why,
            Failure::Other(e) => e.to_string(),
        }
    }
}

/// One write: a record put (`Some`) or removed (`None`).
pub(super) type Op<'a> = (Table, &'a str, Option<&'a str>);

/// Commits `ops` in one transaction; for each, whether its key was there before.
pub(super) fn commit(db: &Database, ops: &[Op]) -> Result<Vec<bool>, String> {
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
