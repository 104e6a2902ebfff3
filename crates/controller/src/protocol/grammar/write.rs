//! The grammar written: a command's fields as the words [`super::parse`] reads back, and
//! the words of them a client must keep whole.

use super::{fields, verb_of, Codec, R};
use crate::protocol::{Amount, Command, MoveOpts, RateArg, SignedRate, TrackOpts};

/// Writes fields as the words [`parse`] reads back.
#[derive(Default)]
struct Writer {
    words: Vec<String>,
}

fn amount_word(a: &Amount) -> String {
    match a {
        Amount::Steps(n) => n.to_string(),
        Amount::Units(x) => format!("{x}u"),
    }
}

impl Codec for Writer {
    fn axis(&mut self, v: &mut String) -> R {
        self.words.push(v.clone());
        Ok(())
    }

    fn name(&mut self, v: &mut String) -> R {
        self.axis(v)
    }

    fn word(&mut self, v: &mut String) -> R {
        self.axis(v)
    }

    fn opt_word(&mut self, v: &mut Option<String>) -> R {
        self.words.extend(v.clone());
        Ok(())
    }

    fn amount(&mut self, v: &mut Amount) -> R {
        self.words.push(amount_word(v));
        Ok(())
    }

    fn literal(&mut self, w: &'static str) -> R {
        self.words.push(w.to_string());
        Ok(())
    }

    fn int(&mut self, v: &mut i64) -> R {
        self.words.push(v.to_string());
        Ok(())
    }

    fn flag(&mut self, w: &'static str, v: &mut bool) -> R {
        if *v {
            self.words.push(w.to_string());
        }
        Ok(())
    }

    fn axes(&mut self, v: &mut Vec<String>) -> R {
        self.words.extend(v.iter().cloned());
        Ok(())
    }

    fn axis_or_all(&mut self, v: &mut Option<String>) -> R {
        self.words.push(v.clone().unwrap_or_else(|| "all".into()));
        Ok(())
    }

    fn opts(&mut self, v: &mut MoveOpts) -> R {
        self.words.extend(v.words());
        Ok(())
    }

    fn group(
        &mut self,
        absolute: &mut bool,
        targets: &mut Vec<(String, Amount)>,
        sync: &mut bool,
        opts: &mut MoveOpts,
    ) -> R {
        self.words
            .push(if *absolute { "moveto" } else { "move" }.into());
        for (a, n) in targets.iter() {
            self.words.push(format!("{a}={}", amount_word(n)));
        }
        self.flag("sync", sync)?;
        self.opts(opts)
    }

    fn rate_arg(&mut self, v: &mut RateArg) -> R {
        self.words.push(match v {
            RateArg::Value(r) => r.to_string(),
            RateArg::Preset(n) => n.clone(),
        });
        Ok(())
    }

    fn rate(&mut self, v: &mut SignedRate) -> R {
        self.words.push(v.to_string());
        Ok(())
    }

    fn track_opts(&mut self, v: &mut TrackOpts) -> R {
        self.words.extend(v.words());
        Ok(())
    }

    fn check(&mut self, _ok: bool, _why: &'static str) -> R {
        Ok(())
    }
}

/// A command as the one protocol line that [`parse`] reads back as the same command: the
/// host side writes what the board reads.
impl std::fmt::Display for Command {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Command::Mount(m) = self {
            return write!(f, "{m}");
        }
        let Some(v) = verb_of(self) else {
            return Ok(());
        };
        let mut w = Writer::default();
        w.words.push(v.words[0].to_string());
        // the writer never fails
        let _ = fields(&mut self.clone(), &mut w);
        f.write_str(&w.words.join(" "))
    }
}

/// The free-text words of a command (names, keys, values, stored names in its options):
/// each must stay one word on the line, or the board would read a different command.
pub fn free_words(cmd: &Command) -> Vec<String> {
    let mut w = FreeWords::default();
    let _ = fields(&mut cmd.clone(), &mut w);
    w.0
}

#[derive(Default)]
struct FreeWords(Vec<String>);

impl FreeWords {
    fn opt_names(&mut self, o: &MoveOpts) {
        self.0
            .extend(o.preset.iter().chain(o.profile.iter()).cloned());
    }
}

impl Codec for FreeWords {
    fn axis(&mut self, v: &mut String) -> R {
        self.0.push(v.clone());
        Ok(())
    }
    fn name(&mut self, v: &mut String) -> R {
        self.axis(v)
    }
    fn word(&mut self, v: &mut String) -> R {
        self.axis(v)
    }
    fn opt_word(&mut self, v: &mut Option<String>) -> R {
        self.0.extend(v.clone());
        Ok(())
    }
    fn amount(&mut self, _v: &mut Amount) -> R {
        Ok(())
    }
    fn literal(&mut self, _w: &'static str) -> R {
        Ok(())
    }
    fn int(&mut self, _v: &mut i64) -> R {
        Ok(())
    }
    fn flag(&mut self, _w: &'static str, _v: &mut bool) -> R {
        Ok(())
    }
    fn axes(&mut self, v: &mut Vec<String>) -> R {
        self.0.extend(v.iter().cloned());
        Ok(())
    }
    fn axis_or_all(&mut self, v: &mut Option<String>) -> R {
        self.opt_word(v)
    }
    fn opts(&mut self, v: &mut MoveOpts) -> R {
        self.opt_names(v);
        Ok(())
    }
    fn group(
        &mut self,
        _absolute: &mut bool,
        targets: &mut Vec<(String, Amount)>,
        _sync: &mut bool,
        opts: &mut MoveOpts,
    ) -> R {
        self.0.extend(targets.iter().map(|t| t.0.clone()));
        self.opt_names(opts);
        Ok(())
    }
    fn rate_arg(&mut self, v: &mut RateArg) -> R {
        if let RateArg::Preset(n) = v {
            self.0.push(n.clone());
        }
        Ok(())
    }
    fn rate(&mut self, _v: &mut SignedRate) -> R {
        Ok(())
    }
    fn track_opts(&mut self, _v: &mut TrackOpts) -> R {
        Ok(())
    }
    fn check(&mut self, _ok: bool, _why: &'static str) -> R {
        Ok(())
    }
}
