//! The host side: one connection to a board, TCP or serial, sending a line and reading
//! its reply (data lines, then `ok` or `error:`).

use crate::axis::AxisStatus;
use crate::error::CtlError;
use crate::protocol::parse_status_line;
use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::time::Duration;

/// Where a board is: `tcp://HOST:PORT` or `serial:DEVICE`.
#[derive(Clone, Debug, PartialEq)]
pub enum Endpoint {
    Tcp(String),
    Serial(String),
}

impl std::str::FromStr for Endpoint {
    type Err = CtlError;
    fn from_str(s: &str) -> Result<Self, CtlError> {
        if let Some(a) = s.strip_prefix("tcp://") {
            Ok(Endpoint::Tcp(a.to_string()))
        } else if let Some(d) = s.strip_prefix("serial:") {
            Ok(Endpoint::Serial(d.to_string()))
        } else {
            Err(CtlError::syntax(format!(
                "'{s}' is neither tcp://HOST:PORT nor serial:DEVICE"
            )))
        }
    }
}

/// A reply that ended in `error:`.
#[derive(Debug, thiserror::Error)]
#[error("board answered error:{code} {message}")]
pub struct Refused {
    pub code: u16,
    pub message: String,
}

#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    #[error(transparent)]
    Refused(#[from] Refused),
    #[error("connection: {0}")]
    Io(#[from] std::io::Error),
    #[error("{0}")]
    Other(String),
}

pub struct Client {
    reader: BufReader<Box<dyn Read + Send>>,
    writer: Box<dyn Write + Send>,
}

impl Client {
    pub fn connect(ep: &Endpoint) -> Result<Client, ClientError> {
        match ep {
            Endpoint::Tcp(addr) => {
                let s = crate::service::connect(addr)?;
                Ok(Client {
                    reader: BufReader::new(Box::new(s.try_clone()?)),
                    writer: Box::new(s),
                })
            }
            Endpoint::Serial(dev) => {
                let port = serialport::new(dev, 115_200)
                    .timeout(Duration::from_secs(30))
                    .open()
                    .map_err(|e| ClientError::Other(format!("cannot open {dev}: {e}")))?;
                let w = port
                    .try_clone()
                    .map_err(|e| ClientError::Other(e.to_string()))?;
                Ok(Client {
                    reader: BufReader::new(Box::new(port)),
                    writer: Box::new(w),
                })
            }
        }
    }

    /// Sends `auth TOKEN` (a board listening off loopback wants it as the first line).
    pub fn authenticate(&mut self, token: &str) -> Result<(), ClientError> {
        self.request(&format!("auth {token}")).map(|_| ())
    }

    /// Sends one command line; returns its data lines, or the board's refusal.
    pub fn request(&mut self, line: &str) -> Result<Vec<String>, ClientError> {
        if line.contains('\n') {
            return Err(ClientError::Other("a command is one line".into()));
        }
        self.writer.write_all(format!("{line}\n").as_bytes())?;
        self.writer.flush()?;
        let mut data = Vec::new();
        loop {
            let mut buf = String::new();
            let n = match self.reader.read_line(&mut buf) {
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                r => r?,
            };
            if n == 0 {
                return Err(ClientError::Other("the board closed the connection".into()));
            }
            let l = buf.trim_end_matches(['\n', '\r']);
            match parse_status_line(l) {
                Some(Ok(())) => return Ok(data),
                Some(Err((code, message))) => return Err(Refused { code, message }.into()),
                None => data.push(l.to_string()),
            }
        }
    }

    /// `status json`, parsed.
    pub fn status(&mut self) -> Result<Vec<AxisStatus>, ClientError> {
        let data = self.request("status json")?;
        let line = data
            .first()
            .ok_or_else(|| ClientError::Other("status json gave no data".into()))?;
        serde_json::from_str(line).map_err(|e| ClientError::Other(format!("bad status json: {e}")))
    }
}
