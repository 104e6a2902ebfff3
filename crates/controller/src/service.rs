//! Serving the line protocol: a TCP listener with one thread per client (capped, with
//! timeouts and, off loopback, a token), and optionally a serial line. Each complete line
//! gets exactly one reply, whatever it contains; a line cut off is never run.

use crate::access::same_token;
use crate::controller::Controller;
use crate::error::CtlError;
use crate::protocol::{auth_token, Line, LineReader, Reply, MAX_LINE};
use std::io::{BufReader, ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Connection limits of the TCP side (and the line timeout of the serial side).
#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    /// Most TCP clients at once; one more is answered one `error:17` line and closed.
    pub max_clients: usize,
    /// A TCP client that sends no complete line for this long is closed.
    pub idle_timeout: Duration,
    /// A TCP line not completed this long after its first byte closes the connection
    /// (slowloris); on the serial line, a pause this long inside a line drops the line.
    pub line_timeout: Duration,
}

/// Ranges of the limits, in clients and seconds.
pub const MAX_CLIENTS_RANGE: (usize, usize) = (1, 1024);
pub const IDLE_TIMEOUT_RANGE: (u64, u64) = (1, 86_400);
pub const LINE_TIMEOUT_RANGE: (u64, u64) = (1, 3_600);

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_clients: 64,
            idle_timeout: Duration::from_secs(600),
            line_timeout: Duration::from_secs(10),
        }
    }
}

impl Limits {
    /// Limits from whole numbers (clients, seconds), each checked against its range.
    pub fn new(max_clients: usize, idle_s: u64, line_s: u64) -> Result<Limits, CtlError> {
        let check = |name: &str, v: u64, (lo, hi): (u64, u64)| {
            if (lo..=hi).contains(&v) {
                Ok(())
            } else {
                Err(CtlError::Setting(format!(
                    "{name} must be in [{lo}, {hi}] (got {v})"
                )))
            }
        };
        let (lo, hi) = MAX_CLIENTS_RANGE;
        check("max clients", max_clients as u64, (lo as u64, hi as u64))?;
        check("idle timeout", idle_s, IDLE_TIMEOUT_RANGE)?;
        check("line timeout", line_s, LINE_TIMEOUT_RANGE)?;
        Ok(Limits {
            max_clients,
            idle_timeout: Duration::from_secs(idle_s),
            line_timeout: Duration::from_secs(line_s),
        })
    }
}

/// How the TCP side serves: its limits, and the token every client must send first.
#[derive(Clone, Debug, Default)]
pub struct TcpOptions {
    pub limits: Limits,
    pub token: Option<String>,
}

/// Answers lines from `input` on `output` until end of input or a write error.
pub fn serve_stream<R: Read, W: Write>(
    ctl: &Controller,
    input: R,
    mut output: W,
) -> std::io::Result<()> {
    let mut input = BufReader::with_capacity(MAX_LINE, input);
    let mut lines = LineReader::new();
    let mut text = String::new();
    loop {
        let line = match lines.read(&mut input)? {
            Line::Eof => return Ok(()),
            line => line,
        };
        answer(ctl, line, &mut text);
        output.write_all(text.as_bytes())?;
        output.flush()?;
    }
}

/// The reply to `line` as sent, in `text` (cleared first: a connection reuses it).
fn answer(ctl: &Controller, line: Line, text: &mut String) {
    text.clear();
    match line {
        Line::Eof => Reply::ok(Vec::new()).write_text(text),
        Line::TooLong => Reply::err(CtlError::LineTooLong { max: MAX_LINE }).write_text(text),
        // Nothing to authenticate against here (serial, or a board without a token).
        Line::Text(b) if auth_token(&b).is_some() => Reply::ok(Vec::new()).write_text(text),
        Line::Text(b) => ctl.answer_bytes(&b, text),
    }
}

fn send(out: &mut impl Write, reply: &Reply) -> std::io::Result<()> {
    out.write_all(reply.to_text().as_bytes())?;
    out.flush()
}

/// Accepts clients on `listener` forever with the default limits and no token.
pub fn serve_tcp(ctl: Arc<Controller>, listener: TcpListener) -> std::io::Result<()> {
    serve_tcp_with(ctl, listener, TcpOptions::default())
}

/// Accepts clients forever, one thread each, at most `limits.max_clients` at once.
pub fn serve_tcp_with(
    ctl: Arc<Controller>,
    listener: TcpListener,
    opts: TcpOptions,
) -> std::io::Result<()> {
    let opts = Arc::new(opts);
    let clients = Arc::new(AtomicUsize::new(0));
    let mut accept_log = RateLimitedLog::new(Duration::from_secs(10));
    for conn in listener.incoming() {
        let stream = match conn {
            Ok(s) => s,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => {
                accept_log.log(&format!("accept: {e}"));
                // Out of file descriptors, accept fails at once again: do not spin.
                std::thread::sleep(Duration::from_millis(50));
                continue;
            }
        };
        let _ = stream.set_nodelay(true);
        if clients.fetch_add(1, Ordering::SeqCst) >= opts.limits.max_clients {
            clients.fetch_sub(1, Ordering::SeqCst);
            refuse(
                stream,
                &format!(
                    "too many clients (at most {}); try again later",
                    opts.limits.max_clients
                ),
            );
            continue;
        }
        let slot = Slot(clients.clone());
        let (ctl, opts) = (ctl.clone(), opts.clone());
        let spawned = std::thread::Builder::new()
            .name("tcp-client".into())
            .spawn(move || {
                let _slot = slot;
                let _ = serve_client(&ctl, &stream, &opts);
            });
        if let Err(e) = spawned {
            accept_log.log(&format!("cannot start a client thread: {e}"));
        }
    }
    Ok(())
}

/// A client that sends more than this many lines a second without pause (a poller) is
/// served at a lower OS priority from then on, so on a loaded machine the scheduler
/// prefers the thread of a client that sends `estop` now and then.
const POLLER_LINES_PER_S: u32 = 200;
/// The nice value a poller's thread gets (0 is a normal thread's; the timing pool's is 10).
const POLLER_NICE: i32 = 5;

/// The shortest read timeout a connection waits with (a deadline closer than this is
/// waited for this long).
const READ_TIMEOUT_FLOOR: Duration = Duration::from_millis(5);

/// Counts a connection's lines per second and lowers its thread's priority, once, when it
/// polls faster than [`POLLER_LINES_PER_S`].
#[derive(Default)]
struct Pace {
    since: Option<Instant>,
    lines: u32,
    lowered: bool,
}

impl Pace {
    fn line(&mut self, now: Instant) {
        if self.lowered {
            return;
        }
        let since = *self.since.get_or_insert(now);
        if now.duration_since(since) >= Duration::from_secs(1) {
            self.since = Some(now);
            self.lines = 0;
        }
        self.lines += 1;
        if self.lines > POLLER_LINES_PER_S {
            crate::pool::lower_priority(POLLER_NICE);
            self.lowered = true;
        }
    }
}

/// A client's place in the count; given back when its thread ends.
struct Slot(Arc<AtomicUsize>);

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Sends one `error:17` line without waiting on the client, and closes.
fn refuse(stream: TcpStream, why: &str) {
    let _ = stream.set_nonblocking(true);
    let mut s = &stream;
    let _ = send(&mut s, &Reply::err(CtlError::Connection(why.into())));
    let _ = stream.shutdown(std::net::Shutdown::Both);
}

/// One TCP client: authentication first if a token is set, then one reply per complete
/// line, until it closes, idles out or dribbles a line for too long.
fn serve_client(ctl: &Controller, stream: &TcpStream, opts: &TcpOptions) -> std::io::Result<()> {
    let lim = &opts.limits;
    stream.set_write_timeout(Some(lim.idle_timeout.min(Duration::from_secs(30))))?;
    let mut out = stream;
    let mut input = BufReader::with_capacity(MAX_LINE, stream);
    let mut lines = LineReader::new();
    let mut authed = opts.token.is_none();
    let mut last_line = Instant::now();
    let mut pace = Pace::default();
    let mut read_timeout = None;
    let mut text = String::new();
    // right after a line, the clock read when it came serves as now (the answer's
    // microseconds only make the timeout a little long, far under its 5 ms floor)
    let mut answered = false;
    loop {
        let partial = lines.partial_since();
        let deadline = match partial {
            Some(t) => t + lim.line_timeout,
            None => last_line + lim.idle_timeout,
        };
        let now = match (answered, partial) {
            (true, None) => last_line,
            _ => Instant::now(),
        };
        answered = false;
        let left = deadline.saturating_duration_since(now);
        if left.is_zero() {
            let why = match partial {
                Some(_) => format!(
                    "line not completed within {} s; closing",
                    lim.line_timeout.as_secs()
                ),
                None => format!("idle for {} s; closing", lim.idle_timeout.as_secs()),
            };
            return send(&mut out, &Reply::err(CtlError::Connection(why)));
        }
        // A read that times out early only goes round again; one that could wait past
        // the deadline by more than the 5 ms floor must not. Setting the timeout is a
        // system call, so a client sending line after line keeps the one already set.
        let want = left.max(READ_TIMEOUT_FLOOR);
        if read_timeout.is_none_or(|t: Duration| t > want + READ_TIMEOUT_FLOOR || t < want / 2) {
            stream.set_read_timeout(Some(want))?;
            read_timeout = Some(want);
        }
        let line = match lines.read(&mut input) {
            Ok(Line::Eof) => return Ok(()),
            Ok(l) => l,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => continue,
            Err(e) => return Err(e),
        };
        last_line = Instant::now();
        pace.line(last_line);
        let token = match &line {
            Line::Text(b) => auth_token(b),
            _ => None,
        };
        match (token, &opts.token) {
            (Some(got), Some(want)) => {
                if !same_token(got, want) {
                    let r = Reply::err(CtlError::Unauthorized("wrong token; closing".into()));
                    return send(&mut out, &r);
                }
                authed = true;
                text.clear();
                Reply::ok(Vec::new()).write_text(&mut text);
            }
            (None, Some(_)) if !authed => {
                let r = Reply::err(CtlError::Unauthorized(
                    "authentication required: the first line must be 'auth TOKEN'; closing".into(),
                ));
                return send(&mut out, &r);
            }
            _ => answer(ctl, line, &mut text),
        }
        out.write_all(text.as_bytes())?;
        answered = true;
    }
}

/// At most one line per `every`; the lines held back are counted in the next one.
struct RateLimitedLog {
    every: Duration,
    last: Option<Instant>,
    held: u64,
}

impl RateLimitedLog {
    fn new(every: Duration) -> Self {
        RateLimitedLog {
            every,
            last: None,
            held: 0,
        }
    }

    fn log(&mut self, msg: &str) {
        let now = Instant::now();
        if self
            .last
            .is_some_and(|t| now.duration_since(t) < self.every)
        {
            self.held += 1;
            return;
        }
        if self.held > 0 {
            eprintln!("{msg} (and {} more like it)", self.held);
        } else {
            eprintln!("{msg}");
        }
        self.last = Some(now);
        self.held = 0;
    }
}

/// Serves the protocol on a serial device (115200 8N1) with the default line timeout.
pub fn serve_serial(ctl: Arc<Controller>, device: &str) -> Result<(), CtlError> {
    serve_serial_with(ctl, device, Limits::default().line_timeout)
}

/// Opens a serial device for [`serve_serial_port`] (115200 8N1).
pub fn open_serial(device: &str) -> Result<Box<dyn serialport::SerialPort>, CtlError> {
    serialport::new(device, 115_200)
        .timeout(Duration::from_millis(200))
        .open()
        .map_err(|e| CtlError::Io(format!("cannot open serial device {device}: {e}")))
}

/// Serves a serial device until it fails to open the first time. When the line hangs up
/// (the other side closed, the device went away) the partial line is dropped and the device
/// is opened again by name, as a board waits on an unplugged cable.
pub fn serve_serial_with(
    ctl: Arc<Controller>,
    device: &str,
    line_timeout: Duration,
) -> Result<(), CtlError> {
    let port = open_serial(device)?;
    serve_serial_port(ctl, device, port, line_timeout)
}

/// [`serve_serial_with`] on a device already opened ([`open_serial`]): a caller that opens
/// it before it announces itself loses no byte sent after the announcement (opening a
/// device drops what it has buffered).
pub fn serve_serial_port(
    ctl: Arc<Controller>,
    device: &str,
    mut port: Box<dyn serialport::SerialPort>,
    line_timeout: Duration,
) -> ! {
    let mut log = RateLimitedLog::new(Duration::from_secs(10));
    loop {
        match serial_session(&ctl, port, line_timeout) {
            Ok(()) => log.log(&format!("serial {device}: hung up; opening it again")),
            Err(e) => log.log(&format!("serial {device}: {e}; opening it again")),
        }
        port = loop {
            std::thread::sleep(Duration::from_millis(100));
            if let Ok(p) = open_serial(device) {
                break p;
            }
        };
    }
}

/// Reads as a plain stream: a hang-up (EIO, as a pseudo-terminal whose other side closed
/// reads) is the end of input.
struct SerialIn(Box<dyn serialport::SerialPort>);

impl Read for SerialIn {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        match self.0.read(buf) {
            Err(e) if e.raw_os_error() == Some(5) || e.kind() == ErrorKind::BrokenPipe => Ok(0),
            other => other,
        }
    }
}

/// One open period of the serial device; ends (Ok) on hang-up.
fn serial_session(
    ctl: &Controller,
    port: Box<dyn serialport::SerialPort>,
    line_timeout: Duration,
) -> std::io::Result<()> {
    let mut out = port.try_clone()?;
    let mut input = BufReader::with_capacity(MAX_LINE, SerialIn(port));
    let mut lines = LineReader::new();
    let mut text = String::new();
    loop {
        let line = match lines.read(&mut input) {
            Ok(Line::Eof) => return Ok(()),
            Ok(l) => l,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                // A host that went away mid-line and came back must not complete it.
                if lines
                    .partial_last_byte()
                    .is_some_and(|t| t.elapsed() >= line_timeout)
                {
                    lines.discard();
                }
                continue;
            }
            Err(e) => return Err(e),
        };
        answer(ctl, line, &mut text);
        match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
            Err(e) if e.raw_os_error() == Some(5) => return Ok(()),
            other => other?,
        }
    }
}

/// Binds the listener (port 0 picks a free port; the bound address is returned).
pub fn bind(addr: &str) -> Result<TcpListener, CtlError> {
    TcpListener::bind(addr).map_err(|e| CtlError::Io(format!("cannot listen on {addr}: {e}")))
}

/// Connects to a board over TCP (used by the host client and tests).
pub fn connect(addr: &str) -> std::io::Result<TcpStream> {
    let s = TcpStream::connect(addr)?;
    s.set_nodelay(true)?;
    Ok(s)
}

/// Checks a TCP listen address and token by the shared rule (loopback unless
/// `allow_remote` with a token); the error names the `serve` flags.
pub fn check_listen(addr: &str, allow_remote: bool, token: Option<&str>) -> Result<(), CtlError> {
    use crate::access::{check, Refusal, MIN_TOKEN_LEN};
    check(addr, allow_remote, token).map(|_| ()).map_err(|r| {
        CtlError::Setting(match r {
            Refusal::RemoteNotAllowed => format!(
                "{addr} is not a loopback address; serving the line protocol to other machines needs --listen-allow-remote and --listen-token"
            ),
            Refusal::TokenRequired => format!(
                "--listen-allow-remote needs an access token (--listen-token, at least {MIN_TOKEN_LEN} characters)"
            ),
            Refusal::BadToken => format!(
                "the access token must be {MIN_TOKEN_LEN} to 256 printable ASCII characters without spaces"
            ),
            Refusal::Unresolved(e) => format!("cannot listen on {addr}: {e}"),
        })
    })
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    /// This thread's nice value.
    fn nice() -> i32 {
        // SAFETY: reads this thread's own nice value.
        unsafe { libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t) }
    }

    #[test]
    fn a_client_polling_without_pause_is_served_at_the_lower_priority() {
        let t0 = Instant::now();
        let polled = std::thread::spawn(move || {
            let mut p = Pace::default();
            let start = nice();
            // a line every 10 ms: 100 a second, for 3 s
            for i in 0..300 {
                p.line(t0 + Duration::from_millis(10 * i));
            }
            let slow = nice();
            for i in 0..=POLLER_LINES_PER_S {
                p.line(t0 + Duration::from_secs(3) + Duration::from_micros(u64::from(i)));
            }
            (start, slow - start, nice() - start)
        })
        .join()
        .unwrap();
        let (start, slow, fast) = polled;
        assert_eq!(
            slow, 0,
            "a client polling 100 times a second keeps its priority"
        );
        if start < POLLER_NICE {
            assert_eq!(start + fast, POLLER_NICE, "a poller's thread is lowered");
        } else {
            assert_eq!(fast, 0, "a thread already lower is never raised");
        }
    }
}
