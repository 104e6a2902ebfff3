//! The host's side of the link over any byte stream ([`HostLink`]: one request at a time,
//! exactly once), and the cross-board start over several links.

use crate::error::io_err;
use crate::{
    status_bits, AxisReg, AxisState, BoardReg, BuildId, BulkWrite, LinkError, Reg, RegWrite,
    ReplyDecoder, Request, REPLY_LEN,
};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Each board's clock relative to the first board's at one instant (the SYNC edge): board
/// j's `SyncTick` subtracted from board 0's, in ticks (modulo 2^32, as a signed offset).
pub fn sync_offsets(sync_ticks: &[u32]) -> Vec<i64> {
    let first = sync_ticks.first().copied().unwrap_or(0);
    sync_ticks
        .iter()
        .map(|&t| i64::from(first.wrapping_sub(t) as i32))
        .collect()
}

/// Starts the groups armed on several boards (wired to one SYNC line) at one instant:
/// polls every board's `Status` (at most `polls` reads each, calling `pause` between
/// them) until its armed group is ready, writes `Fire` to board `firer`, and returns every
/// board's `SyncTick`. A board whose group is not armed, or not ready after `polls`
/// reads, is an error before anything fires.
pub fn fire_armed<T: std::io::Read + std::io::Write>(
    links: &mut [HostLink<T>],
    firer: usize,
    polls: u32,
    mut pause: impl FnMut(),
) -> Result<Vec<u32>, LinkError> {
    if firer >= links.len() {
        return Err(LinkError::Move(format!(
            "board {firer} fires, but there are {} boards",
            links.len()
        )));
    }
    for (i, l) in links.iter_mut().enumerate() {
        let mut n = 0;
        loop {
            let s = l.read(Reg::Board(BoardReg::Status))?;
            if s & status_bits::ARMED == 0 {
                return Err(LinkError::Move(format!("board {i}: no group armed")));
            }
            if s & status_bits::READY != 0 {
                break;
            }
            n += 1;
            if n >= polls {
                return Err(LinkError::Move(format!(
                    "board {i}: the armed group is not ready after {polls} reads"
                )));
            }
            pause();
        }
    }
    links[firer].write(Reg::Board(BoardReg::Fire), 1)?;
    links
        .iter_mut()
        .map(|l| l.read(Reg::Board(BoardReg::SyncTick)))
        .collect()
}

/// How often [`HostLink`] sends a frame again whose reply was damaged or did not come.
pub const RETRANSMITS: u32 = 2;

/// A random nonzero session token for [`HostLink::claim`].
pub fn session_token() -> u32 {
    use std::hash::{BuildHasher, Hasher};
    // the standard library seeds `RandomState` from the OS's randomness
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    h.write_u128(
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos()),
    );
    h.write_u32(std::process::id());
    let v = h.finish();
    ((v ^ (v >> 32)) as u32).max(1)
}

/// The host's side of the link over any byte stream (a serial port, a socket): one
/// request at a time, each answered before the next; sequence numbers are checked. Read
/// timeouts are the stream's own (e.g. `serialport`'s timeout).
///
/// Exactly once: a request whose reply is damaged, refused as a bad CRC or does not come
/// in time is sent again as the same frame (same seq), up to [`RETRANSMITS`] times. The
/// board answers a retransmission of the frame it executed last from that frame's reply
/// (`ms_link.v`), so a write whose reply was lost is never executed twice, and its answer
/// is the one the board gave. An error after the retransmissions leaves the request's
/// outcome unknown ([`LinkError::in_doubt`]).
///
/// Urgent requests: one frame is atomic, but whoever sends many in a row (a stream's
/// code, a poll's reads) checks [`HostLink::urgent`] between them and lets go of the link
/// when it is set, so that an e-stop waits for one frame, not for the whole batch.
#[derive(Debug)]
pub struct HostLink<T> {
    io: T,
    seq: u8,
    decoder: ReplyDecoder,
    /// Frames sent again.
    pub retransmitted: u64,
    /// Set by whoever waits to send something urgent (see above).
    urgent: Option<Arc<AtomicBool>>,
}

impl<T: std::io::Read + std::io::Write> HostLink<T> {
    pub fn new(io: T) -> Self {
        HostLink {
            io,
            seq: 0,
            decoder: ReplyDecoder::new(),
            retransmitted: 0,
            urgent: None,
        }
    }

    /// The link with `flag` as its urgent flag (see [`HostLink::urgent`]).
    pub fn with_urgent(mut self, flag: Option<Arc<AtomicBool>>) -> Self {
        self.urgent = flag;
        self
    }

    /// An urgent request waits for the link: a batch of frames should end here.
    pub fn urgent(&self) -> bool {
        self.urgent
            .as_ref()
            .is_some_and(|f| f.load(Ordering::SeqCst))
    }

    /// Reads the board's session register and writes `token` (nonzero) to it. Returns
    /// what was read: a board that kept its state since this host last claimed it with
    /// token T reads T; 0 after configuration or a reset.
    pub fn claim(&mut self, token: u32) -> Result<u32, LinkError> {
        let before = self.read(Reg::Board(BoardReg::Session))?;
        self.write(Reg::Board(BoardReg::Session), token)?;
        Ok(before)
    }

    /// The stream back.
    pub fn into_inner(self) -> T {
        self.io
    }

    /// Sends `req` (its seq replaced by the link's next) and returns the reply's data, or
    /// the board's refusal, a reply that does not decode, or an I/O error.
    pub fn transact(&mut self, mut req: Request) -> Result<u32, LinkError> {
        req.seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        self.exchange(&req.encode(), req)
    }

    /// Sends a bulk write of `data` to `reg` (an axis's `StreamData`) and returns the
    /// reply's data: the free bytes left in the axis's stream buffer.
    pub fn bulk(&mut self, reg: Reg, data: &[u8]) -> Result<u32, LinkError> {
        let b = BulkWrite {
            seq: self.seq,
            addr: reg.addr(),
            data: data.to_vec(),
        };
        let frame = b.encode()?;
        self.seq = self.seq.wrapping_add(1);
        // the reply is checked against a request of the same seq and address
        self.exchange(&frame, Request::write(b.seq, reg, 0))
    }

    /// Sends `frame` and waits for the reply to `req` (its seq), sending the same frame
    /// again while the reply is damaged or late.
    fn exchange(&mut self, frame: &[u8], req: Request) -> Result<u32, LinkError> {
        let mut tries = 0;
        loop {
            match self.exchange_once(frame, req) {
                Err(e) if e.in_doubt() && tries < RETRANSMITS => {
                    tries += 1;
                    self.retransmitted += 1;
                }
                r => return r,
            }
        }
    }

    fn exchange_once(&mut self, frame: &[u8], req: Request) -> Result<u32, LinkError> {
        self.io.write_all(frame).map_err(io_err)?;
        self.io.flush().map_err(io_err)?;
        let mut buf = [0u8; REPLY_LEN];
        loop {
            let n = self.io.read(&mut buf).map_err(io_err)?;
            if n == 0 {
                return Err(LinkError::Io("the stream closed".into()));
            }
            // A reply with another seq answers an earlier request whose reply never came
            // in time (a host killed mid-request, a timeout, a retransmission): skipped.
            let got: Vec<_> = self
                .decoder
                .push(&buf[..n])
                .into_iter()
                .filter(|r| !matches!(r, Ok(y) if y.seq != req.seq))
                .collect();
            // our reply, even behind the remains of a damaged one
            let found = match got.iter().position(|r| r.is_ok()) {
                Some(i) => got.into_iter().nth(i),
                None => got.into_iter().next(),
            };
            if let Some(r) = found {
                // what is left of a bad frame must not be taken for the next reply
                self.decoder = ReplyDecoder::new();
                return r?.answer(&req);
            }
        }
    }

    pub fn read(&mut self, reg: Reg) -> Result<u32, LinkError> {
        self.transact(Request::read(0, reg))
    }

    pub fn write(&mut self, reg: Reg, data: u32) -> Result<(), LinkError> {
        self.transact(Request::write(0, reg, data)).map(|_| ())
    }

    /// Writes in order; stops at the first refusal.
    pub fn write_all(&mut self, writes: &[RegWrite]) -> Result<(), LinkError> {
        writes.iter().try_for_each(|w| self.write(w.reg, w.data))
    }

    pub fn build_id(&mut self) -> Result<BuildId, LinkError> {
        let mut r = |b: BoardReg| self.read(Reg::Board(b));
        let (id, c, w) = (r(BoardReg::Id)?, r(BoardReg::Config)?, r(BoardReg::Widths)?);
        let (hz, baud) = (r(BoardReg::ClockHz)?, r(BoardReg::Baud)?);
        BuildId::decode(id, c, w, hz, baud)
    }

    pub fn axis_state(&mut self, axis: u32) -> Result<AxisState, LinkError> {
        AxisState::decode(self.read(Reg::Axis(axis, AxisReg::State))?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AxisRun, Command, Reply, Status};

    /// A register file behind the framing, answering like the board (unknown registers
    /// refused), optionally corrupting its replies. As `ms_link.v`, it answers the same
    /// frame as the one it executed last from that frame's reply.
    struct FakeBoard {
        regs: std::collections::HashMap<u16, u32>,
        out: Vec<u8>,
        corrupt: bool,
        /// Replies so far; the one of this index is damaged, of `lose` never sent.
        replies: usize,
        damage: Option<usize>,
        lose: Option<usize>,
        /// The last executed frame and its reply.
        last: Option<(Vec<u8>, Reply)>,
        /// Every write executed.
        executed: Vec<(u16, u32)>,
    }

    impl std::io::Write for FakeBoard {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            let req = Request::decode(b).expect("the host sends whole frames");
            let reply = match &self.last {
                Some((f, r)) if f == b => *r,
                _ => {
                    let (status, data) = match (req.command, self.regs.get(&req.addr)) {
                        (_, None) => (Status::BadAddress, 0),
                        (Command::Read, Some(&v)) => (Status::Ok, v),
                        (Command::Write, Some(_)) => {
                            self.regs.insert(req.addr, req.data);
                            self.executed.push((req.addr, req.data));
                            (Status::Ok, 0)
                        }
                        (Command::Bulk, Some(_)) => (Status::BadCommand, 0),
                    };
                    let r = Reply {
                        seq: req.seq,
                        status,
                        data,
                    };
                    self.last = Some((b.to_vec(), r));
                    r
                }
            };
            let mut f = reply.encode();
            let n = self.replies;
            self.replies += 1;
            if self.corrupt || self.damage == Some(n) {
                f[4] ^= 1;
            }
            if self.lose == Some(n) {
                return Ok(b.len());
            }
            self.out.extend_from_slice(&[0x00, 0x13]); // noise before the reply
            self.out.extend_from_slice(&f);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl std::io::Read for FakeBoard {
        fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
            if self.out.is_empty() {
                // a serial port's read timeout
                return Err(std::io::ErrorKind::TimedOut.into());
            }
            // a few bytes at a time, as a serial port delivers them
            let n = self.out.len().min(b.len()).min(4);
            b[..n].copy_from_slice(&self.out[..n]);
            self.out.drain(..n);
            Ok(n)
        }
    }

    fn fake(corrupt: bool) -> HostLink<FakeBoard> {
        let regs = [
            (0x00, 0x4D53_0010),
            (0x01, 0x0204_0201),
            (0x02, 0x1418_8044),
            (0x03, 50_000_000),
            (0x04, 3_000_000),
            (0x0B, 0),
            (0x2010, 0x109),
        ]
        .into_iter()
        .collect();
        HostLink::new(FakeBoard {
            regs,
            out: Vec::new(),
            corrupt,
            replies: 0,
            damage: None,
            lose: None,
            last: None,
            executed: Vec::new(),
        })
    }

    #[test]
    fn a_write_whose_reply_is_damaged_or_lost_is_executed_once() {
        let start = Reg::Board(BoardReg::Start);
        for (damage, lose) in [(Some(0), None), (None, Some(0)), (Some(0), Some(1))] {
            let mut l = fake(false);
            l.io.regs.insert(start.addr(), 0);
            l.io.damage = damage;
            l.io.lose = lose;
            assert_eq!(l.write(start, 1), Ok(()), "{damage:?} {lose:?}");
            assert_eq!(
                l.io.executed,
                vec![(start.addr(), 1)],
                "{damage:?} {lose:?}"
            );
            // the next write of the same value is a new request: executed
            l.write(start, 1).unwrap();
            assert_eq!(l.io.executed.len(), 2);
        }
        // every reply damaged: an error after the retransmissions, executed once
        let mut l = fake(true);
        l.io.regs.insert(start.addr(), 0);
        let e = l.write(start, 1).unwrap_err();
        assert!(e.in_doubt(), "{e}");
        assert_eq!(
            (l.io.executed.len(), l.retransmitted),
            (1, u64::from(RETRANSMITS))
        );
    }

    #[test]
    fn a_claim_reads_the_session_and_writes_the_token() {
        let mut l = fake(false);
        l.io.regs.insert(0x05, 0);
        assert_eq!(l.claim(0xABCD), Ok(0));
        assert_eq!(l.claim(0x1234), Ok(0xABCD));
        assert_ne!(session_token(), 0);
    }

    #[test]
    fn sync_offsets_are_signed_and_wrap() {
        assert_eq!(sync_offsets(&[1000, 0, 2000]), vec![0, 1000, -1000]);
        assert_eq!(sync_offsets(&[5, u32::MAX - 4]), vec![0, 10]);
        assert!(sync_offsets(&[]).is_empty());
    }

    #[test]
    fn fire_armed_waits_for_ready_then_fires_one_board() {
        let board = |status: u32, tick: u32| {
            let mut l = fake(false);
            l.io.regs.insert(0x06, status);
            l.io.regs.insert(0x14, 0);
            l.io.regs.insert(0x15, tick);
            l
        };
        let armed = status_bits::PENDING | status_bits::ARMED | status_bits::SYNC_LINE;
        let ready = armed | status_bits::READY;
        let mut ls = vec![board(ready, 7000), board(ready, 1000)];
        assert_eq!(fire_armed(&mut ls, 1, 3, || {}), Ok(vec![7000, 1000]));
        assert_eq!(ls[1].io.regs[&0x14], 1, "board 1 fired");
        assert_eq!(ls[0].io.regs[&0x14], 0, "board 0 did not");
        // never ready: polls reads, then an error, nothing fired
        let mut ls = vec![board(ready, 0), board(armed, 0)];
        let mut pauses = 0;
        assert!(matches!(
            fire_armed(&mut ls, 0, 3, || pauses += 1),
            Err(LinkError::Move(m)) if m.contains("board 1") && m.contains("not ready")
        ));
        assert_eq!((pauses, ls[0].io.regs[&0x14]), (2, 0));
        // not armed, and a firer out of range
        let mut ls = vec![board(status_bits::SYNC_LINE, 0)];
        assert!(
            matches!(fire_armed(&mut ls, 0, 3, || {}), Err(LinkError::Move(m)) if m.contains("no group armed"))
        );
        assert!(fire_armed(&mut ls, 1, 3, || {}).is_err());
    }

    #[test]
    fn the_urgent_flag_is_read_through_the_link() {
        let flag = Arc::new(AtomicBool::new(false));
        let l = fake(false).with_urgent(Some(flag.clone()));
        assert!(!l.urgent());
        flag.store(true, Ordering::SeqCst);
        assert!(l.urgent());
        assert!(!fake(false).urgent(), "no flag: never urgent");
    }

    #[test]
    fn host_link_reads_writes_and_reports_refusals() {
        let mut l = fake(false);
        let id = l.build_id().unwrap();
        assert_eq!(
            (id.axes, id.step_bits, id.clock_hz, id.version),
            (2, 20, 50_000_000, 0x10)
        );
        l.write(Reg::Board(BoardReg::PulseWidth), 7).unwrap();
        assert_eq!(l.read(Reg::Board(BoardReg::PulseWidth)), Ok(7));
        let st = l.axis_state(1).unwrap();
        assert!(st.busy && st.run == AxisRun::Running && st.hall);
        assert_eq!(
            l.read(Reg::Board(BoardReg::Session)),
            Err(LinkError::Refused {
                addr: 0x05,
                status: Status::BadAddress
            })
        );
        let mut bad = fake(true);
        assert!(matches!(
            bad.read(Reg::Board(BoardReg::Id)),
            Err(LinkError::Crc { .. })
        ));
        assert_eq!(bad.retransmitted, u64::from(RETRANSMITS));
        let mut closed = HostLink::new(std::io::Cursor::new(Vec::<u8>::new()));
        assert!(matches!(
            closed.read(Reg::Board(BoardReg::Id)),
            Err(LinkError::Io(_))
        ));
    }

    #[test]
    fn a_stale_reply_to_an_earlier_request_is_skipped() {
        // The reply to a request of a host that died (seq 200), then the answer to ours.
        let stale = Reply {
            seq: 200,
            status: Status::Ok,
            data: 1,
        };
        let ours = Reply {
            seq: 0,
            status: Status::Ok,
            data: 42,
        };
        let mut bytes = stale.encode().to_vec();
        bytes.extend_from_slice(&ours.encode());
        struct Canned(std::io::Cursor<Vec<u8>>);
        impl std::io::Read for Canned {
            fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
                self.0.read(b)
            }
        }
        impl std::io::Write for Canned {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                Ok(b.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let mut l = HostLink::new(Canned(std::io::Cursor::new(bytes)));
        assert_eq!(l.read(Reg::Board(BoardReg::Session)), Ok(42));
    }
}
