//! Streamed axes: the board replays a host-computed edge schedule (`crate::stream`'s
//! code) instead of computing periods. Each axis has a byte buffer the host fills over a
//! shared serial link in bulk frames; the replay unit decodes bytes into periods for the
//! axis's FIFO. This models the link and the buffers tick by tick of the move:
//!
//! - **Chunks** ([`Chunks`]): the host cuts each schedule into frames of at most `frame`
//!   bytes; what fits the empty buffer is sent before the start, every later chunk no
//!   earlier than the STEP rise after which the buffer surely has room for it (the replay
//!   unit has taken every byte holding a nibble of the periods it pushed, and a rise
//!   means its period was pushed). The board co-simulation sends exactly these chunks.
//! - **Link**: one frame at a time, `frame bytes + overhead` bytes of 10 bits each at the
//!   baud; among the axes, the chunk that may go earliest goes first.
//! - **Underrun**: the period of step i is needed when step i − 1's edge is made (the
//!   pulse unit loads it then). If the frame holding its code arrives later (plus the
//!   replay unit's decode time), the axis underruns there: its edges are late.
//!
//! No allocation: the edges are caller slices; everything else is per-axis counters.

use crate::real::fm;
use crate::stream::StreamEncoder;

/// A bulk frame's bytes besides its data (sync, seq, command, address, length, CRC).
pub const BULK_OVERHEAD: u64 = 8;
/// Most data bytes in one bulk frame (its length field is one byte).
pub const BULK_MAX: u64 = 255;
/// A register request (the start).
pub const REQUEST_BYTES: u64 = 11;
/// Cycles the replay unit may take from a frame's last byte to a period in the FIFO
/// (commit, fetch, decode: a few cycles per byte; generous).
pub const DECODE_CYCLES: u64 = 64;
/// And as many more for each streamed axis: one decoder serves every axis of a board, a
/// period at a time, in turns of at most 14 cycles (`ms_replay.v`), so an axis's period
/// may wait for a turn of each other axis.
pub const DECODE_TURN: u64 = 16;

/// One chunk of a schedule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Chunk {
    /// Move tick from which it may be sent (`None`: before the start).
    pub not_before: Option<u64>,
    /// Its bytes in the coded schedule.
    pub start: u64,
    pub end: u64,
}

/// A coder running along `edges` to the byte count of a step: how many nibbles code the
/// first `steps` periods.
#[derive(Clone, Debug)]
struct Cursor<'a> {
    edges: &'a [u64],
    enc: StreamEncoder,
}

impl<'a> Cursor<'a> {
    fn new(edges: &'a [u64]) -> Self {
        Cursor {
            edges,
            enc: StreamEncoder::new(),
        }
    }
    fn steps(&self) -> usize {
        self.enc.steps() as usize
    }
    /// Codes one more step (false at the end or on a bad schedule).
    fn advance(&mut self) -> bool {
        match self.edges.get(self.steps()) {
            Some(&t) => self.enc.edge(t, &mut |_| {}).is_ok(),
            None => false,
        }
    }
}

/// The chunks of one schedule, in order (see the module's text).
#[derive(Clone, Debug)]
pub struct Chunks<'a> {
    total: u64,
    buffer: u64,
    frame: u64,
    next: u64,
    started: bool,
    taken: Cursor<'a>,
}

impl<'a> Chunks<'a> {
    /// `edges` coded in `total` bytes, a buffer of `buffer` bytes, frames of `frame` bytes
    /// (1..=[`BULK_MAX`]).
    pub fn new(edges: &'a [u64], total: u64, buffer: u64, frame: u64) -> Self {
        Chunks {
            total,
            buffer,
            frame: frame.clamp(1, BULK_MAX),
            next: 0,
            started: false,
            taken: Cursor::new(edges),
        }
    }
}

impl Iterator for Chunks<'_> {
    type Item = Chunk;
    fn next(&mut self) -> Option<Chunk> {
        if self.next >= self.total {
            return None;
        }
        let start = self.next;
        let end = (start + self.frame).min(self.total);
        let need = end.saturating_sub(self.buffer);
        let not_before = if need == 0 && !self.started {
            None
        } else {
            self.started = true;
            // the first step count after which `need` bytes were surely taken
            while self.taken.enc.nibbles() / 2 < need || self.taken.steps() == 0 {
                if !self.taken.advance() {
                    break;
                }
            }
            let s = self.taken.steps().max(1);
            Some(self.taken.edges[s - 1] + 1)
        };
        self.next = end;
        Some(Chunk {
            not_before,
            start,
            end,
        })
    }
}

/// The bytes `edges` code to (None if a period does not fit the code).
pub fn coded_len(edges: &[u64]) -> Option<u64> {
    let mut e = StreamEncoder::new();
    for &t in edges {
        e.edge(t, &mut |_| {}).ok()?;
    }
    e.finish(&mut |_| {});
    Some(e.bytes())
}

/// The link and the board's buffers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamLink {
    /// Board clock (ticks per second).
    pub clock_hz: f64,
    /// UART baud (10 bits per byte).
    pub baud: f64,
    /// Each axis's stream buffer (bytes).
    pub buffer: u64,
    /// Data bytes per bulk frame (1..=[`BULK_MAX`]).
    pub frame: u64,
    /// Ticks the host sends each chunk after it may (0: at once; a host falling behind).
    pub host_delay: u64,
}

/// One axis of a streamed run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StreamAxisReport {
    pub steps: u64,
    /// The coded schedule's bytes, and with frame overhead.
    pub code_bytes: u64,
    pub link_bytes: u64,
    /// The first step whose period arrived too late (None: no underrun).
    pub first_underrun: Option<u64>,
    /// Least ticks between a period's arrival and its need (negative: late).
    pub min_slack_ticks: i64,
}

/// What a streamed run did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StreamReport {
    /// Move tick 0 on the link's clock (after the preload and the start frame).
    pub go_tick: u64,
    /// Link bytes sent in all, and the tick the last frame arrived.
    pub link_bytes: u64,
    pub last_arrival: u64,
    /// Axes with an underrun.
    pub underruns: usize,
}

struct AxisRun<'a> {
    chunks: Chunks<'a>,
    next: Option<Chunk>,
    need: Cursor<'a>,
}

/// Runs `axes` (each a schedule of edge ticks from the common start) over `link`; each
/// axis's figures go to `out` (same length as `axes`, at most 32 axes). None if a
/// schedule cannot be coded.
pub fn run(
    link: &StreamLink,
    axes: &[&[u64]],
    out: &mut [StreamAxisReport],
) -> Option<StreamReport> {
    const MAX: usize = 32;
    if axes.len() > MAX || out.len() != axes.len() {
        return None;
    }
    let byte_ticks = 10.0 * link.clock_hz / link.baud;
    let decode = DECODE_CYCLES + DECODE_TURN * axes.len() as u64;
    let frame_ticks = |n: u64| fm::ceil((n as f64) * byte_ticks) as u64;
    let mut runs: [Option<AxisRun<'_>>; MAX] = Default::default();
    for (a, &e) in axes.iter().enumerate() {
        let total = coded_len(e)?;
        let mut chunks = Chunks::new(e, total, link.buffer, link.frame);
        let next = chunks.next();
        runs[a] = Some(AxisRun {
            chunks,
            next,
            need: Cursor::new(e),
        });
        out[a] = StreamAxisReport {
            steps: e.len() as u64,
            code_bytes: total,
            min_slack_ticks: i64::MAX,
            ..Default::default()
        };
    }
    let mut rep = StreamReport::default();
    let mut t = 0u64; // the link is free from this tick (the link's clock)
    let send = |t: &mut u64, rep: &mut StreamReport, from: u64, bytes: u64| {
        *t = (*t).max(from) + frame_ticks(bytes);
        rep.link_bytes += bytes;
        *t
    };
    // the preload, axis by axis, then the start
    for (a, r) in runs.iter_mut().enumerate().take(axes.len()) {
        let r = r.as_mut()?;
        while let Some(c) = r.next.filter(|c| c.not_before.is_none()) {
            let n = c.end - c.start + BULK_OVERHEAD;
            send(&mut t, &mut rep, 0, n);
            out[a].link_bytes += n;
            r.next = r.chunks.next();
        }
    }
    let go = send(&mut t, &mut rep, 0, REQUEST_BYTES);
    rep.go_tick = go;
    // arrival of each step's code
    let check = |a: usize, r: &mut AxisRun<'_>, upto: u64, at: u64, o: &mut StreamAxisReport| {
        // every step whose code ends within the first `upto` bytes arrives at `at`
        loop {
            let mut probe = r.need.clone();
            if !probe.advance() || probe.enc.nibbles().div_ceil(2) > upto {
                break;
            }
            r.need = probe;
            let i = r.need.steps() - 1;
            // period i is loaded at edge i − 1 (period 0 at the start)
            let need = go + if i == 0 { 0 } else { axes[a][i - 1] };
            let slack = need as i64 - (at + decode) as i64;
            o.min_slack_ticks = o.min_slack_ticks.min(slack);
            if slack < 0 && o.first_underrun.is_none() {
                o.first_underrun = Some(i as u64);
            }
        }
    };
    for a in 0..axes.len() {
        let r = runs[a].as_mut()?;
        let upto = r.next.map_or(out[a].code_bytes, |c| c.start);
        check(a, r, upto, 0, &mut out[a]);
    }
    loop {
        // the chunk that may go earliest
        let mut pick: Option<(u64, usize)> = None;
        for (a, r) in runs.iter().enumerate().take(axes.len()) {
            if let Some(c) = r.as_ref().and_then(|r| r.next) {
                let at = go + c.not_before.map_or(0, |t| t + link.host_delay);
                if !matches!(pick, Some((b, _)) if b <= at) {
                    pick = Some((at, a));
                }
            }
        }
        let Some((from, a)) = pick else { break };
        let r = runs[a].as_mut()?;
        let c = r.next?;
        let n = c.end - c.start + BULK_OVERHEAD;
        let at = send(&mut t, &mut rep, from, n);
        out[a].link_bytes += n;
        check(a, r, c.end, at, &mut out[a]);
        r.next = r.chunks.next();
        rep.last_arrival = at;
    }
    rep.underruns = out.iter().filter(|o| o.first_underrun.is_some()).count();
    Some(rep)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn steady(n: u64, period: u64) -> Vec<u64> {
        (1..=n).map(|i| i * period + (i * 7) % 3).collect()
    }

    #[test]
    fn chunks_cover_the_code_in_order() {
        let e = steady(3000, 500);
        let total = coded_len(&e).unwrap();
        let cs: Vec<Chunk> = Chunks::new(&e, total, 512, 128).collect();
        assert_eq!(cs.iter().filter(|c| c.not_before.is_none()).count(), 4);
        assert_eq!(cs.last().unwrap().end, total);
        assert!(cs.windows(2).all(|w| w[0].end == w[1].start));
        assert!(cs
            .windows(2)
            .all(|w| w[0].not_before.unwrap_or(0) <= w[1].not_before.unwrap_or(0)));
    }

    fn link(baud: f64) -> StreamLink {
        StreamLink {
            clock_hz: 50e6,
            baud,
            buffer: 512,
            frame: 128,
            host_delay: 0,
        }
    }

    #[test]
    fn a_fast_link_keeps_up_and_a_slow_one_underruns() {
        // 4 axes at 100 k steps/s for 50 ms: 2 MB/s of code would not fit 100 kbaud
        let e = steady(5000, 500);
        let axes = [&e[..], &e[..], &e[..], &e[..]];
        let mut out = [StreamAxisReport::default(); 4];
        let r = run(&link(3e6), &axes, &mut out).unwrap();
        assert_eq!(r.underruns, 0, "{out:?}");
        assert!(out.iter().all(|o| o.min_slack_ticks > 0));
        let r = run(&link(300e3), &axes, &mut out).unwrap();
        assert_eq!(r.underruns, 4);
        assert!(out[0].first_underrun.unwrap() > 16);
    }
}
