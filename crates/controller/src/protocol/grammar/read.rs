//! The grammar read: a line's words into a command's fields, with the protocol's errors.

use super::{Codec, R};
use crate::error::CtlError;
use crate::protocol::{param_of_word, parse_amount, MAX_LEASE};
use crate::protocol::{Amount, MoveOpts, RateArg, SignedRate, TrackOpts};

/// Reads fields from a line's words (counts already checked against the verb).
pub(super) struct Reader<'a> {
    pub(super) words: &'a [&'a str],
    pub(super) at: usize,
    pub(super) usage: &'static str,
}

impl<'a> Reader<'a> {
    fn next(&mut self) -> Result<&'a str, CtlError> {
        let w = self
            .words
            .get(self.at)
            .ok_or_else(|| CtlError::syntax(format!("usage: {}", self.usage)))?;
        self.at += 1;
        Ok(w)
    }

    fn rest(&mut self) -> &'a [&'a str] {
        let r = &self.words[self.at.min(self.words.len())..];
        self.at = self.words.len();
        r
    }

    fn unexpected(&self, w: &str) -> CtlError {
        CtlError::syntax(format!("unexpected '{w}'; usage: {}", self.usage))
    }
}

impl Codec for Reader<'_> {
    fn axis(&mut self, v: &mut String) -> R {
        *v = axis_word(self.next()?)?;
        Ok(())
    }

    fn name(&mut self, v: &mut String) -> R {
        *v = name_word(self.next()?)?;
        Ok(())
    }

    fn word(&mut self, v: &mut String) -> R {
        *v = self.next()?.to_string();
        Ok(())
    }

    fn opt_word(&mut self, v: &mut Option<String>) -> R {
        *v = self.rest().first().map(|w| w.to_string());
        Ok(())
    }

    fn amount(&mut self, v: &mut Amount) -> R {
        *v = parse_amount(self.next()?)?;
        Ok(())
    }

    fn literal(&mut self, w: &'static str) -> R {
        if self.next()?.eq_ignore_ascii_case(w) {
            Ok(())
        } else {
            Err(CtlError::syntax(format!("usage: {}", self.usage)))
        }
    }

    fn int(&mut self, v: &mut i64) -> R {
        let w = self.next()?;
        *v = w
            .parse()
            .map_err(|_| CtlError::syntax(format!("'{w}' is not a whole number")))?;
        Ok(())
    }

    fn flag(&mut self, w: &'static str, v: &mut bool) -> R {
        *v = self
            .words
            .get(self.at)
            .is_some_and(|x| x.eq_ignore_ascii_case(w));
        self.at += usize::from(*v);
        Ok(())
    }

    fn axes(&mut self, v: &mut Vec<String>) -> R {
        *v = self
            .rest()
            .iter()
            .map(|a| axis_word(a))
            .collect::<Result<_, _>>()?;
        Ok(())
    }

    fn axis_or_all(&mut self, v: &mut Option<String>) -> R {
        *v = match self.rest().first() {
            None => None,
            Some(w) if w.eq_ignore_ascii_case("all") => None,
            Some(w) => Some(axis_word(w)?),
        };
        Ok(())
    }

    fn opts(&mut self, v: &mut MoveOpts) -> R {
        let rest = self.rest();
        *v = parse_opts(rest, &mut |w| Err(self.unexpected(w)))?;
        Ok(())
    }

    fn group(
        &mut self,
        absolute: &mut bool,
        targets: &mut Vec<(String, Amount)>,
        sync: &mut bool,
        opts: &mut MoveOpts,
    ) -> R {
        let usage = self.usage;
        *absolute = match self.next()?.to_ascii_lowercase().as_str() {
            "move" => false,
            "moveto" => true,
            other => return Err(CtlError::syntax(format!("'{other}': {usage}"))),
        };
        *opts = parse_opts(self.rest(), &mut |w| {
            if w.eq_ignore_ascii_case("sync") {
                *sync = true;
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
        Ok(())
    }

    fn rate_arg(&mut self, v: &mut RateArg) -> R {
        let w = self.next()?;
        *v = match SignedRate::parse(w) {
            Some(r) => RateArg::Value(r?),
            None => RateArg::Preset(name_word(w).map_err(|_| {
                CtlError::syntax(format!("'{w}' is neither a rate nor a rate's name"))
            })?),
        };
        Ok(())
    }

    fn rate(&mut self, v: &mut SignedRate) -> R {
        let w = self.next()?;
        *v = SignedRate::parse(w).ok_or_else(|| {
            CtlError::syntax(format!("'{w}' is not a rate; usage: {}", self.usage))
        })??;
        Ok(())
    }

    fn track_opts(&mut self, v: &mut TrackOpts) -> R {
        for w in self.rest() {
            let (k, x) = w.split_once('=').ok_or_else(|| self.unexpected(w))?;
            let n: f64 = x
                .parse()
                .ok()
                .filter(|n: &f64| n.is_finite() && *n > 0.0)
                .ok_or_else(|| {
                    CtlError::syntax(format!("{k}: '{x}' is not a number greater than 0"))
                })?;
            let k = k.to_ascii_lowercase();
            match k.as_str() {
                _ if param_of_word(&k).is_some_and(|p| p.name == "amax") => v.amax = Some(n),
                "lease" if n <= MAX_LEASE => v.lease = Some(n),
                "lease" => {
                    return Err(CtlError::syntax(format!(
                        "lease: at most {MAX_LEASE} s (got {x})"
                    )))
                }
                _ => return Err(self.unexpected(w)),
            }
        }
        Ok(())
    }

    fn check(&mut self, ok: bool, why: &'static str) -> R {
        if ok {
            Ok(())
        } else {
            Err(CtlError::syntax(why))
        }
    }
}

/// Reads `key=value` move options; other words go to `other`.
pub(super) fn parse_opts(
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
