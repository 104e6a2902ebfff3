//! The line protocol: one command per line, answered by zero or more data lines and then
//! exactly one `ok` or `error:<code> <message>` (grbl style). See docs/PROTOCOL.md.

pub use crate::domain::{
    param_of_word, word_of_param, Amount, MoveOpts, RateArg, SignedRate, TrackOpts, MAX_LEASE,
};
use crate::error::CtlError;

mod grammar;
mod help;
mod line;

pub use grammar::{free_words, parse};
pub use help::{help, HELP};
pub use line::{read_line, Line, LineReader};

/// Longest accepted line, newline excluded.
pub const MAX_LINE: usize = 4096;

/// Every command of the protocol.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Blank line or comment: answered `ok`.
    Nop,
    Help,
    Version,
    Info,
    Status {
        axes: Vec<String>,
        json: bool,
    },
    Move {
        axis: String,
        by: Amount,
        opts: MoveOpts,
    },
    MoveTo {
        axis: String,
        to: Amount,
        opts: MoveOpts,
    },
    /// Synchronous group move: same start tick; `sync` also gives the same finish time.
    Group {
        absolute: bool,
        targets: Vec<(String, Amount)>,
        sync: bool,
        opts: MoveOpts,
    },
    /// A group loaded like [`Command::Group`] but armed: it starts at the next fall of
    /// the boards' shared SYNC line (`fire` on any board on that line).
    Arm {
        absolute: bool,
        targets: Vec<(String, Amount)>,
        sync: bool,
        opts: MoveOpts,
    },
    /// Pulls the SYNC line low: every board on it starts its armed group.
    Fire,
    /// The SYNC line's state and the board's count latched at its last fall.
    SyncTick,
    /// Controlled stop of one axis, or all.
    Stop {
        axis: Option<String>,
    },
    EStop,
    Reset,
    Home {
        axis: String,
    },
    Get {
        axis: String,
        key: Option<String>,
    },
    Set {
        axis: String,
        key: String,
        value: String,
    },
    /// Save the current positions of some (default all) axes under a name.
    Save {
        name: String,
        axes: Vec<String>,
    },
    Goto {
        name: String,
        opts: MoveOpts,
    },
    Positions,
    /// The board config's `[alpaca]` device section as one JSON line (read-only).
    Devices,
    /// The board's telescope mount (see [`crate::mount::line`]).
    Mount(crate::mount::line::MountCmd),
    Forget {
        name: String,
    },
    Preset {
        name: String,
        opts: MoveOpts,
    },
    Presets,
    /// Simulation only: lose `steps` steps on an axis (the count does not see it).
    SimSlip {
        axis: String,
        steps: i64,
    },
    /// Open-ended motion at a rate (or a change of rate while tracking).
    Track {
        axis: String,
        rate: RateArg,
        opts: TrackOpts,
    },
    /// Stores a named rate (`rate NAME VALUE`).
    RatePreset {
        name: String,
        rate: SignedRate,
    },
    /// Lists the named rates.
    Rates,
    /// De-energizes an idle axis's driver.
    Release {
        axis: String,
    },
    /// Energizes an axis's driver.
    Energize {
        axis: String,
    },
    /// Renames an idle axis's position without moving it (`setpos AXIS N`).
    SetPos {
        axis: String,
        to: Amount,
    },
}

/// The answer to one command.
#[derive(Debug)]
pub struct Reply {
    pub data: Vec<String>,
    pub result: Result<(), CtlError>,
}

impl Reply {
    pub fn ok(data: Vec<String>) -> Reply {
        Reply {
            data,
            result: Ok(()),
        }
    }
    pub fn err(e: CtlError) -> Reply {
        Reply {
            data: Vec::new(),
            result: Err(e),
        }
    }
    pub fn from_result(r: Result<Vec<String>, CtlError>) -> Reply {
        match r {
            Ok(d) => Reply::ok(d),
            Err(e) => Reply::err(e),
        }
    }

    /// The reply as sent: data lines, then the status line; every line ends in `\n`.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        self.write_text(&mut s);
        s
    }

    /// [`Reply::to_text`] appended to `s` (a connection reuses one buffer).
    pub fn write_text(&self, s: &mut String) {
        s.reserve(self.data.iter().map(|d| d.len() + 3).sum::<usize>() + 4);
        for d in &self.data {
            // A data line never looks like a status line and never spans lines; one that
            // holds no line break (every status line: its fault is escaped where it is
            // written) is copied as it is.
            if d == "ok" || d.starts_with("error:") {
                s.push_str("> ");
            }
            // one vectorized pass for either break
            if memchr::memchr2(b'\n', b'\r', d.as_bytes()).is_some() {
                s.push_str(&d.replace(['\n', '\r'], " "));
            } else {
                s.push_str(d);
            }
            s.push('\n');
        }
        match &self.result {
            Ok(()) => s.push_str("ok\n"),
            Err(e) => {
                let msg = e.to_string().replace(['\n', '\r'], " ");
                s.push_str(&format!("error:{} {}\n", e.code(), msg));
            }
        }
    }
}

/// `auth TOKEN`: the token, if the line is an `auth` line (handled by the connection,
/// before and beside the board's commands).
pub fn auth_token(line: &[u8]) -> Option<&str> {
    let text = std::str::from_utf8(line).ok()?;
    let mut words = text.split_whitespace();
    let head = words.next()?;
    head.eq_ignore_ascii_case("auth")
        .then(|| words.next().unwrap_or(""))
}

/// Parses raw bytes (without the newline) into a command.
pub fn parse_bytes(line: &[u8]) -> Result<Command, CtlError> {
    if line.len() > MAX_LINE {
        return Err(CtlError::LineTooLong { max: MAX_LINE });
    }
    let text = std::str::from_utf8(line).map_err(|_| CtlError::InvalidUtf8)?;
    parse(text)
}

/// `123`, `-40` (microsteps) or `12.5u` (user units).
pub fn parse_amount(w: &str) -> Result<Amount, CtlError> {
    let bad = || {
        CtlError::syntax(format!(
            "'{w}' is not a whole number of steps or a number with 'u'"
        ))
    };
    if let Some(u) = w.strip_suffix(['u', 'U']) {
        let x: f64 = u.parse().map_err(|_| bad())?;
        if !x.is_finite() {
            return Err(bad());
        }
        return Ok(Amount::Units(x));
    }
    w.parse::<i64>().map(Amount::Steps).map_err(|_| bad())
}

/// Splits a received reply into its data lines and result (host side).
pub fn parse_status_line(line: &str) -> Option<Result<(), (u16, String)>> {
    if line == "ok" {
        return Some(Ok(()));
    }
    let rest = line.strip_prefix("error:")?;
    let (code, msg) = rest.split_once(' ').unwrap_or((rest, ""));
    Some(Err((code.parse().unwrap_or(0), msg.to_string())))
}
