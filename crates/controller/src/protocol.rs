//! The line protocol: one command per line, answered by zero or more data lines and then
//! exactly one `ok` or `error:<code> <message>` (grbl style). See docs/PROTOCOL.md.

pub use crate::domain::{
    param_of_word, word_of_param, Amount, MoveOpts, RateArg, SignedRate, TrackOpts, MAX_LEASE,
};
use crate::error::CtlError;

mod help;
mod line;

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
        s.reserve(self.data.iter().map(|d| d.len() + 3).sum::<usize>() + 4);
        for d in &self.data {
            // A data line never looks like a status line and never spans lines; one that
            // holds no line break (every status line: its fault is escaped where it is
            // written) is copied as it is.
            if d == "ok" || d.starts_with("error:") {
                s.push_str("> ");
            }
            // (a byte slice's `contains` runs a word at a time)
            if d.as_bytes().contains(&b'\n') || d.as_bytes().contains(&b'\r') {
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
        s
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

/// Parses one line of text into a command.
pub fn parse(line: &str) -> Result<Command, CtlError> {
    let line = line.split(['#', ';']).next().unwrap_or("");
    let words: Vec<&str> = line.split_whitespace().collect();
    let Some((&head, rest)) = words.split_first() else {
        return Ok(Command::Nop);
    };
    let head = head.to_ascii_lowercase();
    let want = |n: usize, usage: &str| -> Result<(), CtlError> {
        if rest.len() < n {
            Err(CtlError::syntax(format!("usage: {usage}")))
        } else {
            Ok(())
        }
    };
    let none_after = |n: usize, usage: &str| -> Result<(), CtlError> {
        if rest.len() > n {
            Err(CtlError::syntax(format!(
                "unexpected '{}'; usage: {usage}",
                rest[n]
            )))
        } else {
            Ok(())
        }
    };
    Ok(match head.as_str() {
        "help" | "?" => Command::Help,
        "version" => Command::Version,
        "info" => Command::Info,
        "status" | "s" => {
            let json = rest.first().is_some_and(|w| w.eq_ignore_ascii_case("json"));
            let axes = rest[json as usize..]
                .iter()
                .map(|a| axis_word(a))
                .collect::<Result<_, _>>()?;
            Command::Status { axes, json }
        }
        "move" | "moveto" => {
            let usage = if head == "move" {
                "move AXIS STEPS [key=value…]"
            } else {
                "moveto AXIS POSITION [key=value…]"
            };
            want(2, usage)?;
            let axis = axis_word(rest[0])?;
            let amount = parse_amount(rest[1])?;
            let opts = only_opts(&rest[2..], usage)?;
            if head == "move" {
                Command::Move {
                    axis,
                    by: amount,
                    opts,
                }
            } else {
                Command::MoveTo {
                    axis,
                    to: amount,
                    opts,
                }
            }
        }
        "group" | "arm" => {
            let usage = if head == "group" {
                "group move|moveto AXIS=N… [sync] [key=value…]"
            } else {
                "arm move|moveto AXIS=N… [sync] [key=value…]"
            };
            want(2, usage)?;
            let absolute = match rest[0].to_ascii_lowercase().as_str() {
                "move" => false,
                "moveto" => true,
                other => return Err(CtlError::syntax(format!("'{other}': {usage}"))),
            };
            let mut targets = Vec::new();
            let mut sync = false;
            let opts = parse_opts(&rest[1..], &mut |w| {
                if w.eq_ignore_ascii_case("sync") {
                    sync = true;
                    return Ok(());
                }
                let (a, n) = w
                    .split_once('=')
                    .ok_or_else(|| CtlError::syntax(format!("'{w}' is not AXIS=N; {usage}")))?;
                targets.push((axis_word(a)?, parse_amount(n)?));
                Ok(())
            })?;
            if targets.is_empty() {
                return Err(CtlError::syntax(format!("no axes given; {usage}")));
            }
            if head == "group" {
                Command::Group {
                    absolute,
                    targets,
                    sync,
                    opts,
                }
            } else {
                Command::Arm {
                    absolute,
                    targets,
                    sync,
                    opts,
                }
            }
        }
        "fire" => {
            none_after(0, "fire")?;
            Command::Fire
        }
        "synctick" => {
            none_after(0, "synctick")?;
            Command::SyncTick
        }
        "stop" => {
            none_after(1, "stop [AXIS|all]")?;
            let axis = match rest.first() {
                None => None,
                Some(w) if w.eq_ignore_ascii_case("all") => None,
                Some(w) => Some(axis_word(w)?),
            };
            Command::Stop { axis }
        }
        "estop" | "!" => {
            none_after(0, "estop")?;
            Command::EStop
        }
        "reset" => {
            none_after(0, "reset")?;
            Command::Reset
        }
        "home" => {
            want(1, "home AXIS")?;
            none_after(1, "home AXIS")?;
            Command::Home {
                axis: axis_word(rest[0])?,
            }
        }
        "get" => {
            want(1, "get AXIS [KEY]")?;
            none_after(2, "get AXIS [KEY]")?;
            Command::Get {
                axis: axis_word(rest[0])?,
                key: rest.get(1).map(|s| s.to_string()),
            }
        }
        "set" => {
            want(3, "set AXIS KEY VALUE")?;
            none_after(3, "set AXIS KEY VALUE")?;
            Command::Set {
                axis: axis_word(rest[0])?,
                key: rest[1].to_string(),
                value: rest[2].to_string(),
            }
        }
        "save" => {
            want(1, "save NAME [AXIS…]")?;
            Command::Save {
                name: name_word(rest[0])?,
                axes: rest[1..]
                    .iter()
                    .map(|a| axis_word(a))
                    .collect::<Result<_, _>>()?,
            }
        }
        "goto" => {
            want(1, "goto NAME [key=value…]")?;
            let opts = only_opts(&rest[1..], "goto NAME [key=value…]")?;
            Command::Goto {
                name: name_word(rest[0])?,
                opts,
            }
        }
        "positions" => Command::Positions,
        "mount" => Command::Mount(crate::mount::line::parse(rest)?),
        "devices" => {
            none_after(0, "devices")?;
            Command::Devices
        }
        "forget" => {
            want(1, "forget NAME")?;
            Command::Forget {
                name: name_word(rest[0])?,
            }
        }
        "preset" => {
            want(2, "preset NAME key=value…")?;
            let opts = only_opts(&rest[1..], "preset NAME key=value…")?;
            if opts.preset.is_some() {
                return Err(CtlError::syntax("a preset cannot refer to another preset"));
            }
            Command::Preset {
                name: name_word(rest[0])?,
                opts,
            }
        }
        "presets" => Command::Presets,
        "sim" => {
            let usage = "sim AXIS slip STEPS";
            want(3, usage)?;
            none_after(3, usage)?;
            if !rest[1].eq_ignore_ascii_case("slip") {
                return Err(CtlError::syntax(format!("usage: {usage}")));
            }
            let steps = rest[2]
                .parse()
                .map_err(|_| CtlError::syntax(format!("'{}' is not a whole number", rest[2])))?;
            Command::SimSlip {
                axis: axis_word(rest[0])?,
                steps,
            }
        }
        "track" => {
            let usage = "track AXIS RATE|NAME [amax=A] [lease=S]";
            want(2, usage)?;
            let axis = axis_word(rest[0])?;
            let rate = match SignedRate::parse(rest[1]) {
                Some(r) => RateArg::Value(r?),
                None => RateArg::Preset(name_word(rest[1]).map_err(|_| {
                    CtlError::syntax(format!("'{}' is neither a rate nor a rate's name", rest[1]))
                })?),
            };
            let mut opts = TrackOpts::default();
            for w in &rest[2..] {
                let (k, v) = w
                    .split_once('=')
                    .ok_or_else(|| CtlError::syntax(format!("unexpected '{w}'; usage: {usage}")))?;
                let x: f64 = v
                    .parse()
                    .ok()
                    .filter(|x: &f64| x.is_finite() && *x > 0.0)
                    .ok_or_else(|| {
                        CtlError::syntax(format!("{k}: '{v}' is not a number greater than 0"))
                    })?;
                let k = k.to_ascii_lowercase();
                match k.as_str() {
                    _ if param_of_word(&k).is_some_and(|p| p.name == "amax") => opts.amax = Some(x),
                    "lease" if x <= MAX_LEASE => opts.lease = Some(x),
                    "lease" => {
                        return Err(CtlError::syntax(format!(
                            "lease: at most {MAX_LEASE} s (got {v})"
                        )))
                    }
                    _ => {
                        return Err(CtlError::syntax(format!(
                            "unexpected '{w}'; usage: {usage}"
                        )))
                    }
                }
            }
            Command::Track { axis, rate, opts }
        }
        "rate" => {
            let usage = "rate NAME RATE";
            want(2, usage)?;
            none_after(2, usage)?;
            let rate = SignedRate::parse(rest[1]).ok_or_else(|| {
                CtlError::syntax(format!("'{}' is not a rate; usage: {usage}", rest[1]))
            })??;
            Command::RatePreset {
                name: name_word(rest[0])?,
                rate,
            }
        }
        "rates" => {
            none_after(0, "rates")?;
            Command::Rates
        }
        "release" | "energize" => {
            let usage = if head == "release" {
                "release AXIS"
            } else {
                "energize AXIS"
            };
            want(1, usage)?;
            none_after(1, usage)?;
            let axis = axis_word(rest[0])?;
            if head == "release" {
                Command::Release { axis }
            } else {
                Command::Energize { axis }
            }
        }
        "setpos" => {
            want(2, "setpos AXIS N")?;
            none_after(2, "setpos AXIS N")?;
            Command::SetPos {
                axis: axis_word(rest[0])?,
                to: parse_amount(rest[1])?,
            }
        }
        other => {
            let shown: String = other.chars().take(40).collect();
            return Err(CtlError::syntax(format!(
                "unknown command '{shown}' (try 'help')"
            )));
        }
    })
}

/// Reads words that must all be move options.
fn only_opts(words: &[&str], usage: &str) -> Result<MoveOpts, CtlError> {
    parse_opts(words, &mut |w| {
        Err(CtlError::syntax(format!(
            "unexpected '{w}'; usage: {usage}"
        )))
    })
}

/// Reads `key=value` move options; other words go to `other`.
fn parse_opts(
    words: &[&str],
    other: &mut dyn FnMut(&str) -> Result<(), CtlError>,
) -> Result<MoveOpts, CtlError> {
    let mut opts = MoveOpts::default();
    for w in words {
        match w.split_once('=') {
            Some((k, v)) if opts.set(&k.to_ascii_lowercase(), v)? => {}
            _ => other(w)?,
        }
    }
    Ok(opts)
}

fn axis_word(w: &str) -> Result<String, CtlError> {
    if crate::axis::valid_axis_name(w) {
        Ok(w.to_string())
    } else {
        let shown: String = w.chars().take(40).collect();
        Err(CtlError::UnknownAxis(shown))
    }
}

fn name_word(w: &str) -> Result<String, CtlError> {
    if crate::axis::valid_axis_name(w) {
        Ok(w.to_string())
    } else {
        Err(CtlError::syntax(
            "names are letters, digits, '_' and '-' (at most 32)",
        ))
    }
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
