//! The HTTP/1.1 server of the web page and of the Alpaca devices: our own accept loop on a
//! `std::net::TcpListener`, one thread per connection up to a cap, and a deadline on every
//! request. (tiny_http 0.12 ends its accept thread for good on the first accept error,
//! EMFILE included, and starts a thread for every connection without a bound; it has no
//! way to be handed accepted connections.)
//!
//! The cap is the line port's: `Limits` (`max_clients`, an idle timeout between requests
//! and a timeout for one request), with the same range. A connection over the cap is
//! answered 503 and closed; an accept error is logged and retried after a pause.

use multistep_controller::service::Limits;
use std::io::{self, BufRead, BufReader, ErrorKind, Read, Write};
use std::net::{Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

pub use multistep_controller::service::MAX_CLIENTS_RANGE;

/// Most connections at once unless told (the line port's default).
pub const DEFAULT_MAX_CLIENTS: usize = 64;
/// A keep-alive connection with no new request for this long is closed (a new
/// connection waits `REQUEST_TIMEOUT` for its first byte).
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(30);
/// A request's head and body must arrive within this from its first byte.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(10);
/// A client that takes no reply bytes for this long is dropped.
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(10);
/// Largest request line and headers together.
pub const MAX_HEAD: usize = 8 * 1024;
/// Largest request body (a protocol line is at most 4 KiB).
pub const MAX_BODY: usize = 16 * 1024;
/// Pause after an accept error: out of descriptors, accept fails again at once.
const ACCEPT_BACKOFF: Duration = Duration::from_millis(50);
/// At most one accept error line per this long.
const LOG_EVERY: Duration = Duration::from_secs(10);

/// The connection limits with `max_clients`, checked against the line port's range.
pub fn limits(max_clients: usize) -> Result<Limits, String> {
    let (lo, hi) = MAX_CLIENTS_RANGE;
    if !(lo..=hi).contains(&max_clients) {
        return Err(format!("must be in [{lo}, {hi}] (got {max_clients})"));
    }
    Ok(Limits {
        max_clients,
        idle_timeout: IDLE_TIMEOUT,
        line_timeout: REQUEST_TIMEOUT,
    })
}

/// One request, its body read in full.
pub struct Request {
    method: String,
    url: String,
    headers: Vec<(String, String)>,
    peer: SocketAddr,
    body: Vec<u8>,
    http10: bool,
}

impl Request {
    pub fn method(&self) -> &str {
        &self.method
    }
    /// The request target as sent (path and query).
    pub fn url(&self) -> &str {
        &self.url
    }
    /// The first header of that name (names are case-insensitive).
    pub fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(k, _)| k.eq_ignore_ascii_case(name))
            .map(|(_, v)| v.as_str())
    }
    pub fn peer(&self) -> SocketAddr {
        self.peer
    }
    pub fn body(&self) -> &[u8] {
        &self.body
    }
    fn wants_close(&self) -> bool {
        self.http10
            || self
                .header("Connection")
                .is_some_and(|v| v.split(',').any(|t| t.trim().eq_ignore_ascii_case("close")))
    }
}

/// Writes an endless body (server-sent events) until it fails or has nothing more to say.
pub type StreamBody = Box<dyn FnOnce(&mut dyn Write) -> io::Result<()> + Send>;

enum Body {
    Bytes(Vec<u8>),
    Stream(StreamBody),
}

/// A reply: status, headers and a body of known length, or a stream that ends the
/// connection.
pub struct Response {
    status: u16,
    headers: Vec<(String, String)>,
    body: Body,
}

impl Response {
    pub fn new(status: u16, content_type: &str, body: impl Into<Vec<u8>>) -> Response {
        Response {
            status,
            headers: vec![("Content-Type".into(), content_type.into())],
            body: Body::Bytes(body.into()),
        }
    }

    /// `text/plain` in UTF-8.
    pub fn text(status: u16, msg: &str) -> Response {
        Response::new(status, "text/plain; charset=utf-8", msg)
    }

    /// A 200 whose body `write` produces for as long as it likes.
    pub fn stream(content_type: &str, write: StreamBody) -> Response {
        Response {
            status: 200,
            headers: vec![("Content-Type".into(), content_type.into())],
            body: Body::Stream(write),
        }
    }

    pub fn with_header(mut self, name: &str, value: &str) -> Response {
        self.headers.push((name.into(), value.into()));
        self
    }

    pub fn status(&self) -> u16 {
        self.status
    }

    /// Sends the reply; false when the connection must close after it.
    fn send(self, out: &mut impl Write, close: bool) -> io::Result<bool> {
        let mut head = format!("HTTP/1.1 {} {}\r\n", self.status, reason(self.status));
        for (k, v) in &self.headers {
            head.push_str(&format!("{k}: {v}\r\n"));
        }
        match self.body {
            Body::Bytes(b) => {
                head.push_str(&format!("Content-Length: {}\r\n", b.len()));
                if close {
                    head.push_str("Connection: close\r\n");
                }
                head.push_str("\r\n");
                let mut all = head.into_bytes();
                all.extend_from_slice(&b);
                out.write_all(&all)?;
                out.flush()?;
                Ok(!close)
            }
            Body::Stream(write) => {
                head.push_str("Connection: close\r\n\r\n");
                out.write_all(head.as_bytes())?;
                write(out)?;
                Ok(false)
            }
        }
    }
}

fn reason(status: u16) -> &'static str {
    match status {
        100 => "Continue",
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        413 => "Content Too Large",
        415 => "Unsupported Media Type",
        431 => "Request Header Fields Too Large",
        500 => "Internal Server Error",
        501 => "Not Implemented",
        503 => "Service Unavailable",
        505 => "HTTP Version Not Supported",
        _ => "",
    }
}

/// What serves each request.
pub type Handler = Arc<dyn Fn(Request) -> Response + Send + Sync>;

/// A listening server; stops accepting when dropped (open connections finish).
pub struct Server {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Server {
    /// Binds `addr` and serves on a thread named `name`.
    pub fn start(addr: &str, limits: Limits, name: &str, handler: Handler) -> io::Result<Server> {
        let listener = TcpListener::bind(addr)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = stop.clone();
            let name = name.to_string();
            std::thread::Builder::new()
                .name(name.clone())
                .spawn(move || accept_loop(&listener, &limits, &name, &handler, &stop))?
        };
        Ok(Server {
            addr,
            stop,
            thread: Some(thread),
        })
    }

    /// The address actually bound (port 0 picks a free port).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Serves until the process ends.
    pub fn join(mut self) {
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wake the blocked accept; on an unspecified address, through loopback.
        let mut to = self.addr;
        if to.ip().is_unspecified() {
            to.set_ip(match to {
                SocketAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
                SocketAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
            });
        }
        let _ = TcpStream::connect_timeout(&to, Duration::from_secs(1));
    }
}

fn accept_loop(
    listener: &TcpListener,
    limits: &Limits,
    name: &str,
    handler: &Handler,
    stop: &AtomicBool,
) {
    let open = Arc::new(AtomicUsize::new(0));
    let mut log = ErrorLog::default();
    loop {
        let accepted = listener.accept();
        if stop.load(Ordering::SeqCst) {
            return;
        }
        let (stream, peer) = match accepted {
            Ok(s) => s,
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::Interrupted | ErrorKind::ConnectionAborted
                ) =>
            {
                continue
            }
            Err(e) => {
                log.log(&format!("{name}: accept: {e}"));
                std::thread::sleep(ACCEPT_BACKOFF);
                continue;
            }
        };
        if open.fetch_add(1, Ordering::SeqCst) >= limits.max_clients {
            open.fetch_sub(1, Ordering::SeqCst);
            refuse(&stream, limits.max_clients);
            continue;
        }
        let slot = Slot(open.clone());
        let (limits, handler) = (limits.clone(), handler.clone());
        let spawned = std::thread::Builder::new()
            .name(format!("{name}-conn"))
            .spawn(move || {
                let _slot = slot;
                serve_connection(&stream, peer, &limits, &*handler);
            });
        if let Err(e) = spawned {
            log.log(&format!("{name}: cannot start a connection thread: {e}"));
        }
    }
}

/// A connection's place in the count, given back when its thread ends.
struct Slot(Arc<AtomicUsize>);

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Answers 503 without waiting on the client, and closes.
fn refuse(stream: &TcpStream, max: usize) {
    let _ = stream.set_nonblocking(true);
    let msg = format!("too many connections (at most {max}); try again later");
    let _ = Response::text(503, &msg)
        .with_header("Retry-After", "1")
        .send(&mut &*stream, true);
    let _ = stream.shutdown(Shutdown::Both);
}

/// Accept errors on stderr, at most one line per `LOG_EVERY`; the ones held back are
/// counted in the next.
#[derive(Default)]
struct ErrorLog {
    last: Option<Instant>,
    held: u64,
}

impl ErrorLog {
    fn log(&mut self, msg: &str) {
        if self.last.is_some_and(|t| t.elapsed() < LOG_EVERY) {
            self.held += 1;
            return;
        }
        // Not eprintln!: it panics when stderr is gone, and this is the accept thread.
        let mut err = io::stderr().lock();
        let _ = match std::mem::take(&mut self.held) {
            0 => writeln!(err, "{msg}"),
            n => writeln!(err, "{msg} (and {n} more like it)"),
        };
        self.last = Some(Instant::now());
    }
}

/// Reads with the time left before `deadline` as the socket's timeout.
struct Timed<'s> {
    stream: &'s TcpStream,
    deadline: Instant,
}

impl Read for Timed<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let left = self.deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(ErrorKind::TimedOut.into());
        }
        self.stream.set_read_timeout(Some(left))?;
        self.stream.read(buf)
    }
}

/// Requests on one connection, one after another, until it closes, idles out or errs.
fn serve_connection(
    stream: &TcpStream,
    peer: SocketAddr,
    limits: &Limits,
    handler: &dyn Fn(Request) -> Response,
) {
    let _ = stream.set_nodelay(true);
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let mut input = BufReader::with_capacity(
        MAX_HEAD,
        Timed {
            stream,
            deadline: Instant::now() + limits.idle_timeout,
        },
    );
    let mut out = stream;
    // A connection that never sends a byte holds its slot no longer than a slow request.
    let mut wait = limits.line_timeout;
    loop {
        input.get_mut().deadline = Instant::now() + wait;
        wait = limits.idle_timeout;
        match input.fill_buf() {
            Ok([]) | Err(_) => return,
            Ok(_) => {}
        }
        input.get_mut().deadline = Instant::now() + limits.line_timeout;
        let req = match read_request(&mut input, &mut out, peer) {
            Ok(r) => r,
            Err(Refused::Gone) => return,
            Err(Refused::Status(code, why)) => {
                let _ = Response::text(code, why).send(&mut out, true);
                return;
            }
        };
        let close = req.wants_close();
        match handler(req).send(&mut out, close) {
            Ok(true) => {}
            _ => return,
        }
    }
}

/// Why a request gets no handler: an answer to send before closing, or none.
#[derive(Debug, PartialEq)]
enum Refused {
    Status(u16, &'static str),
    Gone,
}

fn io_refused(e: io::Error) -> Refused {
    match e.kind() {
        ErrorKind::TimedOut | ErrorKind::WouldBlock => {
            Refused::Status(408, "request not completed in time")
        }
        _ => Refused::Gone,
    }
}

/// One line ending in LF (CR LF or LF), at most `budget` bytes with its end.
fn read_line(
    input: &mut impl BufRead,
    budget: &mut usize,
    too_long: Refused,
) -> Result<String, Refused> {
    let mut line = Vec::new();
    let n = input
        .take(*budget as u64)
        .read_until(b'\n', &mut line)
        .map_err(io_refused)?;
    if n == 0 {
        return Err(Refused::Gone);
    }
    if line.last() != Some(&b'\n') {
        return Err(if n < *budget { Refused::Gone } else { too_long });
    }
    *budget -= n;
    line.pop();
    if line.last() == Some(&b'\r') {
        line.pop();
    }
    String::from_utf8(line).map_err(|_| Refused::Status(400, "request head is not UTF-8"))
}

fn is_token(s: &str) -> bool {
    !s.is_empty()
        && s.bytes()
            .all(|b| b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b))
}

const BAD: Refused = Refused::Status(400, "malformed request");

fn read_request(
    input: &mut impl BufRead,
    out: &mut impl Write,
    peer: SocketAddr,
) -> Result<Request, Refused> {
    let mut budget = MAX_HEAD;
    let head_too_long = || Refused::Status(431, "request head too long");
    let first = read_line(input, &mut budget, head_too_long())?;
    let mut parts = first.split(' ');
    let (Some(method), Some(url), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(BAD);
    };
    let http10 = match version {
        "HTTP/1.1" => false,
        "HTTP/1.0" => true,
        _ => return Err(Refused::Status(505, "HTTP/1.1 only")),
    };
    if !is_token(method) || url.is_empty() {
        return Err(BAD);
    }
    let mut headers = Vec::new();
    loop {
        let line = read_line(input, &mut budget, head_too_long())?;
        if line.is_empty() {
            break;
        }
        let (k, v) = line.split_once(':').ok_or(BAD)?;
        // No space before the colon, no folded lines (RFC 9112 §5).
        if !is_token(k) {
            return Err(BAD);
        }
        headers.push((k.to_string(), v.trim().to_string()));
    }
    let mut req = Request {
        method: method.to_string(),
        url: url.to_string(),
        headers,
        peer,
        body: Vec::new(),
        http10,
    };
    req.body = read_body(&req, input, out)?;
    Ok(req)
}

fn read_body(
    req: &Request,
    input: &mut impl BufRead,
    out: &mut impl Write,
) -> Result<Vec<u8>, Refused> {
    let too_large = Refused::Status(413, "request body too long");
    let chunked = match req.header("Transfer-Encoding") {
        None => false,
        Some(te) if te.eq_ignore_ascii_case("chunked") => true,
        Some(_) => {
            return Err(Refused::Status(
                501,
                "only chunked transfer coding is understood",
            ))
        }
    };
    let lengths: Vec<&str> = req
        .headers
        .iter()
        .filter(|(k, _)| k.eq_ignore_ascii_case("Content-Length"))
        .map(|(_, v)| v.as_str())
        .collect();
    let length = match (chunked, lengths.as_slice()) {
        (_, []) => None,
        (false, [n, rest @ ..]) if rest.iter().all(|m| m == n) => {
            if !n.bytes().all(|b| b.is_ascii_digit()) {
                return Err(BAD);
            }
            Some(
                n.parse::<usize>()
                    .map_err(|_| Refused::Status(413, "request body too long"))?,
            )
        }
        _ => return Err(BAD),
    };
    if length.is_some_and(|n| n > MAX_BODY) {
        return Err(too_large);
    }
    let expects = req
        .header("Expect")
        .is_some_and(|v| v.eq_ignore_ascii_case("100-continue"));
    if expects && (chunked || length.is_some_and(|n| n > 0)) {
        out.write_all(b"HTTP/1.1 100 Continue\r\n\r\n")
            .and_then(|()| out.flush())
            .map_err(|_| Refused::Gone)?;
    }
    let mut body = Vec::new();
    if let Some(n) = length {
        body.resize(n, 0);
        input.read_exact(&mut body).map_err(io_refused)?;
    } else if chunked {
        let mut budget = MAX_HEAD;
        loop {
            let line = read_line(input, &mut budget, BAD)?;
            let size = line.split(';').next().unwrap_or("").trim();
            let size = usize::from_str_radix(size, 16).map_err(|_| BAD)?;
            if size == 0 {
                // Trailers, up to the empty line.
                while !read_line(input, &mut budget, BAD)?.is_empty() {}
                break;
            }
            if body.len() + size > MAX_BODY {
                return Err(too_large);
            }
            let at = body.len();
            body.resize(at + size, 0);
            input.read_exact(&mut body[at..]).map_err(io_refused)?;
            if !read_line(input, &mut budget, BAD)?.is_empty() {
                return Err(BAD);
            }
        }
    }
    Ok(body)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(raw: &[u8]) -> (Result<Request, Refused>, Vec<u8>) {
        let mut out = Vec::new();
        let peer: SocketAddr = "127.0.0.1:9".parse().unwrap();
        let r = read_request(&mut &raw[..], &mut out, peer);
        (r, out)
    }

    #[test]
    fn requests_are_read_with_their_bodies() {
        let (r, _) = parse(b"PUT /a?b=1 HTTP/1.1\r\nHost: x\r\ncontent-length: 3\r\n\r\nabcdef");
        let r = r.unwrap();
        assert_eq!(
            (r.method(), r.url(), r.body()),
            ("PUT", "/a?b=1", &b"abc"[..])
        );
        assert_eq!(r.header("HOST"), Some("x"));
        assert!(!r.wants_close());
        let (r, _) = parse(b"GET / HTTP/1.0\nHost: x\n\n");
        assert!(r.unwrap().wants_close());
        let (r, out) = parse(
            b"POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\nExpect: 100-continue\r\n\r\n\
              3;x=y\r\nabc\r\n2\r\nde\r\n0\r\nT: 1\r\n\r\n",
        );
        assert_eq!(r.unwrap().body(), b"abcde");
        assert_eq!(out, b"HTTP/1.1 100 Continue\r\n\r\n");
    }

    #[test]
    fn malformed_or_oversized_requests_are_refused() {
        let code = |raw: &[u8]| match parse(raw).0 {
            Ok(_) => 0,
            Err(Refused::Status(c, _)) => c,
            Err(Refused::Gone) => 1,
        };
        assert_eq!(code(b"GET /\r\n\r\n"), 400);
        assert_eq!(code(b"GET / HTTP/2\r\n\r\n"), 505);
        assert_eq!(code(b"G(T / HTTP/1.1\r\n\r\n"), 400);
        assert_eq!(code(b"GET / HTTP/1.1\r\nHost x\r\n\r\n"), 400);
        assert_eq!(code(b"GET / HTTP/1.1\r\nHost : x\r\n\r\n"), 400);
        assert_eq!(code(b"GET / HTTP/1.1\r\n folded\r\n\r\n"), 400);
        assert_eq!(
            code(b"PUT / HTTP/1.1\r\nContent-Length: 99999\r\n\r\n"),
            413
        );
        assert_eq!(
            code(b"PUT / HTTP/1.1\r\nContent-Length: 99999999999999999999999\r\n\r\n"),
            413
        );
        assert_eq!(code(b"PUT / HTTP/1.1\r\nContent-Length: -1\r\n\r\n"), 400);
        assert_eq!(
            code(b"PUT / HTTP/1.1\r\nContent-Length: 1\r\nContent-Length: 2\r\n\r\n"),
            400
        );
        assert_eq!(
            code(b"PUT / HTTP/1.1\r\nTransfer-Encoding: gzip\r\n\r\n"),
            501
        );
        assert_eq!(
            code(b"PUT / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n"),
            400
        );
        assert_eq!(
            code(b"PUT / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\nffffffff\r\n"),
            413
        );
        assert_eq!(
            code(b"PUT / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\nfffffffffffffffffffff\r\n"),
            400
        );
        let mut long = b"GET / HTTP/1.1\r\nX: ".to_vec();
        long.resize(MAX_HEAD + 10, b'a');
        assert_eq!(code(&long), 431);
        assert_eq!(code(b"GET / HTTP/1.1\r\nHost: x\r\n"), 1);
        assert_eq!(code(b"PUT / HTTP/1.1\r\nContent-Length: 5\r\n\r\nab"), 1);
        assert_eq!(code(b""), 1);
        assert_eq!(code(&[0xff, b'\n']), 400);
    }

    #[test]
    fn the_connection_cap_has_the_line_ports_range() {
        assert!(limits(0).is_err() && limits(1025).is_err());
        assert_eq!(limits(64).unwrap().max_clients, 64);
    }

    fn get(addr: SocketAddr) -> String {
        let mut s = TcpStream::connect(addr).unwrap();
        s.write_all(b"GET / HTTP/1.1\r\nConnection: close\r\n\r\n")
            .unwrap();
        let mut out = String::new();
        let _ = s.read_to_string(&mut out);
        out
    }

    #[test]
    fn over_the_cap_a_connection_gets_503_and_keep_alive_serves_several_requests() {
        let handler: Handler =
            Arc::new(|r: Request| Response::text(200, &format!("{}\n", r.url())));
        let server = Server::start("127.0.0.1:0", limits(1).unwrap(), "t", handler).unwrap();
        let mut held = TcpStream::connect(server.addr()).unwrap();
        held.write_all(b"GET /one HTTP/1.1\r\n\r\nGET /two HTTP/1.1\r\n\r\n")
            .unwrap();
        let mut r = BufReader::new(held.try_clone().unwrap());
        let mut seen = String::new();
        while !seen.ends_with("/two\n") {
            let mut l = String::new();
            assert!(r.read_line(&mut l).unwrap() > 0, "{seen}");
            seen.push_str(&l);
        }
        assert!(
            seen.contains("/one") && seen.starts_with("HTTP/1.1 200 OK"),
            "{seen}"
        );
        assert!(get(server.addr()).starts_with("HTTP/1.1 503"));
        drop((held, r));
        let t0 = Instant::now();
        while !get(server.addr()).starts_with("HTTP/1.1 200") {
            assert!(
                t0.elapsed() < Duration::from_secs(30),
                "the slot never came back"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}
