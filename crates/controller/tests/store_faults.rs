//! The store under storage faults: a full disk fails writes until space is freed, then
//! the store works again by itself; a deleted or replaced database is refused, never
//! written into the void.

use multistep_controller::protocol::{Amount, MoveOpts, RateArg, SignedRate, TrackOpts};
use multistep_controller::store::{Store, StoreHealth, DB_FILE, RETRY_PERIOD};
use multistep_controller::{AxisSettings, AxisState, Board, BoardConfig, Controller};
use multistep_core::MoveParams;
use redb::backends::FileBackend;
use redb::StorageBackend;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// The database file on a disk that fills up on demand: while `full`, every write and
/// every growth of the file fails with ENOSPC, as on a full filesystem.
#[derive(Debug)]
struct Disk {
    file: FileBackend,
    full: Arc<AtomicBool>,
}

impl Disk {
    fn check(&self) -> std::io::Result<()> {
        if self.full.load(Ordering::SeqCst) {
            Err(std::io::Error::from_raw_os_error(28)) // ENOSPC
        } else {
            Ok(())
        }
    }
}

impl StorageBackend for Disk {
    fn len(&self) -> std::io::Result<u64> {
        self.file.len()
    }
    fn read(&self, offset: u64, len: usize) -> std::io::Result<Vec<u8>> {
        self.file.read(offset, len)
    }
    fn set_len(&self, len: u64) -> std::io::Result<()> {
        if len > self.file.len()? {
            self.check()?;
        }
        self.file.set_len(len)
    }
    fn sync_data(&self, eventual: bool) -> std::io::Result<()> {
        self.file.sync_data(eventual)
    }
    fn write(&self, offset: u64, data: &[u8]) -> std::io::Result<()> {
        self.check()?;
        self.file.write(offset, data)
    }
}

/// A store on a [`Disk`]; the flag fills it.
fn store_on_disk(dir: &Path) -> (Store, Arc<AtomicBool>) {
    let full = Arc::new(AtomicBool::new(false));
    let flag = full.clone();
    let store = Store::open_with_backend(dir, move |path| {
        let f = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)?;
        Ok(Disk {
            file: FileBackend::new(f).map_err(std::io::Error::other)?,
            full: flag.clone(),
        })
    })
    .unwrap();
    (store, full)
}

fn config() -> BoardConfig {
    let mut c = BoardConfig::default();
    c.board.clock_hz = 1e6;
    c
}

/// The reply's text, and its error code (0 for `ok`).
fn run(c: &Controller, line: &str) -> (String, u16) {
    let r = c.execute_bytes(line.as_bytes());
    let code = r.result.as_ref().err().map_or(0, |e| e.code());
    (r.to_text(), code)
}

/// Waits (wall time) until no axis moves.
fn wait_idle(c: &Controller) {
    for _ in 0..2000 {
        if !c.with_board(|b, _| b.busy()) {
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    panic!("the board never came to rest");
}

/// Every kind of write is refused with the documented code, and status and info say why.
fn every_write_is_refused(c: &Controller) {
    for line in [
        "save p1",
        "move X 100",
        "preset slow vmax=100",
        "rate sidereal 15",
        "set X vmax 2000",
        "forget p0",
    ] {
        let (text, code) = run(c, line);
        assert_eq!(code, 20, "{line}: {text}");
        assert!(text.contains("deleted or replaced"), "{line}: {text}");
    }
    let (status, _) = run(c, "status X");
    assert!(status.contains(" store=gone "), "{status}");
    let (info, _) = run(c, "info");
    assert!(info.contains("store=gone"), "{info}");
    // Reads still answer from what the board holds.
    let (presets, code) = run(c, "presets");
    assert_eq!(code, 0, "{presets}");
    assert!(presets.contains("fast"), "{presets}");
}

fn prepared(dir: &Path) -> Controller {
    let c = Controller::open(&config(), dir, 100.0).unwrap();
    for line in ["preset fast vmax=1000", "save p0", "move X 50"] {
        assert_eq!(run(&c, line).1, 0, "{line}");
    }
    wait_idle(&c);
    c
}

#[test]
fn a_deleted_data_directory_refuses_every_write() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("data");
    let c = prepared(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
    every_write_is_refused(&c);
    // Nothing was recreated in its place.
    assert!(!dir.exists());
}

#[test]
fn a_replaced_database_file_refuses_every_write() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("data");
    let c = prepared(&dir);
    // A copy (a restored backup, another board's file) put in its place.
    let db = dir.join(DB_FILE);
    let copy = dir.join("copy.redb");
    std::fs::copy(&db, &copy).unwrap();
    std::fs::rename(&copy, &db).unwrap();
    let before = std::fs::read(&db).unwrap();
    every_write_is_refused(&c);
    assert_eq!(std::fs::read(&db).unwrap(), before);
}

#[test]
fn a_data_directory_moved_away_and_back_is_written_again() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("data");
    let aside = root.path().join("aside");
    let c = prepared(&dir);
    std::fs::rename(&dir, &aside).unwrap();
    assert_eq!(run(&c, "save p1").1, 20);
    std::fs::rename(&aside, &dir).unwrap();
    assert_eq!(run(&c, "save p1").1, 0);
    let (status, _) = run(&c, "status X");
    assert!(status.contains(" store=ok "), "{status}");
}

fn preset(vmax: f64) -> MoveOpts {
    MoveOpts {
        params: MoveParams {
            vmax: Some(vmax),
            ..MoveParams::default()
        },
        ..MoveOpts::default()
    }
}

#[test]
fn a_full_disk_fails_writes_until_space_is_freed_then_the_store_recovers() {
    let dir = tempfile::tempdir().unwrap();
    let (store, full) = store_on_disk(dir.path());
    let c = Controller::open_store(&config(), store, 100.0).unwrap();
    assert_eq!(run(&c, "preset fast vmax=1000").1, 0);
    full.store(true, Ordering::SeqCst);
    // Every write fails while the disk is full, each with the reason.
    for line in [
        "preset slow vmax=10",
        "save p0",
        "move X 100",
        "set X vmax 2000",
    ] {
        let (text, code) = run(&c, line);
        assert_eq!(code, 10, "{line}: {text}");
        assert!(text.contains("No space left on device"), "{line}: {text}");
    }
    let (status, _) = run(&c, "status X");
    assert!(
        status.contains(" state=idle ") && status.contains(" store=failing "),
        "{status}"
    );
    let (info, _) = run(&c, "info");
    assert!(info.contains("store=failing: "), "{info}");
    // Reads and commands that write nothing go on.
    let (presets, code) = run(&c, "presets");
    assert_eq!((code, presets.contains("fast")), (0, true), "{presets}");
    // Space is freed: the next write succeeds, and status says so.
    full.store(false, Ordering::SeqCst);
    assert_eq!(run(&c, "preset slow vmax=10").1, 0);
    let (status, _) = run(&c, "status X");
    assert!(status.contains(" store=ok "), "{status}");
    assert_eq!(run(&c, "move X 100").1, 0);
    wait_idle(&c);
    let (info, _) = run(&c, "info");
    assert!(info.contains("store=ok"), "{info}");
    drop(c);
    // Everything acknowledged is on the disk.
    let s = Store::open(dir.path()).unwrap();
    assert_eq!(s.preset("fast").unwrap(), Some(preset(1000.0)));
    assert_eq!(s.preset("slow").unwrap(), Some(preset(10.0)));
    let x = s.axis("X").unwrap().unwrap();
    assert_eq!((x.position, x.moving), (100, None));
}

#[test]
fn a_failing_store_is_tried_again_without_a_write() {
    let dir = tempfile::tempdir().unwrap();
    let (store, full) = store_on_disk(dir.path());
    full.store(true, Ordering::SeqCst);
    assert!(store.put_preset("p", &preset(5.0)).is_err());
    assert!(matches!(store.check(), StoreHealth::Failing(_)));
    full.store(false, Ordering::SeqCst);
    std::thread::sleep(RETRY_PERIOD);
    assert_eq!(store.check(), StoreHealth::Ok);
    store.put_preset("p", &preset(5.0)).unwrap();
}

#[test]
fn a_tracking_axis_goes_on_while_the_disk_is_full_and_its_stop_shows_the_failure() {
    let dir = tempfile::tempdir().unwrap();
    let (store, full) = store_on_disk(dir.path());
    let axis = AxisSettings {
        vmax: 5000.0,
        amax: 20000.0,
        ..AxisSettings::default()
    };
    let mut c = config();
    c.axes[0].settings = axis;
    let mut b = Board::open(&c, store).unwrap();
    b.set_rate_preset("sidereal", &SignedRate::parse("1000").unwrap().unwrap())
        .unwrap();
    let named = RateArg::Preset("sidereal".into());
    let lease = TrackOpts {
        amax: None,
        lease: Some(0.3),
    };
    b.track("X", &named, &lease, Some(300_000), 0).unwrap();
    full.store(true, Ordering::SeqCst);
    // The jog's renewals (by the stored rate's name) need no write: tracking goes on.
    for k in 1..10u64 {
        b.track("X", &named, &lease, Some(300_000), k * 200_000)
            .unwrap();
    }
    let now = b.now();
    // A move needs its marker written first: refused.
    let e = b
        .move_axis("Y", Amount::Steps(10), false, &MoveOpts::default(), now)
        .unwrap_err();
    assert_eq!(e.code(), 10, "{e}");
    let s = b.status(&["X".into()], now).unwrap().remove(0);
    assert_eq!((s.state, &*s.store), (AxisState::Tracking, "failing"));
    // The stop cannot be stored: the axis says so, not a plain idle.
    b.stop(Some("X"), now).unwrap();
    b.advance(now + 1_000_000);
    let s = b.status(&["X".into()], now + 1_000_000).unwrap().remove(0);
    assert_eq!(s.state, AxisState::Fault, "{s:?}");
    let fault = s.fault.unwrap_or_default();
    assert!(
        fault.contains("position not stored") && fault.contains("No space left"),
        "{fault}"
    );
    assert!(b
        .warnings()
        .iter()
        .any(|w| w.contains("position not stored")));
    // Space is freed: the record the board could not write is written with the next write.
    full.store(false, Ordering::SeqCst);
    let pos = s.position;
    b.set_preset("after", &preset(3.0)).unwrap();
    drop(b);
    let s = Store::open(dir.path()).unwrap();
    let x = s.axis("X").unwrap().unwrap();
    assert_eq!((x.position, x.moving), (pos, None));
}
