//! The boards a page shows: the one this process runs, and others reached over their own
//! line protocol (`--http-board HOST:PORT`), so one page can show a whole instrument
//! (seed 002: 17 motors on two boards). Either way a command is a protocol line run by the
//! board's own dispatcher.

use crate::snapshot::{BoardSnapshot, IDLE_PERIOD, MOVING_PERIOD};
use multistep_controller::client::{Client, ClientError, Endpoint};
use multistep_controller::protocol::Reply;
use multistep_controller::{AxisState, AxisStatus, Controller, CtlError};
use serde_json::{json, Value};
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::{Arc, Mutex};
use std::time::Duration;

pub enum BoardLink {
    Local(Arc<Controller>),
    Remote(Remote),
}

/// Another board's line protocol over TCP; reconnects on the next use after a failure.
/// A poller thread keeps its latest snapshot, so a slow or unreachable board never holds
/// up the updates of the others, however many pages are open.
pub struct Remote {
    link: Arc<RemoteLink>,
}

struct RemoteLink {
    addr: String,
    client: Mutex<Option<Client>>,
    latest: Mutex<Option<BoardSnapshot>>,
}

/// Protocol code of a board that cannot be reached (the controller's `Io` code).
const UNREACHABLE: u16 = 13;
/// How long a connection attempt may take before the board counts as unreachable.
const CONNECT_TIMEOUT: Duration = Duration::from_millis(500);

impl Remote {
    /// Starts polling the board at `addr`; the poller ends when the `Remote` is dropped.
    pub fn new(addr: &str) -> Remote {
        let link = Arc::new(RemoteLink {
            addr: addr.to_string(),
            client: Mutex::new(None),
            latest: Mutex::new(None),
        });
        let weak = Arc::downgrade(&link);
        let _ = std::thread::Builder::new()
            .name("http-board".into())
            .spawn(move || {
                while let Some(link) = weak.upgrade() {
                    let snap = link.read_snapshot();
                    let pause = if snap.axes.iter().any(|a| {
                        matches!(
                            a.state,
                            AxisState::Moving | AxisState::Homing | AxisState::Tracking
                        )
                    }) {
                        MOVING_PERIOD
                    } else {
                        IDLE_PERIOD
                    };
                    *lock(&link.latest) = Some(snap);
                    drop(link);
                    std::thread::sleep(pause);
                }
            });
        Remote { link }
    }

    fn request(&self, line: &str) -> Result<Vec<String>, (u16, String)> {
        self.link.request(line)
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl RemoteLink {
    /// Runs one line: `Ok(data)` or `Err((code, message))`.
    fn request(&self, line: &str) -> Result<Vec<String>, (u16, String)> {
        let unreachable = |e: String| {
            (
                UNREACHABLE,
                format!("board at {} is unreachable: {e}", self.addr),
            )
        };
        let mut slot = lock(&self.client);
        if slot.is_none() {
            // Probe with a timeout first: a plain connect to a silent host waits minutes.
            let sock = self
                .addr
                .to_socket_addrs()
                .map_err(|e| unreachable(e.to_string()))?
                .next()
                .ok_or_else(|| unreachable("no address".into()))?;
            TcpStream::connect_timeout(&sock, CONNECT_TIMEOUT)
                .map_err(|e| unreachable(e.to_string()))?;
            let c = Client::connect(&Endpoint::Tcp(self.addr.clone()))
                .map_err(|e| unreachable(e.to_string()))?;
            *slot = Some(c);
        }
        let client = slot.as_mut().expect("connected above");
        match client.request(line) {
            Ok(data) => Ok(data),
            Err(ClientError::Refused(r)) => Err((r.code, r.message)),
            // the connection broke: said as a board that cannot be reached, whichever
            // request (this one, or the next one's connect) finds out first
            Err(e) => {
                *slot = None;
                Err(unreachable(e.to_string()))
            }
        }
    }

    /// `info` and `status json` over the line protocol.
    fn read_snapshot(&self) -> BoardSnapshot {
        let got = self.request("info").and_then(|info| {
            let st = self.request("status json")?;
            let axes: Vec<AxisStatus> = st
                .first()
                .and_then(|j| serde_json::from_str(j).ok())
                .ok_or((UNREACHABLE, "unreadable status".to_string()))?;
            Ok((info, axes))
        });
        let (info, axes, error) = match got {
            Ok((info, axes)) => (info, axes, None),
            Err((_, m)) => (vec![], vec![], Some(m)),
        };
        BoardSnapshot {
            board: 0,
            name: info_value(&info, "board").unwrap_or(&self.addr).to_string(),
            tick: info_value(&info, "tick")
                .and_then(|x| x.parse().ok())
                .unwrap_or(0),
            clock_hz: info_value(&info, "clock_hz")
                .and_then(|x| x.parse().ok())
                .unwrap_or(0.0),
            estop: info_value(&info, "estop") == Some("1"),
            warnings: info
                .iter()
                .filter_map(|l| l.strip_prefix("warning="))
                .map(String::from)
                .collect(),
            axes,
            error,
        }
    }
}

fn reply_value(r: Result<Vec<String>, (u16, String)>) -> Value {
    match r {
        Ok(data) => json!({ "ok": true, "data": data }),
        Err((code, message)) => {
            json!({ "ok": false, "data": [], "error": { "code": code, "message": message } })
        }
    }
}

/// A protocol reply as JSON: `{ok, data, error: {code, message}}`.
pub fn reply_json(r: &Reply) -> Value {
    reply_value(match &r.result {
        Ok(()) => Ok(r.data.clone()),
        Err(e) => Err((e.code(), e.to_string())),
    })
}

pub fn error_json(e: &CtlError) -> Value {
    json!({ "ok": false, "error": { "code": e.code(), "message": e.to_string() } })
}

/// `key=value` lines of `info`.
fn info_value<'a>(lines: &'a [String], key: &str) -> Option<&'a str> {
    lines
        .iter()
        .find_map(|l| l.strip_prefix(key)?.strip_prefix('='))
}

impl BoardLink {
    /// Runs one protocol line on the board.
    pub fn run(&self, line: &str) -> Value {
        match self {
            BoardLink::Local(c) => reply_json(&c.execute_bytes(line.as_bytes())),
            BoardLink::Remote(r) => reply_value(r.request(line)),
        }
    }

    /// The board's name, axes and clock; a remote board that cannot be reached has none.
    pub fn describe(&self, k: usize) -> Value {
        match self {
            BoardLink::Local(c) => c.with_board(|b, _| {
                json!({ "board": k, "name": b.name(), "axes": b.axis_names(), "clock_hz": b.clock_hz(), "remote": null })
            }),
            BoardLink::Remote(r) => match r.request("info") {
                Ok(info) => json!({
                    "board": k,
                    "name": info_value(&info, "board").unwrap_or(&r.link.addr),
                    "axes": info_value(&info, "axes").map_or(vec![], |a| a.split(',').collect()),
                    "clock_hz": info_value(&info, "clock_hz").and_then(|x| x.parse::<f64>().ok()),
                    "remote": r.link.addr,
                }),
                Err((_, m)) => json!({ "board": k, "name": r.link.addr, "axes": [], "remote": r.link.addr, "error": m }),
            },
        }
    }

    /// Every axis of the board at one moment.
    pub fn snapshot(&self, k: usize) -> BoardSnapshot {
        match self {
            BoardLink::Local(c) => c.with_board(|b, now| BoardSnapshot {
                board: k,
                name: b.name().to_string(),
                tick: now,
                clock_hz: b.clock_hz(),
                estop: b.is_estopped(),
                warnings: b.warnings().to_vec(),
                axes: b.status(&[], now).unwrap_or_default(),
                error: None,
            }),
            BoardLink::Remote(r) => {
                let latest = lock(&r.link.latest).clone();
                let mut snap = latest.unwrap_or_else(|| BoardSnapshot {
                    board: 0,
                    name: r.link.addr.clone(),
                    tick: 0,
                    clock_hz: 0.0,
                    estop: false,
                    warnings: vec![],
                    axes: vec![],
                    error: Some(format!("connecting to the board at {}…", r.link.addr)),
                });
                snap.board = k;
                snap
            }
        }
    }
}
