//! The host side: one connection to a board, TCP or serial, sending a line and reading
//! its reply (data lines, then `ok` or `error:`).

use crate::axis::{AxisState, AxisStatus};
use crate::error::CtlError;
use crate::protocol::parse_status_line;
use crate::protocol::{Amount, Command};
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

    /// `setpos AXIS N`: the idle axis's position becomes `to` without moving (a
    /// focuser's sync); the position it now reads.
    pub fn set_position(&mut self, axis: &str, to: Amount) -> Result<i64, ClientError> {
        let data = self.send(&Command::SetPos {
            axis: axis.to_string(),
            to,
        })?;
        data.first()
            .and_then(|l| l.rsplit_once("pos=")?.1.parse().ok())
            .ok_or_else(|| ClientError::Other(format!("setpos answered {data:?}")))
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

impl Client {
    /// Sends one command, written with the protocol's own words; returns its data lines.
    pub fn send(&mut self, cmd: &Command) -> Result<Vec<String>, ClientError> {
        for w in crate::protocol::free_words(cmd) {
            if w.is_empty() || w.contains(|c: char| c.is_whitespace() || c == '#' || c == ';') {
                return Err(ClientError::Other(format!(
                    "'{w}' is not one protocol word (empty, or has a space, '#' or ';')"
                )));
            }
        }
        self.request(&cmd.to_string())
    }

    /// `status json AXIS…` (every axis when `axes` is empty), parsed.
    pub fn status_of(&mut self, axes: &[String]) -> Result<Vec<AxisStatus>, ClientError> {
        let data = self.send(&Command::Status {
            axes: axes.to_vec(),
            json: true,
        })?;
        let line = data
            .first()
            .ok_or_else(|| ClientError::Other("status json gave no data".into()))?;
        serde_json::from_str(line).map_err(|e| ClientError::Other(format!("bad status json: {e}")))
    }

    /// Polls until every axis in `axes` is idle; an axis in fault, or `timeout`, ends the
    /// wait with an error.
    pub fn wait(&mut self, axes: &[String], timeout: Duration) -> Result<(), ClientError> {
        // a timeout too long to add to the clock is no deadline at all
        let deadline = std::time::Instant::now().checked_add(timeout);
        loop {
            let st = self.status_of(axes)?;
            if let Some(s) = st.iter().find(|s| s.state == AxisState::Fault) {
                return Err(ClientError::Other(format!(
                    "axis {} is in fault: {}",
                    s.axis,
                    s.fault.as_deref().unwrap_or("?")
                )));
            }
            if st.iter().all(|s| s.state == AxisState::Idle) {
                return Ok(());
            }
            if deadline.is_some_and(|d| std::time::Instant::now() > d) {
                let busy: Vec<&str> = st
                    .iter()
                    .filter(|s| s.state != AxisState::Idle)
                    .map(|s| s.axis.as_str())
                    .collect();
                return Err(ClientError::Other(format!(
                    "timed out waiting for {}",
                    busy.join(", ")
                )));
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{parse, MoveOpts, RateArg, SignedRate, TrackOpts};
    use multistep_core::MoveParams;

    fn opts() -> MoveOpts {
        MoveOpts {
            preset: Some("fast".into()),
            profile: Some("scurve4".into()),
            params: MoveParams {
                vmax: Some(12_000.5),
                amax: Some(1e6),
                jmax: Some(3e7),
                smax: Some(1.25e9),
                accel_time: Some(0.1),
                cruise_time: Some(0.0),
                decel_time: Some(1.0 / 3.0),
                start_speed: Some(5.0),
                end_speed: Some(0.1),
                rho: Some(0.2),
                phi: Some(0.3),
                psi: Some(0.4),
            },
        }
    }

    #[test]
    fn every_command_reads_back_as_itself() {
        let x = || "X".to_string();
        let cmds = vec![
            Command::Help,
            Command::Version,
            Command::Info,
            Command::Status {
                axes: vec![],
                json: false,
            },
            Command::Status {
                axes: vec![x(), "y-2".into()],
                json: true,
            },
            Command::Move {
                axis: x(),
                by: Amount::Steps(-3200),
                opts: opts(),
            },
            Command::MoveTo {
                axis: x(),
                to: Amount::Units(12.5),
                opts: MoveOpts::default(),
            },
            Command::Group {
                absolute: true,
                targets: vec![(x(), Amount::Steps(4)), ("Y".into(), Amount::Units(-0.1))],
                sync: true,
                opts: opts(),
            },
            Command::Group {
                absolute: false,
                targets: vec![(x(), Amount::Steps(i64::MIN))],
                sync: false,
                opts: MoveOpts::default(),
            },
            Command::Stop { axis: None },
            Command::Stop { axis: Some(x()) },
            Command::EStop,
            Command::Reset,
            Command::Home { axis: x() },
            Command::Get {
                axis: x(),
                key: None,
            },
            Command::Get {
                axis: x(),
                key: Some("sim.seed".into()),
            },
            Command::Set {
                axis: x(),
                key: "vmax".into(),
                value: "2e4".into(),
            },
            Command::Save {
                name: "park".into(),
                axes: vec![x()],
            },
            Command::Goto {
                name: "park".into(),
                opts: opts(),
            },
            Command::Positions,
            Command::Devices,
            Command::Forget {
                name: "park".into(),
            },
            Command::Preset {
                name: "slow".into(),
                opts: MoveOpts {
                    preset: None,
                    ..opts()
                },
            },
            Command::Presets,
            Command::SimSlip {
                axis: x(),
                steps: -7,
            },
            Command::Track {
                axis: x(),
                rate: RateArg::Value(SignedRate::parse("-15041/324").unwrap().unwrap()),
                opts: TrackOpts {
                    amax: Some(250.5),
                    lease: Some(0.75),
                },
            },
            Command::Track {
                axis: "3".into(),
                rate: RateArg::Value(SignedRate::parse("31999.9u").unwrap().unwrap()),
                opts: TrackOpts::default(),
            },
            Command::Track {
                axis: x(),
                rate: RateArg::Preset("fast".into()),
                opts: TrackOpts::default(),
            },
            Command::RatePreset {
                name: "constant".into(),
                rate: SignedRate::parse("46.4228").unwrap().unwrap(),
            },
            Command::Rates,
            Command::Release { axis: x() },
            Command::Energize { axis: x() },
            Command::SetPos {
                axis: x(),
                to: Amount::Steps(-12000),
            },
            Command::SetPos {
                axis: x(),
                to: Amount::Units(2.5),
            },
        ];
        for c in cmds {
            let line = c.to_string();
            assert_eq!(parse(&line).unwrap(), c, "{line}");
        }
    }

    #[test]
    fn words_that_would_split_are_refused_before_sending() {
        // a client on an empty stream: anything sent would end in "closed the connection"
        let mut c = Client {
            reader: BufReader::new(Box::new(std::io::empty())),
            writer: Box::new(Vec::new()),
        };
        for bad in ["a b", "a#b", "a;b", "", "a\nb"] {
            let cmd = Command::Set {
                axis: "X".into(),
                key: "profile".into(),
                value: bad.into(),
            };
            match c.send(&cmd) {
                Err(ClientError::Other(m)) => assert!(m.contains("not one protocol word"), "{m}"),
                other => panic!("{bad:?}: {other:?}"),
            }
        }
        assert!(matches!(
            c.send(&Command::Version),
            Err(ClientError::Other(m)) if m.contains("closed")
        ));
    }
}
