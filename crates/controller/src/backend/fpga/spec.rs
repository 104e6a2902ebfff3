//! How the host names and opens a board link.

use crate::error::CtlError;
use std::io::{Read, Write};
use std::time::Duration;

/// Baud of `serial:DEVICE` without `@BAUD`: the boards' default build.
pub const DEFAULT_BAUD: u32 = 3_000_000;
/// How long a request waits for its reply before the link counts as failed.
pub const REPLY_TIMEOUT: Duration = Duration::from_millis(500);
/// How often a failed link is tried again.
pub const RECONNECT_PERIOD: Duration = Duration::from_millis(500);
/// How often an idle board is read (its e-stop input, resets, Hall level).
pub const IDLE_POLL: Duration = Duration::from_millis(50);

/// A board link: `serial:DEVICE[@BAUD][,timeout=SECONDS]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LinkSpec {
    pub device: String,
    pub baud: u32,
    /// How long a request waits for its reply ([`REPLY_TIMEOUT`] unless given): a board
    /// answers within a millisecond, a simulated one (`board-sim`) on a busy machine may
    /// need seconds.
    pub timeout: Duration,
}

/// The range of `timeout=` (seconds).
pub const TIMEOUT_RANGE: std::ops::RangeInclusive<f64> = 0.01..=60.0;

impl LinkSpec {
    pub fn parse(s: &str) -> Result<LinkSpec, CtlError> {
        let bad = || {
            CtlError::Setting(format!(
                "board link '{s}': expected serial:DEVICE[@BAUD][,timeout=SECONDS] (BAUD 1200 \
                 to 100000000, SECONDS 0.01 to 60)"
            ))
        };
        let rest = s.strip_prefix("serial:").ok_or_else(bad)?;
        let (rest, timeout) = match rest.rsplit_once(",timeout=") {
            Some((r, t)) => match t.parse::<f64>() {
                Ok(t) if TIMEOUT_RANGE.contains(&t) => (r, Duration::from_secs_f64(t)),
                _ => return Err(bad()),
            },
            None => (rest, REPLY_TIMEOUT),
        };
        let (device, baud) = match rest.rsplit_once('@') {
            Some((d, b)) => (d, b.parse::<u32>().map_err(|_| bad())?),
            None => (rest, DEFAULT_BAUD),
        };
        if device.is_empty() || !(1200..=100_000_000).contains(&baud) {
            return Err(bad());
        }
        Ok(LinkSpec {
            device: device.to_string(),
            baud,
            timeout,
        })
    }
}

impl std::fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "serial:{}@{}", self.device, self.baud)?;
        if self.timeout != REPLY_TIMEOUT {
            write!(f, ",timeout={}", self.timeout.as_secs_f64())?;
        }
        Ok(())
    }
}

/// A byte stream to the board.
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// Opens the stream (again, after a failure).
pub type Opener = Box<dyn FnMut() -> Result<Box<dyn Port>, String> + Send>;

/// How long a serial line just opened is listened to before what came is thrown away. A
/// host killed mid-request leaves a request that the board still answers; a reply carries
/// only its seq, so that reply, taken for this host's first one of the same seq, would give
/// another register's value.
///
/// A tenth of the reply timeout, from 50 ms (a board answers within a millisecond and a USB
/// serial adapter holds bytes for up to 16 ms) to 0.5 s (`timeout=3`, a simulated board
/// on a busy machine: 0.3 s).
pub fn stale_reply_wait(timeout: Duration) -> Duration {
    (timeout / 10).clamp(Duration::from_millis(50), Duration::from_millis(500))
}

/// Opens the serial device of `spec` (8N1, its reply timeout), waits
/// [`stale_reply_wait`] and empties its input.
pub fn serial_opener(spec: &LinkSpec) -> Opener {
    let spec = spec.clone();
    Box::new(move || {
        let err = |e: serialport::Error| format!("{}: {e}", spec.device);
        let port = serialport::new(&spec.device, spec.baud)
            .timeout(spec.timeout)
            .open()
            .map_err(err)?;
        std::thread::sleep(stale_reply_wait(spec.timeout));
        port.clear(serialport::ClearBuffer::Input).map_err(err)?;
        Ok(Box::new(port) as Box<dyn Port>)
    })
}
