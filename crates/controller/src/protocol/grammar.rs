//! The protocol's grammar, once for reading and writing: each verb is one row of [`VERBS`]
//! (its words, usage, word counts and an empty command) and one arm of [`fields`], which
//! walks the command's fields in line order through a [`Codec`]: `read.rs` fills them
//! from a line's words ([`parse`]), `write.rs` prints them (the host client's `Display`)
//! and collects the words a client must keep whole (names, keys, values).

use super::{Amount, Command, MoveOpts, RateArg, SignedRate, TrackOpts};
use crate::error::CtlError;

mod read;
mod write;

use read::Reader;
pub use write::free_words;

/// One verb: its word and aliases, its usage, how many words may follow it (`max`
/// `None`: any number, the extra ones ignored or read by the verb), and its command with
/// empty fields, which [`fields`] fills.
pub(super) struct Verb {
    words: &'static [&'static str],
    usage: &'static str,
    min: usize,
    max: Option<usize>,
    blank: fn() -> Command,
}

const fn verb(
    words: &'static [&'static str],
    usage: &'static str,
    min: usize,
    max: Option<usize>,
    blank: fn() -> Command,
) -> Verb {
    Verb {
        words,
        usage,
        min,
        max,
        blank,
    }
}

fn s() -> String {
    String::new()
}

/// Every verb but `mount` (whose own grammar is `crate::mount::line`).
pub(super) const VERBS: &[Verb] = &[
    verb(&["help", "?"], "help", 0, None, || Command::Help),
    verb(&["version"], "version", 0, None, || Command::Version),
    verb(&["info"], "info", 0, None, || Command::Info),
    verb(&["status", "s"], "status [json] [AXIS…]", 0, None, || {
        Command::Status {
            axes: vec![],
            json: false,
        }
    }),
    verb(&["move"], "move AXIS STEPS [key=value…]", 2, None, || {
        Command::Move {
            axis: s(),
            by: Amount::Steps(0),
            opts: MoveOpts::default(),
        }
    }),
    verb(
        &["moveto"],
        "moveto AXIS POSITION [key=value…]",
        2,
        None,
        || Command::MoveTo {
            axis: s(),
            to: Amount::Steps(0),
            opts: MoveOpts::default(),
        },
    ),
    verb(
        &["group"],
        "group move|moveto AXIS=N… [sync] [key=value…]",
        2,
        None,
        || Command::Group {
            absolute: false,
            targets: vec![],
            sync: false,
            opts: MoveOpts::default(),
        },
    ),
    verb(
        &["arm"],
        "arm move|moveto AXIS=N… [sync] [key=value…]",
        2,
        None,
        || Command::Arm {
            absolute: false,
            targets: vec![],
            sync: false,
            opts: MoveOpts::default(),
        },
    ),
    verb(&["fire"], "fire", 0, Some(0), || Command::Fire),
    verb(&["synctick"], "synctick", 0, Some(0), || Command::SyncTick),
    verb(&["stop"], "stop [AXIS|all]", 0, Some(1), || Command::Stop {
        axis: None,
    }),
    verb(&["estop", "!"], "estop", 0, Some(0), || Command::EStop),
    verb(&["reset"], "reset", 0, Some(0), || Command::Reset),
    verb(&["home"], "home AXIS", 1, Some(1), || Command::Home {
        axis: s(),
    }),
    verb(&["get"], "get AXIS [KEY]", 1, Some(2), || Command::Get {
        axis: s(),
        key: None,
    }),
    verb(&["set"], "set AXIS KEY VALUE", 3, Some(3), || {
        Command::Set {
            axis: s(),
            key: s(),
            value: s(),
        }
    }),
    verb(&["save"], "save NAME [AXIS…]", 1, None, || {
        Command::Save {
            name: s(),
            axes: vec![],
        }
    }),
    verb(&["goto"], "goto NAME [key=value…]", 1, None, || {
        Command::Goto {
            name: s(),
            opts: MoveOpts::default(),
        }
    }),
    verb(&["positions"], "positions", 0, None, || Command::Positions),
    verb(&["devices"], "devices", 0, Some(0), || Command::Devices),
    verb(&["forget"], "forget NAME", 1, None, || Command::Forget {
        name: s(),
    }),
    verb(&["preset"], "preset NAME key=value…", 2, None, || {
        Command::Preset {
            name: s(),
            opts: MoveOpts::default(),
        }
    }),
    verb(&["presets"], "presets", 0, None, || Command::Presets),
    verb(&["sim"], "sim AXIS slip STEPS", 3, Some(3), || {
        Command::SimSlip {
            axis: s(),
            steps: 0,
        }
    }),
    verb(
        &["track"],
        "track AXIS RATE|NAME [amax=A] [lease=S]",
        2,
        None,
        || Command::Track {
            axis: s(),
            rate: RateArg::Preset(s()),
            opts: TrackOpts::default(),
        },
    ),
    verb(&["rate"], "rate NAME RATE", 2, Some(2), || {
        Command::RatePreset {
            name: s(),
            rate: SignedRate {
                negative: false,
                rate: multistep_core::Rate::ZERO,
                units: false,
            },
        }
    }),
    verb(&["rates"], "rates", 0, Some(0), || Command::Rates),
    verb(&["release"], "release AXIS", 1, Some(1), || {
        Command::Release { axis: s() }
    }),
    verb(&["energize"], "energize AXIS", 1, Some(1), || {
        Command::Energize { axis: s() }
    }),
    verb(&["setpos"], "setpos AXIS N", 2, Some(2), || {
        Command::SetPos {
            axis: s(),
            to: Amount::Steps(0),
        }
    }),
];

/// The verb of `cmd` (`None`: `Nop` and `Mount`, which have their own forms).
fn verb_of(cmd: &Command) -> Option<&'static Verb> {
    let d = std::mem::discriminant(cmd);
    VERBS
        .iter()
        .find(|v| std::mem::discriminant(&(v.blank)()) == d)
}

type R = Result<(), CtlError>;

/// One direction of the grammar: each method reads its field from the line's words or
/// writes it out.
pub(super) trait Codec {
    /// An axis name.
    fn axis(&mut self, v: &mut String) -> R;
    /// A stored name (a position, a preset, a rate).
    fn name(&mut self, v: &mut String) -> R;
    /// A key or value: any one word.
    fn word(&mut self, v: &mut String) -> R;
    /// An optional last word.
    fn opt_word(&mut self, v: &mut Option<String>) -> R;
    fn amount(&mut self, v: &mut Amount) -> R;
    /// The literal word `w` (any case).
    fn literal(&mut self, w: &'static str) -> R;
    /// A whole number.
    fn int(&mut self, v: &mut i64) -> R;
    /// The optional word `w` first (any case): `v` is whether it is there.
    fn flag(&mut self, w: &'static str, v: &mut bool) -> R;
    /// The remaining words, each an axis name.
    fn axes(&mut self, v: &mut Vec<String>) -> R;
    /// `AXIS` or `all` (`None`) or nothing (`None`).
    fn axis_or_all(&mut self, v: &mut Option<String>) -> R;
    /// The remaining words, each a `key=value` move option.
    fn opts(&mut self, v: &mut MoveOpts) -> R;
    /// A group: `move|moveto`, then `AXIS=N`, `sync` and move options in any order.
    fn group(
        &mut self,
        absolute: &mut bool,
        targets: &mut Vec<(String, Amount)>,
        sync: &mut bool,
        opts: &mut MoveOpts,
    ) -> R;
    /// A rate or a stored rate's name.
    fn rate_arg(&mut self, v: &mut RateArg) -> R;
    fn rate(&mut self, v: &mut SignedRate) -> R;
    /// The remaining words, `amax=A` and `lease=S`.
    fn track_opts(&mut self, v: &mut TrackOpts) -> R;
    /// A rule on what was read (the writer takes the command as it is).
    fn check(&mut self, ok: bool, why: &'static str) -> R;
}

/// Every field of `cmd` in line order, through `k`.
pub(super) fn fields(cmd: &mut Command, k: &mut impl Codec) -> R {
    match cmd {
        Command::Nop
        | Command::Help
        | Command::Version
        | Command::Info
        | Command::Fire
        | Command::SyncTick
        | Command::EStop
        | Command::Reset
        | Command::Positions
        | Command::Devices
        | Command::Presets
        | Command::Rates
        | Command::Mount(_) => Ok(()),
        Command::Status { axes, json } => {
            k.flag("json", json)?;
            k.axes(axes)
        }
        Command::Move { axis, by: n, opts } | Command::MoveTo { axis, to: n, opts } => {
            k.axis(axis)?;
            k.amount(n)?;
            k.opts(opts)
        }
        Command::Group {
            absolute,
            targets,
            sync,
            opts,
        }
        | Command::Arm {
            absolute,
            targets,
            sync,
            opts,
        } => k.group(absolute, targets, sync, opts),
        Command::Stop { axis } => k.axis_or_all(axis),
        Command::Home { axis } | Command::Release { axis } | Command::Energize { axis } => {
            k.axis(axis)
        }
        Command::Get { axis, key } => {
            k.axis(axis)?;
            k.opt_word(key)
        }
        Command::Set { axis, key, value } => {
            k.axis(axis)?;
            k.word(key)?;
            k.word(value)
        }
        Command::Save { name, axes } => {
            k.name(name)?;
            k.axes(axes)
        }
        Command::Goto { name, opts } => {
            k.name(name)?;
            k.opts(opts)
        }
        Command::Forget { name } => k.name(name),
        Command::Preset { name, opts } => {
            k.name(name)?;
            k.opts(opts)?;
            k.check(
                opts.preset.is_none(),
                "a preset cannot refer to another preset",
            )
        }
        Command::SimSlip { axis, steps } => {
            k.axis(axis)?;
            k.literal("slip")?;
            k.int(steps)
        }
        Command::Track { axis, rate, opts } => {
            k.axis(axis)?;
            k.rate_arg(rate)?;
            k.track_opts(opts)
        }
        Command::RatePreset { name, rate } => {
            k.name(name)?;
            k.rate(rate)
        }
        Command::SetPos { axis, to } => {
            k.axis(axis)?;
            k.amount(to)
        }
    }
}

/// Parses one line of text into a command.
pub fn parse(line: &str) -> Result<Command, CtlError> {
    let line = line.split(['#', ';']).next().unwrap_or("");
    let words: Vec<&str> = line.split_whitespace().collect();
    let Some((&head, rest)) = words.split_first() else {
        return Ok(Command::Nop);
    };
    if head.eq_ignore_ascii_case("mount") {
        return Ok(Command::Mount(crate::mount::line::parse(rest)?));
    }
    // (the table's words are lower case)
    let Some(v) = VERBS
        .iter()
        .find(|v| v.words.iter().any(|w| w.eq_ignore_ascii_case(head)))
    else {
        let head = head.to_ascii_lowercase();
        let shown: String = head.chars().take(40).collect();
        return Err(CtlError::syntax(format!(
            "unknown command '{shown}' (try 'help')"
        )));
    };
    if rest.len() < v.min {
        return Err(CtlError::syntax(format!("usage: {}", v.usage)));
    }
    if let Some(w) = v.max.and_then(|max| rest.get(max)) {
        return Err(CtlError::syntax(format!(
            "unexpected '{w}'; usage: {}",
            v.usage
        )));
    }
    let mut cmd = (v.blank)();
    fields(
        &mut cmd,
        &mut Reader {
            words: rest,
            at: 0,
            usage: v.usage,
        },
    )?;
    Ok(cmd)
}
