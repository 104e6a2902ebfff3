//! Lines as read from a connection: at most [`MAX_LINE`] bytes held, a line counted only
//! once its newline arrives.

use super::MAX_LINE;
use std::io::{BufRead, ErrorKind};
use std::time::Instant;

/// One line as read from a connection.
#[derive(Debug, PartialEq)]
pub enum Line {
    Text(Vec<u8>),
    /// Longer than [`MAX_LINE`]; the rest of it up to the newline was discarded.
    TooLong,
    /// End of input. A line not ended by `\n` before it is dropped, never run.
    Eof,
}

/// Reads lines of at most [`MAX_LINE`] bytes (the `\n` or `\r\n` not counted) without ever
/// holding more. A line only counts once its `\n` arrives: a partial line survives read
/// timeouts (it stays here) but not the end of input.
#[derive(Debug, Default)]
pub struct LineReader {
    buf: Vec<u8>,
    too_long: bool,
    /// When the first and the latest byte of the unfinished line arrived.
    started: Option<Instant>,
    last: Option<Instant>,
}

impl LineReader {
    pub fn new() -> LineReader {
        LineReader::default()
    }

    /// When the unfinished line began, if there is one.
    pub fn partial_since(&self) -> Option<Instant> {
        self.started
    }

    /// When the latest byte of the unfinished line arrived.
    pub fn partial_last_byte(&self) -> Option<Instant> {
        self.last
    }

    /// Forgets the unfinished line.
    pub fn discard(&mut self) {
        self.buf = Vec::new();
        self.too_long = false;
        self.started = None;
        self.last = None;
    }

    /// The next complete line. Errors (a read timeout among them) keep the partial line.
    pub fn read<R: BufRead>(&mut self, r: &mut R) -> std::io::Result<Line> {
        loop {
            let chunk = match r.fill_buf() {
                Ok(c) => c,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if chunk.is_empty() {
                self.discard();
                return Ok(Line::Eof);
            }
            let (part, found) = match memchr::memchr(b'\n', chunk) {
                Some(i) => (&chunk[..i], Some(i + 1)),
                None => (chunk, None),
            };
            // only a line left unfinished needs its times (a line that arrives whole,
            // the usual case, costs no clock reading)
            if found.is_none() {
                let now = Instant::now();
                self.started.get_or_insert(now);
                self.last = Some(now);
            }
            // One byte more than the limit may be a `\r` before the `\n`.
            if !self.too_long {
                if self.buf.len() + part.len() > MAX_LINE + 1 {
                    self.too_long = true;
                    self.buf = Vec::new();
                } else {
                    self.buf.extend_from_slice(part);
                }
            }
            let used = found.unwrap_or(chunk.len());
            r.consume(used);
            if found.is_some() {
                let mut buf = std::mem::take(&mut self.buf);
                let too_long = self.too_long;
                self.discard();
                if buf.last() == Some(&b'\r') {
                    buf.pop();
                }
                return Ok(if too_long || buf.len() > MAX_LINE {
                    Line::TooLong
                } else {
                    Line::Text(buf)
                });
            }
        }
    }
}

/// Reads one line with a fresh [`LineReader`] (a partial line at the end is dropped).
pub fn read_line<R: BufRead>(r: &mut R) -> std::io::Result<Line> {
    LineReader::new().read(r)
}
