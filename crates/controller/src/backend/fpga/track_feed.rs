//! Tracking streams on the board model with replay units: a rate whose steps the replay
//! unit cannot time is refused before anything runs, and a stream that fails anyway halts
//! its own axis while the host goes on reading the rest of the board.

use super::model::{Model, ModelPort};
use super::*;
use multistep_core::{Rate, TrackLimits};
use multistep_link::{Reply, Request};
use std::io::{Read, Write};
use std::sync::{Arc, Mutex};

/// Bytes free in each replay unit's buffer.
const FREE: u32 = 4096;

/// The model's port, with replay units: bulk writes (stream code) are taken whole and
/// the free count read is always [`FREE`].
struct Streams {
    model: ModelPort,
    out: Vec<u8>,
}

impl Write for Streams {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        let reply = |seq| Reply {
            seq,
            status: Status::Ok,
            data: FREE,
        };
        if b.get(2) == Some(&(link::Command::Bulk as u8)) {
            self.out.extend_from_slice(&reply(b[1]).encode());
            return Ok(b.len());
        }
        let free = Reg::Axis(0, AxisReg::StreamFree).addr();
        match Request::decode(b) {
            Ok(r) if r.command == link::Command::Read && r.addr & 0xF00F == free => {
                self.out.extend_from_slice(&reply(r.seq).encode());
                Ok(b.len())
            }
            _ => self.model.write(b),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Read for Streams {
    fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
        if self.out.is_empty() {
            return self.model.read(b);
        }
        let n = self.out.len().min(b.len());
        b[..n].copy_from_slice(&self.out[..n]);
        self.out.drain(..n);
        Ok(n)
    }
}

fn connect() -> (FpgaBackend, Arc<Mutex<Model>>) {
    let m = Arc::new(Mutex::new(Model::default()));
    let port = m.clone();
    let open: Opener = Box::new(move || {
        Ok(Box::new(Streams {
            model: ModelPort(port.clone()),
            out: Vec::new(),
        }) as Box<dyn Port>)
    });
    let mut b = FpgaBackend::with_opener("model".into(), open, 2).expect("the model answers");
    assert!(b.tracking().is_ok(), "the model has replay units");
    (b, m)
}

fn tracker(rate: u128, amax: f64) -> Box<TrackSource> {
    let limits = TrackLimits { amax, jmax: None };
    Box::new(TrackSource::new(50e6, limits, Rate::new(rate, 1).unwrap(), 0).unwrap())
}

fn events(b: &mut FpgaBackend, now: u64) -> Vec<(usize, PinEvent)> {
    b.begin_advance();
    std::iter::from_fn(|| b.poll(now)).collect()
}

/// `track X 1000` then `track X 2`: a step of 0.5 s is more than the 2^24 − 1 ticks (0.34 s
/// at 50 MHz) the replay unit times, so the change is refused (error:19) and the axis goes
/// on at 1000 steps/s; 3 steps/s still fits, and so does its stop.
#[test]
fn a_rate_the_replay_unit_cannot_time_is_refused_up_front() {
    let (mut b, _m) = connect();
    b.start_source(0, tracker(1000, 20_000.0), 1, 0).unwrap();
    let src = b.tracker(0).unwrap();
    let e = src.set_rate(Rate::new(2, 1).unwrap()).unwrap_err();
    assert_eq!(e.code(), 19, "{e}");
    let text = e.to_string();
    assert!(text.contains("at least 2.9803 steps/s"), "{text}");
    assert_eq!(
        src.rate(),
        Rate::new(1000, 1).unwrap(),
        "still at the old rate"
    );
    src.set_rate(Rate::new(3, 1).unwrap()).unwrap();
    src.set_rate(Rate::ZERO).unwrap();
    // from rest too, and a ramp whose first step from rest is too long (amax 1: 1.4 s)
    let e = b.start_source(1, tracker(2, 20_000.0), 1, 0).unwrap_err();
    assert_eq!(e.code(), 19, "{e}");
    let e = b.start_source(1, tracker(1000, 1.0), 1, 0).unwrap_err();
    assert!(e.to_string().contains("an amax that leaves rest"), "{e}");
}

/// A source whose step `bad` comes 2^25 ticks after the one before (1 kHz otherwise).
struct LongStep {
    next: u64,
    last: u64,
    bad: u64,
}

impl LongStep {
    fn period(&self) -> u64 {
        if self.next == self.bad {
            1 << 25
        } else {
            50_000
        }
    }
}

impl StepSource for LongStep {
    fn peek(&mut self) -> Option<u64> {
        Some(self.last + self.period())
    }
    fn take(&mut self) {
        self.last += self.period();
        self.next += 1;
    }
    fn speed_at(&self, _tick: u64) -> f64 {
        1000.0
    }
    fn end_tick(&self) -> u64 {
        u64::MAX
    }
    fn steps_left(&self) -> u64 {
        0
    }
}

/// The failing stream halts its axis (a fault event, the reason on stderr) and the host
/// still reads every axis of the board in the same poll.
#[test]
fn a_stream_that_fails_halts_its_axis_and_the_board_is_still_read() {
    let (mut b, m) = connect();
    let src = LongStep {
        next: 1,
        last: 0,
        bad: 120,
    };
    b.start_source(0, Box::new(src), 1, 0).unwrap();
    assert!(events(&mut b, 1).is_empty(), "the first 50 ms are coded");
    assert_eq!(m.lock().unwrap().busy, 1);
    // the board made 100 steps: the host codes on to step 120 at the next poll
    m.lock().unwrap().position[0] = 100;
    assert!(events(&mut b, 2).is_empty());
    m.lock().unwrap().position[1] = 777;
    let ev = events(&mut b, 3);
    assert!(
        matches!(&ev[..], [(0, PinEvent::Late { why }), (0, PinEvent::End { .. })]
            if why.starts_with("bad_code:") && why.contains("step 120")),
        "{ev:?}"
    );
    assert_eq!(m.lock().unwrap().busy, 0, "axis 0 halted");
    assert_eq!((b.count(0), b.count(1)), (100, 777), "every axis read");
}

/// A tracker that comes to rest after `steps` steps at 1 kHz.
struct Rests {
    steps: u64,
    made: u64,
}

impl StepSource for Rests {
    fn peek(&mut self) -> Option<u64> {
        (self.made < self.steps).then_some((self.made + 1) * 50_000)
    }
    fn take(&mut self) {
        self.made += 1;
    }
    fn speed_at(&self, _tick: u64) -> f64 {
        1000.0
    }
    fn end_tick(&self) -> u64 {
        u64::MAX
    }
    fn steps_left(&self) -> u64 {
        self.steps - self.made
    }
}

/// An open-ended stream is armed for the most steps and, once its source comes to rest,
/// closed at exactly the steps coded: the axis ends there, not a step beyond.
#[test]
fn a_tracking_stream_at_rest_is_closed_at_its_last_coded_step() {
    let (mut b, m) = connect();
    let src = Rests { steps: 40, made: 0 };
    b.start_source(0, Box::new(src), 1, 0).unwrap();
    events(&mut b, 1);
    let written = m.lock().unwrap().stream_steps[0].clone();
    assert!(written.ends_with(&[u32::MAX, 40]), "{written:?}");
}

/// A tracking stream's code runs ahead of the board's count: a stop asked for now makes
/// those steps before its ramp, so `steps_ahead` counts at least them (a stop for a soft
/// limit begins that much earlier).
#[test]
fn a_tracking_streams_lead_counts_as_steps_ahead() {
    let (mut b, _m) = connect();
    b.start_source(0, tracker(20_000, 200_000.0), 1, 0).unwrap();
    events(&mut b, 1);
    let coded = b.axes[0].feed.as_ref().unwrap().coded();
    assert!(coded > 0, "the stream was fed");
    let ahead = b.tracking().unwrap().steps_ahead(0);
    assert!(ahead >= coded, "{ahead} steps ahead, {coded} coded");
    assert_eq!(b.tracking().unwrap().steps_ahead(1), 0, "an idle axis");
}

/// A durable write (an fsync, here 2 s at most) runs beside the thread that holds the
/// board, which keeps the tracking stream fed meanwhile: the board steps on during the
/// write, and its count is read and the code sent on from it before the write ends.
#[test]
fn a_tracking_stream_is_fed_during_a_durable_write() {
    let (mut b, m) = connect();
    b.start_source(0, tracker(2_000, 200_000.0), 1, 0).unwrap();
    for _ in 0..3 {
        events(&mut b, 1);
    }
    let before = b.axes[0].feed.as_ref().unwrap().coded();
    let mut waited = None;
    b.during_write(&mut || {
        let reads = |m: &Arc<Mutex<Model>>| m.lock().unwrap().position_reads[0];
        m.lock().unwrap().position[0] = 1_000;
        let seen = reads(&m);
        let end = std::time::Instant::now() + std::time::Duration::from_secs(2);
        // two reads after the board stepped on: one whole top-up came between them
        while reads(&m) < seen + 2 && std::time::Instant::now() < end {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
        waited = Some(reads(&m) - seen);
    });
    let after = b.axes[0].feed.as_ref().unwrap().coded();
    assert!(waited >= Some(2), "{waited:?} reads during the write");
    // 50 ms at 2000 steps/s ahead of 0, then of 1000
    assert!(
        before <= 110 && after >= 1_016,
        "{before} then {after} steps coded"
    );
    let ahead = b.tracking().unwrap().steps_ahead(0);
    assert!(ahead >= after - 1_000, "{ahead} steps ahead, {after} coded");
}
