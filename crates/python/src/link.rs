//! The line to a board, TCP or serial: one request line out, data lines and `ok` or
//! `error:` back, as the controller crate's client speaks it, but with a deadline on every
//! call and the GIL released in short slices between which Python's signal handlers run
//! (so Ctrl-C ends a call within a slice).

use crate::errors::{board_err, connection_err, timeout_err};
use multistep_controller::client::{Endpoint, Refused};
use multistep_controller::protocol::parse_status_line;
use multistep_controller::Command;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Longest wait without running Python's signal handlers.
pub const SLICE: Duration = Duration::from_millis(50);
/// Longest line of a reply, and longest reply: a board's longest (`status json` of 16
/// axes, a long `positions`) is far shorter; past these the peer is not a board.
const MAX_LINE: usize = 1 << 20;
const MAX_REPLY: usize = 64 << 20;

enum Stream {
    Tcp(TcpStream),
    Serial(Box<dyn serialport::SerialPort>),
}

impl Stream {
    /// Sets how long one read or write may block.
    fn slice(&mut self, d: Duration) -> std::io::Result<()> {
        let d = d.max(Duration::from_millis(1));
        match self {
            Stream::Tcp(s) => {
                s.set_read_timeout(Some(d))?;
                s.set_write_timeout(Some(d))
            }
            Stream::Serial(p) => p.set_timeout(d).map_err(std::io::Error::from),
        }
    }

    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self {
            Stream::Tcp(s) => s.read(buf),
            Stream::Serial(p) => p.read(buf),
        }
    }

    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            Stream::Tcp(s) => s.write(buf),
            Stream::Serial(p) => p.write(buf),
        }
    }
}

/// A TCP connection to `addr` (its addresses tried in turn) by `deadline`.
fn open_tcp(addr: &str, deadline: Instant) -> std::io::Result<TcpStream> {
    let mut last = None;
    for a in addr.to_socket_addrs()? {
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(ErrorKind::TimedOut.into());
        }
        match TcpStream::connect_timeout(&a, left) {
            Ok(s) => {
                s.set_nodelay(true)?;
                return Ok(s);
            }
            Err(e) => last = Some(e),
        }
    }
    Err(last.unwrap_or_else(|| {
        std::io::Error::new(ErrorKind::NotFound, format!("no address for {addr}"))
    }))
}

/// Waits for what `rx` brings, without the GIL, running Python's signal handlers every
/// `SLICE`; `None` once `deadline` passes. On Ctrl-C, with `stop` it sets `stop` and still
/// waits (the sender then ends soon) before raising; without, it raises at once.
pub fn wait_for<T: Send>(
    py: Python<'_>,
    mut rx: mpsc::Receiver<T>,
    stop: Option<&AtomicBool>,
    deadline: Option<Instant>,
) -> PyResult<Option<T>> {
    let mut interrupted = None;
    loop {
        let slice = deadline.map_or(SLICE, |d| {
            d.saturating_duration_since(Instant::now()).min(SLICE)
        });
        let (back, r) = py.detach(move || {
            let r = rx.recv_timeout(slice);
            (rx, r)
        });
        rx = back;
        match r {
            Ok(t) => return interrupted.map_or(Ok(Some(t)), Err),
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                return Err(PyRuntimeError::new_err(
                    "the worker thread ended without a result",
                ))
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
        }
        if interrupted.is_none() {
            if let Err(e) = py.check_signals() {
                match stop {
                    Some(flag) => {
                        flag.store(true, Ordering::Relaxed);
                        interrupted = Some(e);
                    }
                    None => return Err(e),
                }
            }
        }
        if interrupted.is_none() && deadline.is_some_and(|d| Instant::now() >= d) {
            return Ok(None);
        }
    }
}

/// A read or write that ran out of its slice, or was cut short by a signal: try again.
fn again(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
    )
}

pub struct Link {
    stream: Stream,
    /// Bytes received after the last whole line.
    buf: Vec<u8>,
    /// Replies still to come to requests whose calls ended early (a timeout, Ctrl-C): the
    /// next request reads past them first, so every call gets its own reply.
    owed: usize,
    /// Why the line can no longer be used (a line half written, a peer that is not a board).
    broken: Option<String>,
}

impl Link {
    /// Opens the line to `ep` within `timeout`.
    pub fn connect(py: Python<'_>, ep: &Endpoint, timeout: Duration) -> PyResult<Link> {
        let stream = match ep {
            Endpoint::Tcp(addr) => {
                let deadline = Instant::now() + timeout;
                let late = || {
                    let t = timeout.as_secs_f64();
                    timeout_err(py, format!("could not connect to {addr} within {t} s"))
                };
                // on a thread of its own (the name lookup has no timeout); if Ctrl-C or the
                // deadline comes first, it is left to end by itself
                let (tx, rx) = mpsc::channel();
                let a = addr.clone();
                std::thread::spawn(move || tx.send(open_tcp(&a, deadline)));
                let s = wait_for(py, rx, None, Some(deadline))?
                    .ok_or_else(late)?
                    .map_err(|e| match e.kind() {
                        ErrorKind::TimedOut | ErrorKind::WouldBlock => late(),
                        _ => connection_err(py, format!("connection: {e}")),
                    })?;
                Stream::Tcp(s)
            }
            Endpoint::Serial(dev) => {
                let port = py
                    .detach(|| serialport::new(dev, 115_200).timeout(SLICE).open())
                    .map_err(|e| board_err(py, format!("cannot open {dev}: {e}")))?;
                Stream::Serial(port)
            }
        };
        Ok(Link {
            stream,
            buf: Vec::new(),
            owed: 0,
            broken: None,
        })
    }

    /// Sends one command and returns its data lines, or the board's refusal; the whole
    /// exchange (and the replies still owed before it) within `timeout`.
    pub fn send(
        &mut self,
        py: Python<'_>,
        cmd: &Command,
        timeout: Duration,
    ) -> PyResult<Result<Vec<String>, Refused>> {
        check_words(cmd).map_err(|m| board_err(py, m))?;
        self.request(py, &cmd.to_string(), timeout)
    }

    /// Sends one line as it is; see [`Link::send`].
    pub fn request(
        &mut self,
        py: Python<'_>,
        line: &str,
        timeout: Duration,
    ) -> PyResult<Result<Vec<String>, Refused>> {
        if line.contains(['\n', '\r']) {
            return Err(board_err(py, "a command is one line".into()));
        }
        if let Some(why) = &self.broken {
            return Err(connection_err(py, why.clone()));
        }
        let deadline = Instant::now().checked_add(timeout);
        while self.owed > 0 {
            // the reply to a call that already ended: nobody is left to hear it
            let _ = self.reply(py, deadline, timeout)?;
            self.owed -= 1;
        }
        self.write_all(py, format!("{line}\n").as_bytes(), deadline, timeout)?;
        self.owed += 1;
        let r = self.reply(py, deadline, timeout)?;
        self.owed -= 1;
        Ok(r)
    }

    fn write_all(
        &mut self,
        py: Python<'_>,
        mut data: &[u8],
        deadline: Option<Instant>,
        timeout: Duration,
    ) -> PyResult<()> {
        let whole = data.len();
        // Ctrl-C and the deadline are let in only while nothing is written, so a line sent
        // whole is always counted as owed a reply
        let cut = |link: &mut Link, e: PyErr, left: usize| {
            if left != whole && link.broken.is_none() {
                // half a line on the wire: what follows would be read with it
                link.broken = Some("a command was cut short halfway; reconnect".into());
            }
            e
        };
        while !data.is_empty() {
            let left = match self.left(py, deadline, timeout, "take the command") {
                Ok(l) => l,
                Err(e) => return Err(cut(self, e, data.len())),
            };
            let stream = &mut self.stream;
            let r = py.detach(|| {
                stream
                    .slice(left.min(SLICE))
                    .and_then(|_| stream.write(data))
            });
            match r {
                Ok(0) => return Err(self.fail(py, "the board closed the connection".into())),
                Ok(n) => data = &data[n..],
                Err(e) if again(&e) => {
                    if let Err(e) = py.check_signals() {
                        return Err(cut(self, e, data.len()));
                    }
                }
                Err(e) => return Err(self.fail(py, format!("connection: {e}"))),
            }
        }
        Ok(())
    }

    /// Reads one reply: data lines up to `ok`, or `error:<code> <message>`.
    fn reply(
        &mut self,
        py: Python<'_>,
        deadline: Option<Instant>,
        timeout: Duration,
    ) -> PyResult<Result<Vec<String>, Refused>> {
        let mut data = Vec::new();
        let mut size = 0;
        loop {
            let line = self.line(py, deadline, timeout)?;
            match parse_status_line(&line) {
                Some(Ok(())) => return Ok(Ok(data)),
                Some(Err((code, message))) => return Ok(Err(Refused { code, message })),
                None => {
                    size += line.len();
                    if size > MAX_REPLY {
                        let why = format!("a reply longer than {} MiB", MAX_REPLY >> 20);
                        return Err(board_err(py, self.broke(why)));
                    }
                    data.push(line);
                }
            }
        }
    }

    /// The next whole line, without its line end.
    fn line(
        &mut self,
        py: Python<'_>,
        deadline: Option<Instant>,
        timeout: Duration,
    ) -> PyResult<String> {
        let mut seen = 0;
        loop {
            if let Some(i) = self.buf[seen..].iter().position(|&b| b == b'\n') {
                let rest = self.buf.split_off(seen + i + 1);
                let line = std::mem::replace(&mut self.buf, rest);
                let text = String::from_utf8_lossy(&line);
                return Ok(text.trim_end_matches(['\n', '\r']).to_string());
            }
            seen = self.buf.len();
            if seen > MAX_LINE {
                let why = format!("a reply line longer than {} MiB", MAX_LINE >> 20);
                return Err(board_err(py, self.broke(why)));
            }
            let left = self.left(py, deadline, timeout, "answer")?;
            let mut chunk = [0u8; 4096];
            let stream = &mut self.stream;
            let r = py.detach(|| {
                stream
                    .slice(left.min(SLICE))
                    .and_then(|_| stream.read(&mut chunk))
            });
            match r {
                Ok(0) => {
                    return Err(self.fail(py, "the board closed the connection".into()));
                }
                Ok(n) => self.buf.extend_from_slice(&chunk[..n]),
                Err(e) if again(&e) => {}
                Err(e) => return Err(self.fail(py, format!("connection: {e}"))),
            }
            py.check_signals()?;
        }
    }

    /// Time left before `deadline`, or the timeout error.
    fn left(
        &self,
        py: Python<'_>,
        deadline: Option<Instant>,
        timeout: Duration,
        what: &str,
    ) -> PyResult<Duration> {
        let Some(d) = deadline else {
            return Ok(SLICE);
        };
        let left = d.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(timeout_err(
                py,
                format!(
                    "the board did not {what} within {} s",
                    timeout.as_secs_f64()
                ),
            ));
        }
        Ok(left)
    }

    /// Marks the line unusable (later calls raise `BoardConnectionError` with `why`).
    fn broke(&mut self, why: String) -> String {
        self.broken = Some(why.clone());
        why
    }

    /// A broken connection: the error that ends this call and every later one.
    fn fail(&mut self, py: Python<'_>, why: String) -> PyErr {
        connection_err(py, self.broke(why))
    }
}

/// Every free-text word of `cmd` (names, keys, values) must stay one word on the line, or
/// the board would read another command.
fn check_words(cmd: &Command) -> Result<(), String> {
    let opts = |o: &multistep_controller::MoveOpts| -> Vec<String> {
        o.preset.iter().chain(o.profile.iter()).cloned().collect()
    };
    let words: Vec<String> = match cmd {
        Command::Status { axes, .. } => axes.clone(),
        Command::Save { name, axes } => [name.clone()].into_iter().chain(axes.clone()).collect(),
        Command::Move { axis, opts: o, .. } | Command::MoveTo { axis, opts: o, .. } => {
            [axis.clone()].into_iter().chain(opts(o)).collect()
        }
        Command::Group {
            targets, opts: o, ..
        }
        | Command::Arm {
            targets, opts: o, ..
        } => targets.iter().map(|t| t.0.clone()).chain(opts(o)).collect(),
        Command::Stop { axis: Some(a) }
        | Command::Home { axis: a }
        | Command::SimSlip { axis: a, .. }
        | Command::Release { axis: a }
        | Command::Energize { axis: a }
        | Command::Forget { name: a }
        | Command::RatePreset { name: a, .. } => vec![a.clone()],
        Command::Track { axis, rate, .. } => match rate {
            multistep_controller::protocol::RateArg::Preset(n) => vec![axis.clone(), n.clone()],
            _ => vec![axis.clone()],
        },
        Command::Get { axis, key } => [axis.clone()].into_iter().chain(key.clone()).collect(),
        Command::Set { axis, key, value } => vec![axis.clone(), key.clone(), value.clone()],
        Command::Goto { name, opts: o } | Command::Preset { name, opts: o } => {
            [name.clone()].into_iter().chain(opts(o)).collect()
        }
        _ => Vec::new(),
    };
    for w in words {
        if w.is_empty() || w.contains(|c: char| c.is_whitespace() || c == '#' || c == ';') {
            return Err(format!(
                "'{w}' is not one protocol word (empty, or has a space, '#' or ';')"
            ));
        }
    }
    Ok(())
}
