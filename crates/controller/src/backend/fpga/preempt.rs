//! A halt waiting for the link goes ahead of a stream being pumped: the pump ends after
//! the frame in flight, so the e-stop's write is the next frame on the link.

use super::pump;
use super::stream::Feed;
use crate::motion::EdgeSource;
use multistep_core::{Family, PhaseMove, Profile};
use multistep_link::{BoardReg, BulkWrite, HostLink, Reg, Reply, Request, Status};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A board that answers every frame and logs it (`None`: a bulk write, `Some(addr)`: a
/// register write or read); it sets `urgent` while the `at`-th bulk frame is in flight,
/// as an e-stop asked for then would.
struct Board {
    log: Vec<Option<u16>>,
    out: Vec<u8>,
    urgent: Arc<AtomicBool>,
    at: usize,
}

impl Write for Board {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        let (seq, entry) = match BulkWrite::decode(b) {
            Ok(w) => (w.seq, None),
            Err(_) => {
                let r = Request::decode(b).map_err(|e| std::io::Error::other(e.to_string()))?;
                (r.seq, Some(r.addr))
            }
        };
        self.log.push(entry);
        if self.log.iter().filter(|e| e.is_none()).count() == self.at {
            self.urgent.store(true, Ordering::SeqCst);
        }
        let reply = Reply {
            seq,
            status: Status::Ok,
            // free bytes: plenty, so the pump would go on to the end of the move
            data: 1 << 20,
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
        super::model::read_out(&mut self.out, b)
    }
}

/// A 20 000-step move's stream: many frames of code.
fn feed() -> Feed {
    let p = Profile::phase(&PhaseMove {
        steps: 20_000,
        accel_time: 0.05,
        cruise_time: 0.2,
        decel_time: 0.05,
        start_speed: 0.0,
        end_speed: 0.0,
        family: Family::Parabolic,
    })
    .expect("a valid move");
    let src = EdgeSource::new(p, 50e6, 0).expect("a valid source");
    let mut f = Feed::new(Box::new(src), 0, 24, false);
    f.buffer = 1 << 20;
    f.free = f.buffer;
    f
}

fn link(at: usize) -> (HostLink<Board>, Arc<AtomicBool>) {
    let urgent = Arc::new(AtomicBool::new(false));
    let board = Board {
        log: Vec::new(),
        out: Vec::new(),
        urgent: urgent.clone(),
        at,
    };
    (
        HostLink::new(board).with_urgent(Some(urgent.clone())),
        urgent,
    )
}

#[test]
fn an_estop_asked_for_mid_stream_is_the_next_frame_on_the_link() {
    let (mut l, _) = link(3);
    let mut f = feed();
    pump(&mut l, &mut f, 0, 0, true).unwrap();
    // the holder lets go and the halt is written
    l.write(Reg::Board(BoardReg::Estop), 1).unwrap();
    let log = l.into_inner().log;
    let estop = Some(Reg::Board(BoardReg::Estop).addr());
    let at = log.iter().position(|e| *e == estop).expect("written");
    // frames 0..3 are the stream's, the third in flight when the halt was asked for
    assert_eq!((at, f.frames), (3, 3), "{log:?}");
    assert!(log[..at].iter().all(Option::is_none), "{log:?}");
}

#[test]
fn without_an_urgent_request_the_stream_is_sent_whole() {
    let (mut l, urgent) = link(usize::MAX);
    let mut f = feed();
    pump(&mut l, &mut f, 0, 0, true).unwrap();
    assert!(!urgent.load(Ordering::SeqCst));
    assert!(f.frames > 10, "{} frames", f.frames);
    assert_eq!(f.pending(), 0, "all the code sent");
}

#[test]
fn a_preload_before_a_start_is_not_cut_short() {
    let (mut l, urgent) = link(2);
    let mut f = feed();
    pump(&mut l, &mut f, 0, 0, false).unwrap();
    assert!(urgent.load(Ordering::SeqCst));
    assert!(f.frames > 10, "{} frames", f.frames);
}
