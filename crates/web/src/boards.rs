//! The boards a page shows: the one this process runs, and others reached over their own
//! line protocol (`--http-board HOST:PORT`), so one page can show a whole instrument
//! (seed 002: 17 motors on two boards). Either way a command is a protocol line run by the
//! board's own dispatcher.

use crate::events::BoardSnapshot;
use multistep_controller::client::{Client, ClientError, Endpoint};
use multistep_controller::protocol::Reply;
use multistep_controller::{AxisStatus, Controller, CtlError};
use serde_json::{json, Value};
use std::sync::{Arc, Mutex};

pub enum BoardLink {
    Local(Arc<Controller>),
    Remote(Remote),
}

/// Another board's line protocol over TCP; reconnects on the next use after a failure.
pub struct Remote {
    addr: String,
    client: Mutex<Option<Client>>,
}

/// Protocol code of a board that cannot be reached (the controller's `Io` code).
const UNREACHABLE: u16 = 13;

impl Remote {
    pub fn new(addr: &str) -> Remote {
        Remote {
            addr: addr.to_string(),
            client: Mutex::new(None),
        }
    }

    /// Runs one line: `Ok(data)` or `Err((code, message))`.
    fn request(&self, line: &str) -> Result<Vec<String>, (u16, String)> {
        let mut slot = self.client.lock().unwrap_or_else(|p| p.into_inner());
        if slot.is_none() {
            let c = Client::connect(&Endpoint::Tcp(self.addr.clone())).map_err(|e| {
                (
                    UNREACHABLE,
                    format!("board at {} is unreachable: {e}", self.addr),
                )
            })?;
            *slot = Some(c);
        }
        let client = slot.as_mut().expect("connected above");
        match client.request(line) {
            Ok(data) => Ok(data),
            Err(ClientError::Refused(r)) => Err((r.code, r.message)),
            Err(e) => {
                *slot = None;
                Err((UNREACHABLE, format!("board at {}: {e}", self.addr)))
            }
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
                    "name": info_value(&info, "board").unwrap_or(&r.addr),
                    "axes": info_value(&info, "axes").map_or(vec![], |a| a.split(',').collect()),
                    "clock_hz": info_value(&info, "clock_hz").and_then(|x| x.parse::<f64>().ok()),
                    "remote": r.addr,
                }),
                Err((_, m)) => json!({ "board": k, "name": r.addr, "axes": [], "remote": r.addr, "error": m }),
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
                let got = r.request("info").and_then(|info| {
                    let st = r.request("status json")?;
                    let axes: Vec<AxisStatus> = st
                        .first()
                        .and_then(|j| serde_json::from_str(j).ok())
                        .ok_or((UNREACHABLE, "unreadable status".to_string()))?;
                    Ok((info, axes))
                });
                match got {
                    Ok((info, axes)) => BoardSnapshot {
                        board: k,
                        name: info_value(&info, "board").unwrap_or(&r.addr).to_string(),
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
                        error: None,
                    },
                    Err((_, m)) => BoardSnapshot {
                        board: k,
                        name: r.addr.clone(),
                        tick: 0,
                        clock_hz: 0.0,
                        estop: false,
                        warnings: vec![],
                        axes: vec![],
                        error: Some(m),
                    },
                }
            }
        }
    }
}
