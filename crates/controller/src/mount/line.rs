//! The mount on the line protocol: `mount …` commands, parsed here and run on the
//! board's mount (the first `[[alpaca.telescope]]` of its config), so clients other than
//! Alpaca ones (the INDI driver, scripts) drive the same mount the Alpaca side serves.

use super::{DriveRate, Mount, MountError, PierSide, MAX_PULSE_MS};
use crate::error::CtlError;
use crate::Controller;

/// One `mount` command.
#[derive(Clone, Debug, PartialEq)]
pub enum MountCmd {
    /// Where it points and what it does.
    Status,
    /// To RA (hours) and Dec (degrees).
    Slew {
        ra: f64,
        dec: f64,
    },
    Sync {
        ra: f64,
        dec: f64,
    },
    Track {
        on: bool,
        rate: Option<DriveRate>,
    },
    Park,
    Unpark,
    /// The stored park position becomes where the axes are now.
    SetPark,
    Abort,
    /// A guide pulse: ASCOM's direction code (0 north, 1 south, 2 east, 3 west).
    Pulse {
        dir: i64,
        ms: i64,
    },
}

const USAGE: &str = "mount [slew RA DEC|sync RA DEC|track on|off [sidereal|lunar|solar|king]|\
                     park|unpark|setpark|abort|pulse n|s|e|w MS]";

fn syntax(m: String) -> CtlError {
    CtlError::Syntax(format!("{m}; usage: {USAGE}"))
}

fn number(w: &str, what: &str) -> Result<f64, CtlError> {
    match w.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(syntax(format!("{what} '{w}' is not a number"))),
    }
}

/// The drive rate a word names.
pub fn drive_rate(w: &str) -> Option<DriveRate> {
    Some(match w.to_ascii_lowercase().as_str() {
        "sidereal" => DriveRate::Sidereal,
        "lunar" => DriveRate::Lunar,
        "solar" => DriveRate::Solar,
        "king" => DriveRate::King,
        _ => return None,
    })
}

/// The word of a drive rate.
pub fn rate_word(r: DriveRate) -> &'static str {
    match r {
        DriveRate::Sidereal => "sidereal",
        DriveRate::Lunar => "lunar",
        DriveRate::Solar => "solar",
        DriveRate::King => "king",
    }
}

fn side_word(s: PierSide) -> &'static str {
    match s {
        PierSide::East => "east",
        PierSide::West => "west",
        PierSide::Unknown => "unknown",
    }
}

/// The line [`parse`] reads back as the same command (`mount …`).
impl std::fmt::Display for MountCmd {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            MountCmd::Status => write!(f, "mount"),
            MountCmd::Slew { ra, dec } => write!(f, "mount slew {ra} {dec}"),
            MountCmd::Sync { ra, dec } => write!(f, "mount sync {ra} {dec}"),
            MountCmd::Track { on, rate } => {
                write!(f, "mount track {}", if on { "on" } else { "off" })?;
                match rate {
                    Some(r) => write!(f, " {}", rate_word(r)),
                    None => Ok(()),
                }
            }
            MountCmd::Park => write!(f, "mount park"),
            MountCmd::Unpark => write!(f, "mount unpark"),
            MountCmd::SetPark => write!(f, "mount setpark"),
            MountCmd::Abort => write!(f, "mount abort"),
            MountCmd::Pulse { dir, ms } => {
                let d = ["n", "s", "e", "w"].get(dir as usize).unwrap_or(&"?");
                write!(f, "mount pulse {d} {ms}")
            }
        }
    }
}

/// Parses the words after `mount`.
pub fn parse(rest: &[&str]) -> Result<MountCmd, CtlError> {
    let Some((&verb, args)) = rest.split_first() else {
        return Ok(MountCmd::Status);
    };
    let verb = verb.to_ascii_lowercase();
    let count = |n: usize| {
        if args.len() == n {
            Ok(())
        } else {
            Err(syntax(format!(
                "'mount {verb}' takes {n} argument{}",
                if n == 1 { "" } else { "s" }
            )))
        }
    };
    Ok(match verb.as_str() {
        "status" => {
            count(0)?;
            MountCmd::Status
        }
        "slew" | "sync" => {
            count(2)?;
            let (ra, dec) = (number(args[0], "RA")?, number(args[1], "Dec")?);
            if verb == "slew" {
                MountCmd::Slew { ra, dec }
            } else {
                MountCmd::Sync { ra, dec }
            }
        }
        "track" => {
            if args.is_empty() || args.len() > 2 {
                return Err(syntax("'mount track' takes on or off and a rate".into()));
            }
            let on = match args[0].to_ascii_lowercase().as_str() {
                "on" => true,
                "off" => false,
                w => return Err(syntax(format!("'{w}' is neither on nor off"))),
            };
            let rate = match args.get(1) {
                None => None,
                Some(w) => Some(drive_rate(w).ok_or_else(|| {
                    syntax(format!("'{w}' is not sidereal, lunar, solar or king"))
                })?),
            };
            MountCmd::Track { on, rate }
        }
        "park" => {
            count(0)?;
            MountCmd::Park
        }
        "unpark" => {
            count(0)?;
            MountCmd::Unpark
        }
        "setpark" => {
            count(0)?;
            MountCmd::SetPark
        }
        "abort" => {
            count(0)?;
            MountCmd::Abort
        }
        "pulse" => {
            count(2)?;
            let dir = match args[0].to_ascii_lowercase().as_str() {
                "n" | "north" => 0,
                "s" | "south" => 1,
                "e" | "east" => 2,
                "w" | "west" => 3,
                w => return Err(syntax(format!("'{w}' is not n, s, e or w"))),
            };
            let ms = args[1]
                .parse::<i64>()
                .ok()
                .filter(|ms| (0..=MAX_PULSE_MS).contains(ms))
                .ok_or_else(|| {
                    syntax(format!(
                        "pulse length '{}' is not a whole number of ms from 0 to {MAX_PULSE_MS}",
                        args[1]
                    ))
                })?;
            MountCmd::Pulse { dir, ms }
        }
        w => return Err(syntax(format!("unknown mount command '{w}'"))),
    })
}

impl From<MountError> for CtlError {
    fn from(e: MountError) -> CtlError {
        match e {
            MountError::Ctl(c) => c,
            e => CtlError::Mount(e.to_string()),
        }
    }
}

/// Runs `cmd` on `mount`; its data lines.
pub fn run(mount: &Mount, ctl: &Controller, cmd: &MountCmd) -> Result<Vec<String>, CtlError> {
    match *cmd {
        MountCmd::Status => return Ok(vec![status(mount, ctl)?]),
        MountCmd::Slew { ra, dec } => mount.slew(ctl, ra, dec)?,
        MountCmd::Sync { ra, dec } => mount.sync(ctl, ra, dec)?,
        MountCmd::Track { on, rate } => {
            if let Some(r) = rate {
                mount.set_drive_rate(ctl, r)?;
            }
            mount.set_tracking(ctl, on)?;
        }
        MountCmd::Park => mount.park(ctl)?,
        MountCmd::Unpark => mount.unpark(ctl)?,
        MountCmd::SetPark => mount.set_park(ctl)?,
        MountCmd::Abort => mount.abort(ctl)?,
        MountCmd::Pulse { dir, ms } => mount.pulse(ctl, dir, ms)?,
    }
    Ok(vec![])
}

/// The `mount` status line.
fn status(m: &Mount, ctl: &Controller) -> Result<String, CtlError> {
    let p = m.pointing(ctl)?;
    let (lat, lon, elevation) = m.site();
    let b = |x: bool| x as u8;
    Ok(format!(
        "mount ra={:.6} dec={:.6} ha={:.6} lst={:.6} alt={:.6} az={:.6} side={} \
         tracking={} rate={} slewing={} parked={} guiding={} lat={lat} lon={lon} elevation={elevation}",
        p.ra,
        p.dec,
        p.ha,
        p.lst,
        p.alt,
        p.az,
        side_word(p.side),
        b(m.tracking()),
        rate_word(m.drive_rate()),
        b(m.slewing()),
        b(m.at_park()),
        b(m.is_pulse_guiding()),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(line: &str) -> Result<MountCmd, CtlError> {
        let w: Vec<&str> = line.split_whitespace().collect();
        parse(&w)
    }

    #[test]
    fn each_command_parses_to_what_it_names() {
        assert_eq!(p("").unwrap(), MountCmd::Status);
        assert_eq!(
            p("slew 5.5 -12.25").unwrap(),
            MountCmd::Slew {
                ra: 5.5,
                dec: -12.25
            }
        );
        assert_eq!(
            p("SYNC 0 90").unwrap(),
            MountCmd::Sync { ra: 0.0, dec: 90.0 }
        );
        assert_eq!(
            p("track on lunar").unwrap(),
            MountCmd::Track {
                on: true,
                rate: Some(DriveRate::Lunar)
            }
        );
        assert_eq!(
            p("track off").unwrap(),
            MountCmd::Track {
                on: false,
                rate: None
            }
        );
        assert_eq!(
            p("pulse W 250").unwrap(),
            MountCmd::Pulse { dir: 3, ms: 250 }
        );
        assert_eq!(p("setpark").unwrap(), MountCmd::SetPark);
    }

    #[test]
    fn a_command_written_reads_back_as_itself() {
        for line in [
            "mount",
            "mount slew 5.5 -12.25",
            "mount sync 23.999 0",
            "mount track on king",
            "mount track off",
            "mount park",
            "mount unpark",
            "mount setpark",
            "mount abort",
            "mount pulse e 1500",
        ] {
            let cmd = p(line.strip_prefix("mount").unwrap()).unwrap();
            assert_eq!(cmd.to_string(), line);
        }
    }

    #[test]
    fn bad_words_are_syntax_errors_naming_the_word() {
        for (line, says) in [
            ("slew 5", "takes 2 arguments"),
            ("slew five 3", "RA 'five'"),
            ("slew 1 nan", "Dec 'nan'"),
            ("track maybe", "'maybe' is neither"),
            ("track on weekly", "'weekly' is not sidereal"),
            ("pulse up 10", "'up' is not n"),
            ("pulse n 600001", "'600001'"),
            ("pulse n -1", "'-1'"),
            ("park now", "takes 0 arguments"),
            ("fly", "unknown mount command 'fly'"),
        ] {
            let e = p(line).unwrap_err();
            assert_eq!(e.code(), 3, "{line}");
            assert!(e.to_string().contains(says), "{line}: {e}");
        }
    }

    #[test]
    fn the_mounts_refusals_keep_their_message_under_code_24() {
        let e: CtlError = MountError::Parked.into();
        assert_eq!(e.code(), 24);
        assert!(e.to_string().contains("parked"), "{e}");
        let e: CtlError = MountError::Ctl(CtlError::EStopped).into();
        assert_eq!(e.code(), 11);
    }
}
