//! `status` of a board with a link, through the whole controller on the register model:
//! the link's state as a field, and answers while a link exchange stalls.

use super::model::{Model, ModelPort};
use super::{FpgaBackend, Opener, Port};
use crate::axis::{AxisState, AxisStatus, Link};
use crate::store::Store;
use crate::{BoardConfig, Controller};
use std::io::{Read, Write};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// The longest a stalled read waits for the test to let it go: only a failing test
/// (whose `status` waited for the board) ever reaches it.
const STALL_CAP: Duration = Duration::from_secs(30);

#[derive(Default)]
struct StallState {
    /// Reads stall from now on, until `released`.
    armed: bool,
    /// A read is stalled now.
    holding: bool,
    released: bool,
}

#[derive(Default)]
struct Stall {
    state: Mutex<StallState>,
    changed: Condvar,
}

impl Stall {
    fn lock(&self) -> std::sync::MutexGuard<'_, StallState> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// The model's port, whose reads stall while the test holds them.
struct StallPort {
    inner: ModelPort,
    stall: Arc<Stall>,
}

impl Write for StallPort {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.inner.write(b)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl Read for StallPort {
    fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
        let mut st = self.stall.lock();
        if st.armed && !st.released {
            st.holding = true;
            self.stall.changed.notify_all();
            st = self
                .stall
                .changed
                .wait_timeout_while(st, STALL_CAP, |s| !s.released)
                .unwrap_or_else(|p| p.into_inner())
                .0;
            st.holding = false;
            self.stall.changed.notify_all();
        }
        drop(st);
        self.inner.read(b)
    }
}

/// A controller running a two-axis board on the model through `StallPort`.
fn controller(dir: &std::path::Path) -> (Controller, Arc<Mutex<Model>>, Arc<Stall>) {
    let m = Arc::new(Mutex::new(Model::default()));
    let stall = Arc::new(Stall::default());
    let (port, s) = (m.clone(), stall.clone());
    let open: Opener = Box::new(move || {
        Ok(Box::new(StallPort {
            inner: ModelPort(port.clone()),
            stall: s.clone(),
        }) as Box<dyn Port>)
    });
    let pins = FpgaBackend::with_opener("model".into(), open, 2).expect("the model answers");
    let config = BoardConfig::parse(
        "[board]\nname = \"t\"\n[[axis]]\nname = \"X\"\n[[axis]]\nname = \"Y\"\n",
    )
    .unwrap();
    let store = Store::open(dir).unwrap();
    let ctl = Controller::open_backend(&config, store, 1.0, Box::new(pins)).unwrap();
    (ctl, m, stall)
}

/// Asks for X's status until `done` holds of it (each answer is immediate).
fn x_until(ctl: &Controller, what: &str, done: impl Fn(&AxisStatus) -> bool) -> AxisStatus {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let x = ctl.status(&["X".into()]).unwrap().remove(0);
        if done(&x) {
            return x;
        }
        assert!(Instant::now() < deadline, "never {what}: {x:?}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn status_says_whether_the_link_is_up_as_a_field() {
    let dir = tempfile::tempdir().unwrap();
    let (ctl, m, _) = controller(dir.path());
    let x = x_until(&ctl, "up", |x| x.link == Some(Link::Up));
    assert_eq!(x.state, AxisState::Idle, "{x:?}");
    assert!(x.age_ms.is_some(), "the board was read: {x:?}");
    assert!(x.line().contains(" link=up age_ms="), "{}", x.line());
    m.lock().unwrap().cut = true;
    let x = x_until(&ctl, "down", |x| x.link == Some(Link::Down));
    assert_eq!((x.state, x.trusted), (AxisState::Fault, false), "{x:?}");
    // the fault text as before, for clients that read it
    let fault = x.fault.clone().unwrap_or_default();
    assert!(fault.starts_with("board link model down: "), "{fault}");
    assert!(x.line().contains(" link=down age_ms="), "{}", x.line());
    // by number as well as by name
    let by_number = ctl.status(&["0".into()]).unwrap().remove(0);
    assert_eq!(
        (by_number.axis.as_str(), by_number.link),
        ("X", Some(Link::Down))
    );
    assert!(
        ctl.status(&["Z".into()]).is_err(),
        "an unknown axis is refused"
    );
    m.lock().unwrap().cut = false;
    let x = x_until(&ctl, "up again", |x| x.link == Some(Link::Up));
    assert_eq!(x.state, AxisState::Idle, "{x:?}");
}

/// The poll holds the board through a link exchange; `status` answers meanwhile, from the
/// board as last read, while the stalled read still waits.
#[test]
fn status_answers_while_a_link_exchange_stalls() {
    let dir = tempfile::tempdir().unwrap();
    let (ctl, _m, stall) = controller(dir.path());
    x_until(&ctl, "up", |x| x.link == Some(Link::Up));
    stall.lock().armed = true;
    // the ticker's next poll reads the board and stalls in it, holding the board
    {
        let st = stall.lock();
        let (st, _) = stall
            .changed
            .wait_timeout_while(st, Duration::from_secs(20), |s| !s.holding)
            .unwrap();
        assert!(st.holding, "the poll never read the board");
    }
    let all = ctl.status(&[]).unwrap();
    assert!(
        stall.lock().holding,
        "status waited for the stalled exchange to end"
    );
    assert_eq!(all.len(), 2);
    for s in &all {
        assert_eq!(
            (s.state, s.link),
            (AxisState::Idle, Some(Link::Up)),
            "{s:?}"
        );
        assert!(s.age_ms.is_some(), "{s:?}");
    }
    let mut st = stall.lock();
    st.released = true;
    stall.changed.notify_all();
}
