//! The mount on the line protocol: `mount [TELESCOPE] …` commands, parsed here and run on
//! one of the board's mounts (its `[[alpaca.telescope]]` entries: the first unless one is
//! named), so clients other than Alpaca ones (the INDI driver, scripts) drive the same
//! mounts the Alpaca side serves.

use super::{DriveRate, Mount, MountError, PierSide, MAX_PULSE_MS};
use crate::error::CtlError;
use crate::Controller;
use std::sync::Arc;

/// One `mount` line: which telescope (None: the first) and what to do.
#[derive(Clone, Debug, PartialEq)]
pub struct MountCmd {
    /// Its number (0, 1, … in config order, as Alpaca numbers them), its polar axis's
    /// name, or its one-word name.
    pub telescope: Option<String>,
    pub op: MountOp,
}

/// What a `mount` line asks.
#[derive(Clone, Debug, PartialEq)]
pub enum MountOp {
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
    /// To altitude and azimuth (degrees, azimuth from north through east); tracking off.
    SlewAltAz {
        alt: f64,
        az: f64,
    },
    SyncAltAz {
        alt: f64,
        az: f64,
    },
    /// A German mount's pier flip to this side.
    Side(PierSide),
    /// MoveAxis: axis 0 (polar) or 1 (dec) at degrees per second; 0 ends it.
    Move {
        axis: usize,
        rate: f64,
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
    /// UTCDate: the mount's clock, ISO 8601 text.
    Utc(String),
    /// RightAscensionRate (seconds of RA per sidereal second) and DeclinationRate (″/s):
    /// offsets from the drive rate while tracking.
    Offset {
        ra: f64,
        dec: f64,
    },
}

const USAGE: &str = "mount [TELESCOPE] [slew RA DEC|sync RA DEC|slewaltaz ALT AZ|\
                     syncaltaz ALT AZ|side east|west|move ra|dec DEG_PER_S|\
                     track on|off [sidereal|lunar|solar|king]|park|unpark|setpark|abort|\
                     pulse n|s|e|w MS|utc ISO8601|offset RA_S_PER_S DEC_ARCSEC_PER_S]";

/// The words that start a mount command (any other first word names a telescope).
const VERBS: [&str; 15] = [
    "status",
    "slew",
    "sync",
    "slewaltaz",
    "syncaltaz",
    "side",
    "move",
    "track",
    "park",
    "unpark",
    "setpark",
    "abort",
    "pulse",
    "utc",
    "offset",
];

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
        write!(f, "mount")?;
        if let Some(t) = &self.telescope {
            write!(f, " {t}")?;
        }
        match &self.op {
            MountOp::Status => Ok(()),
            MountOp::Slew { ra, dec } => write!(f, " slew {ra} {dec}"),
            MountOp::Sync { ra, dec } => write!(f, " sync {ra} {dec}"),
            MountOp::SlewAltAz { alt, az } => write!(f, " slewaltaz {alt} {az}"),
            MountOp::SyncAltAz { alt, az } => write!(f, " syncaltaz {alt} {az}"),
            MountOp::Side(s) => write!(f, " side {}", side_word(*s)),
            MountOp::Move { axis, rate } => {
                write!(f, " move {} {rate}", if *axis == 0 { "ra" } else { "dec" })
            }
            MountOp::Track { on, rate } => {
                write!(f, " track {}", if *on { "on" } else { "off" })?;
                match rate {
                    Some(r) => write!(f, " {}", rate_word(*r)),
                    None => Ok(()),
                }
            }
            MountOp::Park => write!(f, " park"),
            MountOp::Unpark => write!(f, " unpark"),
            MountOp::SetPark => write!(f, " setpark"),
            MountOp::Abort => write!(f, " abort"),
            MountOp::Pulse { dir, ms } => {
                let d = ["n", "s", "e", "w"].get(*dir as usize).unwrap_or(&"?");
                write!(f, " pulse {d} {ms}")
            }
            MountOp::Utc(t) => write!(f, " utc {t}"),
            MountOp::Offset { ra, dec } => write!(f, " offset {ra} {dec}"),
        }
    }
}

/// Parses the words after `mount`: a first word that is no command names the telescope.
pub fn parse(rest: &[&str]) -> Result<MountCmd, CtlError> {
    let (telescope, rest) = match rest.split_first() {
        Some((w, tail)) if !VERBS.contains(&w.to_ascii_lowercase().as_str()) => {
            (Some(w.to_string()), tail)
        }
        _ => (None, rest),
    };
    Ok(MountCmd {
        telescope,
        op: parse_op(rest)?,
    })
}

fn parse_op(rest: &[&str]) -> Result<MountOp, CtlError> {
    let Some((&verb, args)) = rest.split_first() else {
        return Ok(MountOp::Status);
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
            MountOp::Status
        }
        "slew" | "sync" => {
            count(2)?;
            let (ra, dec) = (number(args[0], "RA")?, number(args[1], "Dec")?);
            if verb == "slew" {
                MountOp::Slew { ra, dec }
            } else {
                MountOp::Sync { ra, dec }
            }
        }
        "slewaltaz" | "syncaltaz" => {
            count(2)?;
            let (alt, az) = (number(args[0], "altitude")?, number(args[1], "azimuth")?);
            if verb == "slewaltaz" {
                MountOp::SlewAltAz { alt, az }
            } else {
                MountOp::SyncAltAz { alt, az }
            }
        }
        "side" => {
            count(1)?;
            match args[0].to_ascii_lowercase().as_str() {
                "east" | "e" => MountOp::Side(PierSide::East),
                "west" | "w" => MountOp::Side(PierSide::West),
                w => return Err(syntax(format!("'{w}' is neither east nor west"))),
            }
        }
        "move" => {
            count(2)?;
            let axis = match args[0].to_ascii_lowercase().as_str() {
                "ra" | "primary" => 0,
                "dec" | "secondary" => 1,
                w => return Err(syntax(format!("'{w}' is neither ra nor dec"))),
            };
            let rate = number(args[1], "rate")?;
            MountOp::Move { axis, rate }
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
            MountOp::Track { on, rate }
        }
        "park" => {
            count(0)?;
            MountOp::Park
        }
        "unpark" => {
            count(0)?;
            MountOp::Unpark
        }
        "setpark" => {
            count(0)?;
            MountOp::SetPark
        }
        "abort" => {
            count(0)?;
            MountOp::Abort
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
            MountOp::Pulse { dir, ms }
        }
        "utc" => {
            count(1)?;
            MountOp::Utc(args[0].to_string())
        }
        "offset" => {
            count(2)?;
            let (ra, dec) = (number(args[0], "RA rate")?, number(args[1], "Dec rate")?);
            MountOp::Offset { ra, dec }
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

/// The mount `telescope` names among `mounts` (None: the first).
pub fn select<'m>(
    mounts: &'m [Arc<Mount>],
    telescope: Option<&str>,
) -> Result<&'m Arc<Mount>, CtlError> {
    let none = || {
        CtlError::Mount("this board has no mount (its config has no [[alpaca.telescope]])".into())
    };
    let Some(t) = telescope else {
        return mounts.first().ok_or_else(none);
    };
    if mounts.is_empty() {
        return Err(none());
    }
    let found = match t.parse::<usize>() {
        Ok(k) => mounts.get(k),
        Err(_) => mounts.iter().find(|m| {
            m.cfg.ra_axis == t
                || m.cfg
                    .name
                    .as_deref()
                    .is_some_and(|n| n.eq_ignore_ascii_case(t))
        }),
    };
    found.ok_or_else(|| {
        let names: Vec<String> = mounts
            .iter()
            .enumerate()
            .map(|(k, m)| format!("{k} ({})", m.cfg.ra_axis))
            .collect();
        CtlError::Mount(format!(
            "no telescope '{t}' on this board; its telescopes are {}",
            names.join(", ")
        ))
    })
}

/// Runs `cmd` on the mount it names among `mounts`; its data lines.
pub fn run(
    mounts: &[Arc<Mount>],
    ctl: &Controller,
    cmd: &MountCmd,
) -> Result<Vec<String>, CtlError> {
    let mount = select(mounts, cmd.telescope.as_deref())?;
    match cmd.op {
        MountOp::Status => return Ok(vec![status(mount, ctl)?]),
        MountOp::Utc(ref t) => mount.set_utc_date(t)?,
        MountOp::Offset { ra, dec } => {
            // Both checked before either is set; a coelostat takes a Dec offset of 0.
            mount.check_rate_offset(false, ra)?;
            if dec != 0.0 || mount.cfg.dec_axis.is_some() {
                mount.check_rate_offset(true, dec)?;
                mount.set_rate_offset(ctl, true, dec)?;
            }
            mount.set_rate_offset(ctl, false, ra)?;
        }
        MountOp::Slew { ra, dec } => mount.slew(ctl, ra, dec)?,
        MountOp::Sync { ra, dec } => mount.sync(ctl, ra, dec)?,
        MountOp::SlewAltAz { alt, az } => mount.slew_alt_az(ctl, alt, az)?,
        MountOp::SyncAltAz { alt, az } => mount.sync_alt_az(ctl, alt, az)?,
        MountOp::Side(s) => mount.set_pier_side(ctl, s)?,
        MountOp::Move { axis, rate } => mount.move_axis(ctl, axis, rate)?,
        MountOp::Track { on, rate } => {
            if let Some(r) = rate {
                mount.set_drive_rate(ctl, r)?;
            }
            mount.set_tracking(ctl, on)?;
        }
        MountOp::Park => mount.park(ctl)?,
        MountOp::Unpark => mount.unpark(ctl)?,
        MountOp::SetPark => mount.set_park(ctl)?,
        MountOp::Abort => mount.abort(ctl)?,
        MountOp::Pulse { dir, ms } => mount.pulse(ctl, dir, ms)?,
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
         tracking={} rate={} slewing={} parked={} guiding={} lat={lat} lon={lon} elevation={elevation} \
         utc={} raoffset={} decoffset={}",
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
        m.utc_date(),
        m.rate_offsets().0,
        m.rate_offsets().1,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(line: &str) -> Result<MountOp, CtlError> {
        let w: Vec<&str> = line.split_whitespace().collect();
        parse(&w).map(|c| {
            assert_eq!(c.telescope, None, "{line}");
            c.op
        })
    }

    #[test]
    fn each_command_parses_to_what_it_names() {
        assert_eq!(p("").unwrap(), MountOp::Status);
        assert_eq!(
            p("slew 5.5 -12.25").unwrap(),
            MountOp::Slew {
                ra: 5.5,
                dec: -12.25
            }
        );
        assert_eq!(
            p("SYNC 0 90").unwrap(),
            MountOp::Sync { ra: 0.0, dec: 90.0 }
        );
        assert_eq!(
            p("track on lunar").unwrap(),
            MountOp::Track {
                on: true,
                rate: Some(DriveRate::Lunar)
            }
        );
        assert_eq!(
            p("track off").unwrap(),
            MountOp::Track {
                on: false,
                rate: None
            }
        );
        assert_eq!(
            p("pulse W 250").unwrap(),
            MountOp::Pulse { dir: 3, ms: 250 }
        );
        assert_eq!(p("setpark").unwrap(), MountOp::SetPark);
        assert_eq!(
            p("slewaltaz 45 180.5").unwrap(),
            MountOp::SlewAltAz {
                alt: 45.0,
                az: 180.5
            }
        );
        assert_eq!(p("side W").unwrap(), MountOp::Side(PierSide::West));
        assert_eq!(
            p("move dec -1.5").unwrap(),
            MountOp::Move {
                axis: 1,
                rate: -1.5
            }
        );
    }

    #[test]
    fn a_first_word_that_is_no_command_names_the_telescope() {
        let w = |l: &str| parse(&l.split_whitespace().collect::<Vec<_>>()).unwrap();
        assert_eq!(
            w("1 park"),
            MountCmd {
                telescope: Some("1".into()),
                op: MountOp::Park
            }
        );
        assert_eq!(
            w("ha2"),
            MountCmd {
                telescope: Some("ha2".into()),
                op: MountOp::Status
            }
        );
        // A telescope and a wrong command: the command's error.
        let e = parse(&["1", "fly"]).unwrap_err();
        assert!(e.to_string().contains("unknown mount command 'fly'"), "{e}");
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
            "mount slewaltaz 45 180.5",
            "mount syncaltaz -5 0",
            "mount side east",
            "mount move ra 2.5",
            "mount move dec 0",
            "mount utc 2026-12-04T23:41:49Z",
            "mount offset 0.5 -1.25",
            "mount 1 slew 5.5 -12.25",
            "mount ha2 side west",
            "mount 0",
        ] {
            let w: Vec<&str> = line.split_whitespace().skip(1).collect();
            assert_eq!(parse(&w).unwrap().to_string(), line);
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
            ("slewaltaz 45", "takes 2 arguments"),
            ("syncaltaz 45 north", "azimuth 'north'"),
            ("side up", "'up' is neither east nor west"),
            ("move x 1", "'x' is neither ra nor dec"),
            ("move ra fast", "rate 'fast'"),
            ("utc", "takes 1 argument"),
            ("offset 1", "takes 2 arguments"),
            ("offset 0 x", "Dec rate 'x'"),
            ("1 fly", "unknown mount command 'fly'"),
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
