//! `multistep serve` with the web page and Alpaca open, under pressure: more connections
//! than the process has file descriptors, and event streams from many loopback addresses.
//! Every wait is a poll with a generous deadline, so a slow machine only takes longer.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::os::fd::FromRawFd;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");
const DEADLINE: Duration = Duration::from_secs(60);

const CONFIG: &str = r#"
[board]
name = "optics"
[[axis]]
name = "F"
soft_min = 0
soft_max = 20000
[[alpaca.focuser]]
axis = "F"
name = "Focus"
"#;

/// The running service, its addresses, and everything it says on stderr.
struct Service {
    child: Child,
    tcp: String,
    web: String,
    alpaca: String,
    stderr: Arc<Mutex<String>>,
}

impl Service {
    /// `serve` with --http and --alpaca, its open files limited to `nofile` when given.
    fn start(dir: &Path, nofile: Option<u32>, extra: &[&str]) -> Service {
        let cfg = dir.join("board.toml");
        std::fs::write(&cfg, CONFIG).unwrap();
        let mut cmd = match nofile {
            Some(n) => {
                let mut c = Command::new("sh");
                c.args(["-c", &format!("ulimit -n {n} && exec \"$0\" \"$@\""), BIN]);
                c
            }
            None => Command::new(BIN),
        };
        let mut child = cmd
            .args(["serve", "--listen", "127.0.0.1:0", "--data"])
            .arg(dir.join("d"))
            .arg("--board-config")
            .arg(&cfg)
            .args(["--http", "127.0.0.1:0", "--alpaca", "127.0.0.1:0"])
            .arg("--alpaca-no-discovery")
            .args(extra)
            .env_remove("MULTISTEP_HTTP_TOKEN")
            .env_remove("MULTISTEP_ALPACA_TOKEN")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut err = BufReader::new(child.stderr.take().unwrap());
        let (mut web, mut alpaca) = (String::new(), String::new());
        while web.is_empty() || alpaca.is_empty() {
            let mut line = String::new();
            assert!(err.read_line(&mut line).unwrap() > 0, "serve ended early");
            if let Some(a) = line.trim().strip_prefix("web page on http://") {
                web = a.trim_end_matches('/').to_string();
            } else if let Some(a) = line.trim().strip_prefix("alpaca devices on http://") {
                alpaca = a.trim_end_matches('/').to_string();
            }
        }
        // Read stderr to its end, so logging never blocks on a full pipe.
        let stderr = Arc::new(Mutex::new(String::new()));
        let keep = stderr.clone();
        std::thread::spawn(move || {
            for line in err.lines() {
                let Ok(line) = line else { break };
                let mut s = keep.lock().unwrap();
                s.push_str(&line);
                s.push('\n');
            }
        });
        let mut first = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut first)
            .unwrap();
        let tcp = first.trim().rsplit("tcp://").next().unwrap().to_string();
        Service {
            child,
            tcp,
            web,
            alpaca,
            stderr,
        }
    }

    fn alive(&mut self) -> bool {
        self.child.try_wait().unwrap().is_none()
    }

    fn said(&self) -> String {
        self.stderr.lock().unwrap().clone()
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One GET with `Connection: close`: the status, or why there is none.
fn get(addr: &str, path: &str) -> Result<u16, String> {
    let mut s = TcpStream::connect(addr).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .map_err(|e| e.to_string())?;
    let mut out = String::new();
    s.read_to_string(&mut out).map_err(|e| e.to_string())?;
    out.get(9..12)
        .and_then(|c| c.parse().ok())
        .ok_or_else(|| format!("no status line: {out:?}"))
}

/// One protocol line on the line port: the last line of its reply (`ok` or `error:…`).
fn line(addr: &str, text: &str) -> Result<String, String> {
    let mut s = TcpStream::connect(addr).map_err(|e| e.to_string())?;
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    writeln!(s, "{text}").map_err(|e| e.to_string())?;
    for l in BufReader::new(s).lines() {
        let l = l.map_err(|e| e.to_string())?;
        if l.starts_with("ok") || l.starts_with("error") {
            return Ok(l);
        }
    }
    Err("no reply".into())
}

/// Polls `f` until it returns true; false after the deadline.
fn eventually(mut f: impl FnMut() -> bool) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < DEADLINE {
        if f() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    false
}

#[test]
fn running_out_of_file_descriptors_stops_no_port_for_good() {
    let tmp = tempfile::tempdir().unwrap();
    let mut svc = Service::start(tmp.path(), Some(64), &[]);
    // Clients that connect and send half a request, more than the process has files.
    let mut held = Vec::new();
    for addr in [&svc.web, &svc.alpaca, &svc.web, &svc.alpaca] {
        let sa: SocketAddr = addr.parse().unwrap();
        for _ in 0..60 {
            // A full backlog or a closed port: enough for this round.
            let Ok(mut s) = TcpStream::connect_timeout(&sa, Duration::from_secs(2)) else {
                break;
            };
            let _ = s.write_all(b"GET / HTTP/1.1\r\n");
            held.push(s);
        }
    }
    assert!(held.len() > 64, "only {} connections opened", held.len());
    // Checked once the ports are back: that is the point, the log line only a witness.
    let said = eventually(|| svc.said().contains("accept: Too many open files"));
    drop(held);
    let (mut page, mut alpaca, mut tcp) = (false, false, false);
    eventually(|| {
        page = page || get(&svc.web, "/") == Ok(200);
        alpaca = alpaca || get(&svc.alpaca, "/management/apiversions") == Ok(200);
        tcp = tcp || line(&svc.tcp, "info").is_ok_and(|r| r.starts_with("ok"));
        page && alpaca && tcp
    });
    assert!(
        page && alpaca && tcp,
        "web {page}, alpaca {alpaca}, line port {tcp} after the clients left: {:?} {:?}; stderr:\n{}",
        get(&svc.web, "/"),
        get(&svc.alpaca, "/management/apiversions"),
        svc.said()
    );
    assert!(svc.alive(), "serve died; stderr:\n{}", svc.said());
    assert!(said, "no accept error logged; stderr:\n{}", svc.said());
}

#[test]
fn a_connection_over_the_cap_is_answered_503_and_the_rest_go_on() {
    let tmp = tempfile::tempdir().unwrap();
    let svc = Service::start(
        tmp.path(),
        None,
        &["--http-max-clients", "4", "--alpaca-max-clients", "4"],
    );
    for addr in [&svc.web, &svc.alpaca] {
        let held: Vec<TcpStream> = (0..4).map(|_| TcpStream::connect(addr).unwrap()).collect();
        // The four are accepted in order; the fifth finds every slot taken.
        let full = eventually(|| get(addr, "/") == Ok(503));
        assert!(full, "{addr}: {:?}", get(addr, "/"));
        drop(held);
        let back = eventually(|| matches!(get(addr, "/"), Ok(200 | 404)));
        assert!(back, "{addr}: {:?}", get(addr, "/"));
    }
}

/// A TCP connection to `to` from the local address `from` (any port).
fn connect_from(from: [u8; 4], to: SocketAddr) -> TcpStream {
    let SocketAddr::V4(to) = to else {
        panic!("{to} is not IPv4")
    };
    let sin = |ip: [u8; 4], port: u16| libc::sockaddr_in {
        sin_family: libc::AF_INET as libc::sa_family_t,
        sin_port: port.to_be(),
        sin_addr: libc::in_addr {
            s_addr: u32::from_ne_bytes(ip),
        },
        sin_zero: [0; 8],
    };
    let len = std::mem::size_of::<libc::sockaddr_in>() as libc::socklen_t;
    // SAFETY: a fresh socket, owned by the TcpStream on success, closed on failure; the
    // addresses are valid sockaddr_in values of the length given.
    unsafe {
        let fd = libc::socket(libc::AF_INET, libc::SOCK_STREAM | libc::SOCK_CLOEXEC, 0);
        assert!(fd >= 0, "socket: {}", std::io::Error::last_os_error());
        let local = sin(from, 0);
        let remote = sin(to.ip().octets(), to.port());
        let ok = libc::bind(fd, &local as *const _ as *const libc::sockaddr, len) == 0
            && libc::connect(fd, &remote as *const _ as *const libc::sockaddr, len) == 0;
        if !ok {
            let e = std::io::Error::last_os_error();
            libc::close(fd);
            panic!("connect from {from:?} to {to}: {e}");
        }
        TcpStream::from_raw_fd(fd)
    }
}

/// Opens the event stream on `s`: the status, and whether a snapshot followed a 200.
fn open_events(mut s: TcpStream, host: &str) -> (u16, bool, TcpStream) {
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    write!(s, "GET /api/events HTTP/1.1\r\nHost: {host}\r\n\r\n").unwrap();
    let mut r = BufReader::new(s.try_clone().unwrap());
    let mut head = String::new();
    r.read_line(&mut head).unwrap();
    let code: u16 = head.get(9..12).and_then(|c| c.parse().ok()).unwrap_or(0);
    let mut data = false;
    if code == 200 {
        let mut l = String::new();
        while r.read_line(&mut l).is_ok_and(|n| n > 0) {
            if l.starts_with("data: ") {
                data = true;
                break;
            }
            l.clear();
        }
    }
    (code, data, s)
}

#[test]
fn streams_from_other_loopback_addresses_leave_the_operator_page_its_stream() {
    let tmp = tempfile::tempdir().unwrap();
    let svc = Service::start(tmp.path(), None, &[]);
    let to: SocketAddr = svc.web.parse().unwrap();
    let mut held = Vec::new();
    for last in 2..=11u8 {
        for _ in 0..4 {
            let (code, _, s) = open_events(connect_from([127, 0, 0, last], to), &svc.web);
            assert!(matches!(code, 200 | 503), "127.0.0.{last}: {code}");
            held.push(s);
        }
    }
    // The operator's page on 127.0.0.1: the page, its API and its live updates.
    assert_eq!(get(&svc.web, "/"), Ok(200));
    assert_eq!(get(&svc.web, "/api/status"), Ok(200));
    let (code, data, _page) = open_events(connect_from([127, 0, 0, 1], to), &svc.web);
    assert_eq!(
        (code, data),
        (200, true),
        "the operator page's event stream"
    );
    drop(held);
}

#[test]
fn a_connection_cap_out_of_range_is_refused_before_the_database_is_made() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = tmp.path().join("board.toml");
    std::fs::write(&cfg, CONFIG).unwrap();
    for (args, says) in [
        (
            ["--http", "0", "--http-max-clients", "0"],
            "--http-max-clients must be in [1, 1024] (got 0)",
        ),
        (
            ["--alpaca", "0", "--alpaca-max-clients", "1025"],
            "--alpaca-max-clients must be in [1, 1024] (got 1025)",
        ),
    ] {
        let out = Command::new(BIN)
            .args(["serve", "--listen", "127.0.0.1:0", "--data"])
            .arg(tmp.path().join("d"))
            .arg("--board-config")
            .arg(&cfg)
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!tmp.path().join("d").exists(), "{args:?} made the database");
    }
}
