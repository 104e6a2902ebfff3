//! An axis's streamed schedule on the board's replay unit (docs/HDL.md "Streamed moves"):
//! the exact edges of a planned move or a tracker, coded (`multistep_core::stream`) as the
//! board's buffer makes room for them.

use crate::motion::{stop_profile, EdgeSource, StepSource, Stopped};
use crate::tracking::TrackSource;
use multistep_core::stream::StreamEncoder;
use multistep_link::{AxisReg, HostLink, LinkError, Reg, Status, BULK_MAX};
use std::collections::VecDeque;
use std::io::{Read, Write};

/// Least bytes worth a bulk frame while more code is to come (a frame costs 8 bytes
/// more than its data and one reply).
pub const MIN_FRAME: usize = 64;
/// How far (in time at the tracker's speed) a tracking axis's code may run ahead of the
/// board's count: a rate change or stop takes effect that much after it is asked for.
/// 50 ms rides out a host's scheduling hiccups and a USB serial adapter's latency timer
/// (16 ms by default on FTDI's); 10 ms starved a tracking HIL board on a busy machine.
pub const TRACK_LEAD_S: f64 = 0.05;
/// Steps a tracking axis's code may always run ahead (the FIFO's, and a slow rate's).
pub const TRACK_LEAD_MIN: u64 = 16;

/// One axis's stream: its edge source, the coder, and the code not yet sent.
pub struct Feed {
    src: Box<dyn StepSource>,
    /// The source's tick of the move's tick 0 (the board's `Start`).
    start: u64,
    enc: StreamEncoder,
    pending: VecDeque<u8>,
    /// The last edge coded (move ticks).
    last: u64,
    /// The longest period the replay unit takes (its tick bits).
    max_period: u64,
    /// The source gave its last edge and the code is complete.
    pub ended: bool,
    /// Open-ended (a tracker): armed for the most steps; `StreamSteps` is written with the
    /// real count once the tracker comes to rest (`closed`).
    pub open: bool,
    pub closed: bool,
    /// A finite move coded only a lead ahead, as a tracker is, so the host can still
    /// replace its rest by a stop ramp ([`Feed::ramp_down`]): a fast homing search.
    pub lead_limited: bool,
    /// The last fill stopped at its step limit (a tracker's lead): what is coded goes now.
    held: bool,
    /// Free bytes in the board's buffer, as the board last said.
    pub free: u32,
    /// The buffer's size (the free count after arming).
    pub buffer: u32,
    /// Bytes sent and bulk frames sent.
    pub sent: u64,
    pub frames: u64,
    /// The least code left in the buffer when the host read its free count to top it up
    /// (while more was to come).
    min_left: Option<u32>,
    /// The board's count when the stream started, and the direction.
    pub count0: i64,
    pub dir: i64,
    /// The steps of a fixed feed's bytes (chain records), which are not coded here.
    fixed_steps: u64,
    /// Bulk writes the link had to send again (damaged or lost on the way, or their
    /// reply): the board got them once, late.
    pub resent: u64,
    /// A bulk write whose outcome the link left unknown: what the board holds of the code
    /// is unknown, so the stream cannot go on; the axis is stopped (its count stays exact).
    pub lost: Option<String>,
    /// The stop for a lost stream was written.
    pub stopped: bool,
}

impl Feed {
    pub fn new(src: Box<dyn StepSource>, start: u64, tick_bits: u32, open: bool) -> Feed {
        Feed {
            src,
            start,
            enc: StreamEncoder::new(),
            pending: VecDeque::new(),
            last: 0,
            max_period: (1u64 << tick_bits.min(63)) - 1,
            ended: false,
            open,
            closed: false,
            lead_limited: false,
            held: false,
            free: 0,
            buffer: 0,
            sent: 0,
            frames: 0,
            min_left: None,
            count0: 0,
            dir: 1,
            fixed_steps: 0,
            resent: 0,
            lost: None,
            stopped: false,
        }
    }

    /// A feed of fixed bytes for `steps` steps (an axis's chain records): nothing is
    /// coded, the bytes go as the buffer has room; `src` gives the move's speeds.
    pub fn fixed(src: Box<dyn StepSource>, bytes: Vec<u8>, steps: u64, tick_bits: u32) -> Feed {
        let mut f = Feed::new(src, 0, tick_bits, false);
        f.pending = bytes.into();
        f.ended = true;
        f.fixed_steps = steps;
        f
    }

    /// Notes the free count just read (the buffer's margin before topping up).
    pub fn saw_free(&mut self) {
        if !self.ended {
            let left = self.buffer.saturating_sub(self.free);
            self.min_left = Some(self.min_left.map_or(left, |m| m.min(left)));
        }
    }

    /// The least code left in the buffer seen while more was to come (bytes).
    pub fn min_left(&self) -> u32 {
        self.min_left.unwrap_or(self.buffer)
    }

    /// Fixed bytes (chain records), not a code.
    pub fn is_fixed(&self) -> bool {
        self.fixed_steps > 0
    }

    /// Steps coded so far.
    pub fn coded(&self) -> u64 {
        self.enc.steps() + self.fixed_steps
    }

    /// The tracker behind an open-ended stream.
    pub fn tracker(&mut self) -> Option<&mut TrackSource> {
        self.src.as_track()
    }

    /// Commanded speed (steps/s) at the last edge coded.
    pub fn speed(&self) -> f64 {
        self.src.speed_at(self.start.saturating_add(self.last))
    }

    /// Codes edges until `want` bytes wait to be sent, the source ends, or `max_steps`
    /// steps are coded. A period the replay unit cannot take (0, 1 or wider than its tick
    /// bits) is an error naming the step.
    pub fn fill(&mut self, want: usize, max_steps: u64) -> Result<(), String> {
        self.held = self.coded() >= max_steps;
        while !self.ended && self.pending.len() < want && !self.held {
            let Some(t) = self.src.peek() else {
                let p = &mut self.pending;
                self.enc.finish(&mut |b| p.push_back(b));
                self.ended = true;
                break;
            };
            let t = t.saturating_sub(self.start);
            let period = t.wrapping_sub(self.last);
            if t <= self.last && self.coded() > 0 || period < 2 || period > self.max_period {
                return Err(format!(
                    "step {}: a period of {period} ticks; the board's replay unit takes 2 to {}",
                    self.coded() + 1,
                    self.max_period
                ));
            }
            let p = &mut self.pending;
            self.enc
                .edge(t, &mut |b| p.push_back(b))
                .map_err(|e| e.to_string())?;
            self.src.take();
            self.last = t;
            self.held = self.coded() >= max_steps;
        }
        Ok(())
    }

    /// Bytes waiting to be sent.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// The next frame's bytes: up to `max`, at least [`MIN_FRAME`] unless that is all
    /// the code there is for now (`None`: nothing worth sending now).
    pub fn next_frame(&self, max: usize) -> Option<usize> {
        let n = self.pending.len().min(max);
        let all = (self.ended || self.held) && n == self.pending.len();
        (n > 0 && (n >= MIN_FRAME || all)).then_some(n)
    }

    pub fn take(&mut self, n: usize) -> Vec<u8> {
        self.pending.drain(..n).collect()
    }

    /// Puts bytes taken but not delivered back in front of the code still to send.
    fn untake(&mut self, bytes: Vec<u8>) {
        for b in bytes.into_iter().rev() {
            self.pending.push_front(b);
        }
    }

    /// Ends the stream with a stop at `amax` from the speed at the last edge coded: the
    /// rest of the source is dropped and `motion::stop_profile`'s edges follow that edge,
    /// as a Hall stop's ramp follows the edge on the simulated backend. Returns the
    /// stream's new step count (coded + ramp), for the board's `StreamSteps`.
    pub fn ramp_down(&mut self, amax: f64, clock_hz: f64) -> Result<u64, String> {
        self.lead_limited = false;
        if self.ended {
            return Ok(self.coded());
        }
        let from = self.start.saturating_add(self.last);
        let ramp = stop_profile(self.speed(), amax)
            .map(|p| EdgeSource::new(p, clock_hz, from))
            .transpose()
            .map_err(|e| format!("the stop ramp: {e}"))?;
        let steps = ramp.as_ref().map_or(0, |r| r.steps_left());
        self.src = match ramp {
            Some(r) => Box::new(r),
            None => Box::new(Stopped(from)),
        };
        Ok(self.coded() + steps)
    }

    /// Steps a stop asked for now still makes before its ramp when the board has made
    /// `done`: those coded already and those the next fill may code before the host looks
    /// again.
    pub fn committed_ahead(&self, done: u64) -> u64 {
        let lead = self.lead_limit(done).saturating_sub(done);
        self.coded()
            .saturating_sub(done)
            .saturating_add(lead.min(u64::MAX / 2))
    }

    /// Steps a tracking (or lead-limited) stream may have coded when the board has made
    /// `done`.
    pub fn lead_limit(&self, done: u64) -> u64 {
        if !self.open && !self.lead_limited {
            return u64::MAX;
        }
        let lead = (self.speed() * TRACK_LEAD_S).ceil().min(1e9) as u64;
        done.saturating_add(lead.max(TRACK_LEAD_MIN))
    }
}

/// Sends the next `n` bytes of `f` to `axis` in one bulk write. The link sends a damaged
/// or unanswered frame again (the board executes it once); a refusal leaves the bytes to
/// be sent again (a full buffer: after its free count is read again); a write whose
/// outcome stays unknown marks the stream lost ([`Feed::lost`]), since the board's code
/// may now lack those bytes or hold them.
pub fn send_frame<T: Read + Write>(
    l: &mut HostLink<T>,
    f: &mut Feed,
    axis: u32,
    n: usize,
) -> Result<(), LinkError> {
    let data = f.take(n);
    let again = l.retransmitted;
    match l.bulk(Reg::Axis(axis, AxisReg::StreamData), &data) {
        Ok(free) => {
            f.free = free;
            f.sent += n as u64;
            f.frames += 1;
            f.resent += u64::from(l.retransmitted != again);
            Ok(())
        }
        Err(e) if e.in_doubt() || matches!(e, LinkError::Io(_)) => {
            f.lost = Some(format!(
                "a bulk write of {n} code bytes after {} was lost on the link ({e})",
                f.sent
            ));
            Err(e)
        }
        Err(e) => {
            if matches!(
                e,
                LinkError::Refused {
                    status: Status::StreamFull,
                    ..
                }
            ) {
                f.free = 0;
            }
            f.untake(data);
            Err(e)
        }
    }
}

/// Sends `axis` the code its buffer has room for: fills the frame from the feed, sends it
/// when the free count (the last reply's, read again when it looks short) says it fits.
/// `done`: the steps the board has made of this motion (a tracker codes only a lead
/// beyond them). `may_yield`: ends early, between two frames, for an urgent request.
pub(super) fn pump<T: Read + Write>(
    l: &mut HostLink<T>,
    f: &mut Feed,
    axis: u32,
    done: u64,
    may_yield: bool,
) -> Result<(), LinkError> {
    let mut refreshed = false;
    loop {
        if may_yield && l.urgent() {
            return Ok(());
        }
        f.fill(BULK_MAX, f.lead_limit(done))
            .map_err(LinkError::Move)?;
        let Some(n) = f.next_frame(BULK_MAX.min(f.free as usize)) else {
            if f.open && f.ended && f.pending() == 0 && !f.closed {
                // the tracker came to rest: the stream ends after the steps coded, so
                // the axis ends as a planned move does (no underrun)
                let n = u32::try_from(f.coded()).unwrap_or(u32::MAX);
                l.write(Reg::Axis(axis, AxisReg::StreamSteps), n)?;
                f.closed = true;
            }
            if refreshed || f.pending() == 0 {
                return Ok(());
            }
            // the board took code since the last reply
            f.free = l.read(Reg::Axis(axis, AxisReg::StreamFree))?;
            f.saw_free();
            refreshed = true;
            continue;
        };
        send_frame(l, f, axis, n)?;
    }
}

#[cfg(test)]
mod tests;
