//! The driver's one connection to the controller's line protocol, opened again after the
//! controller went away. Every reply is waited for at most the link's timeout: a
//! controller that accepts and never answers must not hang the driver.

use multistep_controller::client::{Client, ClientError, Endpoint};
use multistep_controller::protocol::parse_status_line;
use multistep_controller::AxisStatus;
use std::io::{BufRead, BufReader, ErrorKind, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// How long a reply (and a TCP connect) may take unless `MULTISTEP_INDI_TIMEOUT` says.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(5);

/// Why a request got no answer it could use.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The controller answered `error:CODE MESSAGE`.
    #[error("controller: error:{code} {message}")]
    Refused { code: u16, message: String },
    /// No connection (refused, closed, reset), or no reply within the timeout.
    #[error("controller unreachable at {at}: {why}")]
    Down { at: String, why: String },
}

/// One open connection: TCP read here with a deadline per reply, or the controller
/// crate's client on a serial line (whose port has a read timeout of its own).
enum Conn {
    Tcp {
        reader: BufReader<TcpStream>,
        writer: TcpStream,
    },
    Serial(Client),
}

/// How a request failed on an open connection.
enum Failed {
    Refused(u16, String),
    /// The connection is of no more use (closed, reset, no answer in time).
    Lost(String),
}

impl Conn {
    fn open(ep: &Endpoint, timeout: Duration) -> Result<Conn, String> {
        match ep {
            Endpoint::Tcp(addr) => {
                let to = addr
                    .to_socket_addrs()
                    .map_err(|e| e.to_string())?
                    .next()
                    .ok_or_else(|| format!("{addr} names no address"))?;
                let s = TcpStream::connect_timeout(&to, timeout).map_err(|e| e.to_string())?;
                s.set_nodelay(true).map_err(|e| e.to_string())?;
                s.set_write_timeout(Some(timeout))
                    .map_err(|e| e.to_string())?;
                let r = s.try_clone().map_err(|e| e.to_string())?;
                Ok(Conn::Tcp {
                    reader: BufReader::new(r),
                    writer: s,
                })
            }
            Endpoint::Serial(_) => Client::connect(ep)
                .map(Conn::Serial)
                .map_err(|e| e.to_string()),
        }
    }

    /// Sends `line` and reads its reply: data lines, then `ok` or `error:`, all within
    /// `timeout`.
    fn request(&mut self, line: &str, timeout: Duration) -> Result<Vec<String>, Failed> {
        let (reader, writer) = match self {
            Conn::Serial(c) => {
                return c.request(line).map_err(|e| match e {
                    ClientError::Refused(r) => Failed::Refused(r.code, r.message),
                    e => Failed::Lost(e.to_string()),
                })
            }
            Conn::Tcp { reader, writer } => (reader, writer),
        };
        let lost = |e: std::io::Error| Failed::Lost(e.to_string());
        writer
            .write_all(format!("{line}\n").as_bytes())
            .and_then(|_| writer.flush())
            .map_err(lost)?;
        let deadline = Instant::now() + timeout;
        let mut data = Vec::new();
        let mut buf = String::new();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let late = || {
                Failed::Lost(format!(
                    "no answer to '{line}' within {} s",
                    timeout.as_secs_f64()
                ))
            };
            if left.is_zero() {
                return Err(late());
            }
            reader
                .get_ref()
                .set_read_timeout(Some(left))
                .map_err(lost)?;
            // A line cut by the timeout stays in `buf` and is completed by the next read.
            match reader.read_line(&mut buf) {
                Ok(0) => return Err(Failed::Lost("the controller closed the connection".into())),
                Ok(_) if !buf.ends_with('\n') => continue,
                Ok(_) => {}
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return Err(late())
                }
                Err(e) => return Err(lost(e)),
            }
            let l = buf.trim_end_matches(['\n', '\r']).to_string();
            buf.clear();
            match parse_status_line(&l) {
                Some(Ok(())) => return Ok(data),
                Some(Err((code, message))) => return Err(Failed::Refused(code, message)),
                None => data.push(l),
            }
        }
    }
}

pub struct Link {
    endpoint: Endpoint,
    token: Option<String>,
    timeout: Duration,
    conn: Option<Conn>,
}

impl Link {
    pub fn new(endpoint: Endpoint, token: Option<String>, timeout: Duration) -> Link {
        Link {
            endpoint,
            token,
            timeout,
            conn: None,
        }
    }

    fn down(&self, why: impl ToString) -> LinkError {
        LinkError::Down {
            at: match &self.endpoint {
                Endpoint::Tcp(a) => format!("tcp://{a}"),
                Endpoint::Serial(d) => format!("serial:{d}"),
            },
            why: why.to_string(),
        }
    }

    /// Sends one line, connecting first if there is no connection; a connection that fails
    /// or does not answer in time is dropped (a late reply would answer the next request),
    /// to be opened again by the next request.
    pub fn request(&mut self, line: &str) -> Result<Vec<String>, LinkError> {
        if self.conn.is_none() {
            let mut c = Conn::open(&self.endpoint, self.timeout).map_err(|e| self.down(e))?;
            if let Some(t) = &self.token {
                match c.request(&format!("auth {t}"), self.timeout) {
                    Ok(_) => {}
                    Err(Failed::Refused(code, m)) => {
                        return Err(self.down(format!("auth refused: error:{code} {m}")))
                    }
                    Err(Failed::Lost(why)) => return Err(self.down(why.replace(t, "TOKEN"))),
                }
            }
            self.conn = Some(c);
        }
        let Some(c) = self.conn.as_mut() else {
            return Err(self.down("not connected"));
        };
        match c.request(line, self.timeout) {
            Ok(data) => Ok(data),
            Err(Failed::Refused(code, message)) => Err(LinkError::Refused { code, message }),
            Err(Failed::Lost(why)) => {
                self.conn = None;
                Err(self.down(why))
            }
        }
    }

    /// `status json`, parsed.
    pub fn status(&mut self) -> Result<Vec<AxisStatus>, LinkError> {
        let data = self.request("status json")?;
        let line = data.first().map(String::as_str).unwrap_or("[]");
        serde_json::from_str(line).map_err(|e| self.down(format!("bad status json: {e}")))
    }

    /// One setting of an axis (`get AXIS KEY`), `None` when unset.
    pub fn setting(&mut self, axis: &str, key: &str) -> Result<Option<f64>, LinkError> {
        let data = self.request(&format!("get {axis} {key}"))?;
        let v = data
            .first()
            .and_then(|l| l.split_once('='))
            .map(|(_, v)| v.trim().to_string())
            .unwrap_or_default();
        Ok(v.parse::<f64>().ok())
    }
}
