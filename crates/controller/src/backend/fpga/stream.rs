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
mod tests {
    use super::*;
    use crate::motion::EdgeSource;
    use multistep_core::stream::StreamDecoder;
    use multistep_core::{Family, PhaseMove, Profile};

    fn profile(steps: u64) -> Profile {
        Profile::phase(&PhaseMove {
            steps,
            accel_time: 0.01,
            cruise_time: 0.01,
            decel_time: 0.01,
            start_speed: 0.0,
            end_speed: 0.0,
            family: Family::Parabolic,
        })
        .unwrap()
    }

    /// The frames decode to exactly the generator's edges.
    #[test]
    fn frames_carry_the_exact_edges() {
        let p = profile(1500);
        let want: Vec<u64> = multistep_core::EdgeGenerator::new(p.clone(), 50e6)
            .unwrap()
            .collect();
        let src = EdgeSource::new(p, 50e6, 777).unwrap();
        let mut f = Feed::new(Box::new(src), 777, 24, false);
        let mut bytes = Vec::new();
        loop {
            f.fill(200, u64::MAX).unwrap();
            let Some(n) = f.next_frame(100) else { break };
            assert!(n >= MIN_FRAME || f.ended, "{n}");
            bytes.extend(f.take(n));
        }
        assert!(f.ended && f.pending() == 0);
        let mut d = StreamDecoder::new();
        let mut got = Vec::new();
        let mut t = 0u64;
        for b in bytes {
            d.byte(b, &mut |p| {
                t += u64::from(p);
                got.push(t)
            })
            .unwrap();
        }
        assert_eq!(got, want);
        assert_eq!(f.coded(), 1500);
    }

    /// The feed's frames so far, after coding up to `max_steps`.
    fn drain(f: &mut Feed, max_steps: u64, bytes: &mut Vec<u8>) {
        f.fill(100_000, max_steps).unwrap();
        while let Some(n) = f.next_frame(usize::MAX) {
            bytes.extend(f.take(n));
        }
    }

    /// The edge ticks the replay unit decodes from `bytes`.
    fn decode(bytes: &[u8]) -> Vec<u64> {
        let mut d = StreamDecoder::new();
        let (mut got, mut t) = (Vec::new(), 0u64);
        for &b in bytes {
            d.byte(b, &mut |p| {
                t += u64::from(p);
                got.push(t)
            })
            .unwrap();
        }
        got
    }

    /// A fast search cut short: the search's edges up to the lead, then the stop ramp
    /// at amax from the speed there, continuing from the last edge coded.
    #[test]
    fn a_lead_limited_search_ramps_down_after_its_last_coded_edge() {
        let (clock, amax) = (50e6, 20_000.0);
        let search = multistep_core::MoveSpec {
            steps: Some(100_000),
            params: multistep_core::MoveParams {
                vmax: Some(2000.0),
                amax: Some(amax),
                ..Default::default()
            },
            ..Default::default()
        }
        .plan_on_clock(clock)
        .unwrap();
        let want: Vec<u64> = multistep_core::EdgeGenerator::new(search.clone(), clock)
            .unwrap()
            .collect();
        let mut f = Feed::new(
            Box::new(EdgeSource::new(search, clock, 0).unwrap()),
            0,
            24,
            false,
        );
        f.lead_limited = true;
        // the board has made 400 steps (in cruise): 50 ms at 2000 steps/s are coded beyond
        let mut bytes = Vec::new();
        drain(&mut f, 400, &mut bytes);
        let lead = f.lead_limit(400);
        assert_eq!(lead, 500);
        drain(&mut f, lead, &mut bytes);
        assert_eq!(decode(&bytes), want[..500]);
        let total = f.ramp_down(amax, clock).unwrap();
        // 2000² / (2 · 20 000) = 100 steps to stop
        assert_eq!(total, 600);
        let limit = f.lead_limit(500);
        drain(&mut f, limit, &mut bytes);
        assert!(f.ended);
        let got = decode(&bytes);
        assert_eq!(got.len(), 600);
        let ramp: Vec<u64> =
            multistep_core::EdgeGenerator::new(stop_profile(2000.0, amax).unwrap(), clock)
                .unwrap()
                .map(|e| want[499] + e)
                .collect();
        assert_eq!(got[500..], ramp);
        // the speed carries on through the splice (the first ramp step already slows by
        // amax · period: 10 steps/s), then only falls
        let periods: Vec<u64> = got.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!(periods[498], 25_000);
        assert!((25_001..25_250).contains(&periods[499]), "{}", periods[499]);
        assert!(periods[499..].windows(2).all(|w| w[1] + 1 >= w[0]));
        assert!(periods[598] > 5 * periods[498]);
    }

    #[test]
    fn a_period_beyond_the_tick_bits_is_refused_by_step() {
        // 1500 steps in 0.03 s: the first period is far above 2^10 ticks
        let src = EdgeSource::new(profile(1500), 50e6, 0).unwrap();
        let mut f = Feed::new(Box::new(src), 0, 10, false);
        let e = f.fill(100, u64::MAX).unwrap_err();
        assert!(e.starts_with("step 1: a period of"), "{e}");
    }

    #[test]
    fn a_tracking_stream_stays_within_its_lead() {
        use multistep_core::{Rate, TrackLimits};
        let limits = TrackLimits {
            amax: 1e5,
            jmax: None,
        };
        let src = TrackSource::new(50e6, limits, Rate::new(20_000, 1).unwrap(), 0).unwrap();
        let mut f = Feed::new(Box::new(src), 0, 24, true);
        f.fill(10_000, f.lead_limit(0)).unwrap();
        assert_eq!(f.coded(), TRACK_LEAD_MIN);
        // at speed: 50 ms at 20 000 steps/s ahead of the board
        f.fill(100_000, 5000).unwrap();
        assert_eq!(f.lead_limit(1000), 2000);
        assert!(!f.ended);
    }

    /// A board's stream buffer behind the link's framing: bulk writes append to
    /// `committed`; a chosen copy of a chosen frame arrives with a byte damaged (refused
    /// as a bad CRC), one frame may be refused as not fitting; a retransmission of the
    /// frame executed last is answered from its kept reply (as `ms_link.v`).
    #[derive(Default)]
    struct Board {
        committed: Vec<u8>,
        out: Vec<u8>,
        /// Copies of bulk frames received so far.
        copies: usize,
        /// (copy, byte) to damage.
        damage: Vec<(usize, usize)>,
        /// Refuse this copy as not fitting.
        full: Option<usize>,
        kept: Option<(Vec<u8>, Reply)>,
    }

    use multistep_link::{BulkWrite, Reply};

    impl Write for Board {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            let mut f = b.to_vec();
            let copy = self.copies;
            self.copies += 1;
            for &(c, i) in &self.damage {
                if c == copy {
                    f[i] ^= 0x10;
                }
            }
            let reply = match (BulkWrite::decode(&f), &self.kept) {
                (Err(_), _) => Reply {
                    seq: f[1],
                    status: Status::BadCrc,
                    data: 0,
                },
                (Ok(_), Some((k, r))) if *k == f => *r,
                (Ok(w), _) => {
                    let status = if self.full == Some(copy) {
                        Status::StreamFull
                    } else {
                        self.committed.extend(&w.data);
                        Status::Ok
                    };
                    let r = Reply {
                        seq: w.seq,
                        status,
                        data: 512,
                    };
                    self.kept = Some((f, r));
                    r
                }
            };
            self.out.extend(reply.encode());
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Read for Board {
        fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
            super::super::model::read_out(&mut self.out, b)
        }
    }

    /// A 1500-step parabolic move's feed, and its edges.
    fn feed() -> (Feed, Vec<u64>) {
        let p = profile(1500);
        let want = multistep_core::EdgeGenerator::new(p.clone(), 50e6)
            .unwrap()
            .collect();
        let f = Feed::new(Box::new(EdgeSource::new(p, 50e6, 0).unwrap()), 0, 24, false);
        (f, want)
    }

    /// Sends the whole feed in frames of up to 100 bytes; the first error ends it.
    fn send_all(l: &mut HostLink<Board>, f: &mut Feed) -> Result<(), LinkError> {
        loop {
            f.fill(100, u64::MAX).unwrap();
            let Some(n) = f.next_frame(100) else {
                return Ok(());
            };
            send_frame(l, f, 0, n)?;
        }
    }

    #[test]
    fn a_damaged_bulk_write_is_sent_again_and_the_code_arrives_whole() {
        for byte in [0, 5, 40, 107] {
            let (mut f, want) = feed();
            let mut l = HostLink::new(Board {
                damage: vec![(2, byte)],
                ..Board::default()
            });
            send_all(&mut l, &mut f).unwrap();
            assert_eq!(decode(&l.into_inner().committed), want, "byte {byte}");
            assert_eq!((f.resent, f.lost.is_none()), (1, true), "byte {byte}");
        }
    }

    #[test]
    fn a_refused_bulk_write_keeps_its_bytes_for_the_next_try() {
        let (mut f, want) = feed();
        let mut l = HostLink::new(Board {
            full: Some(1),
            ..Board::default()
        });
        let e = send_all(&mut l, &mut f).unwrap_err();
        assert!(!e.in_doubt(), "{e}");
        assert_eq!(f.free, 0, "the free count is read again");
        f.free = 512;
        send_all(&mut l, &mut f).unwrap();
        assert_eq!(decode(&l.into_inner().committed), want);
    }

    #[test]
    fn a_bulk_write_whose_every_copy_is_damaged_loses_the_stream() {
        let (mut f, _) = feed();
        let mut l = HostLink::new(Board {
            damage: (2..5).map(|c| (c, 40)).collect(),
            ..Board::default()
        });
        let e = send_all(&mut l, &mut f).unwrap_err();
        assert!(e.in_doubt(), "{e}");
        let why = f.lost.clone().unwrap_or_default();
        assert!(why.contains("after 200 was lost"), "{why}");
        assert_eq!(
            l.into_inner().committed.len(),
            200,
            "two frames of 100 bytes"
        );
    }
}
