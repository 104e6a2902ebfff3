//! Request and reply frames with their CRC (`rtl/board/ms_link.v`), and the decoder that
//! finds replies in the byte stream from the board. Decoding never panics: every
//! malformed input is a [`LinkError`].

use crate::{LinkError, Reg};

/// First byte of a request.
pub const REQUEST_SYNC: u8 = 0xA5;
/// First byte of a reply.
pub const REPLY_SYNC: u8 = 0x5A;
// The frame sizes are the link model's (`multistep_core::tdm::stream`), defined there once.
pub const REQUEST_LEN: usize = multistep_core::tdm::stream::REQUEST_BYTES as usize;
pub const REPLY_LEN: usize = 9;

const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

/// The CRC of a frame's bytes before its CRC field.
pub fn crc16(bytes: &[u8]) -> u16 {
    CRC16.checksum(bytes)
}

/// Read or write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Command {
    Read = 1,
    Write = 2,
    /// A [`BulkWrite`]'s command byte (never in a [`Request`]).
    Bulk = 3,
}

/// A reply's status (`ms_link.v`, `ms_regs.v`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Ok = 0,
    /// The request's CRC was wrong (nothing executed).
    BadCrc = 1,
    /// Unknown command byte.
    BadCommand = 2,
    /// No such register, or a read of a write-only one / a write of a read-only one.
    BadAddress = 3,
    /// The write would change a running move (or a setting while any axis runs).
    Busy = 4,
    /// The e-stop is latched (start refused) or still active (clear refused).
    Estop = 5,
    /// A value out of range (an axis mask with bits beyond K, an empty start).
    BadValue = 6,
    /// A bulk write larger than the free space of the axis's stream buffer (nothing kept).
    StreamFull = 7,
}

impl Status {
    pub fn from_code(c: u8) -> Result<Status, LinkError> {
        Ok(match c {
            0 => Status::Ok,
            1 => Status::BadCrc,
            2 => Status::BadCommand,
            3 => Status::BadAddress,
            4 => Status::Busy,
            5 => Status::Estop,
            6 => Status::BadValue,
            7 => Status::StreamFull,
            c => return Err(LinkError::StatusCode(c)),
        })
    }
}

/// One request frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request {
    pub seq: u8,
    pub command: Command,
    pub addr: u16,
    /// The value written (0 for a read).
    pub data: u32,
}

impl Request {
    pub fn read(seq: u8, reg: Reg) -> Request {
        Request {
            seq,
            command: Command::Read,
            addr: reg.addr(),
            data: 0,
        }
    }

    pub fn write(seq: u8, reg: Reg, data: u32) -> Request {
        Request {
            seq,
            command: Command::Write,
            addr: reg.addr(),
            data,
        }
    }

    pub fn encode(&self) -> [u8; REQUEST_LEN] {
        let mut f = [0u8; REQUEST_LEN];
        f[0] = REQUEST_SYNC;
        f[1] = self.seq;
        f[2] = self.command as u8;
        f[3..5].copy_from_slice(&self.addr.to_le_bytes());
        f[5..9].copy_from_slice(&self.data.to_le_bytes());
        let c = crc16(&f[..9]);
        f[9..].copy_from_slice(&c.to_be_bytes());
        f
    }

    /// Decodes one request frame (what the board's parser accepts).
    pub fn decode(f: &[u8]) -> Result<Request, LinkError> {
        let f = frame(f, REQUEST_LEN, REQUEST_SYNC, "request")?;
        let command = match f[2] {
            1 => Command::Read,
            2 => Command::Write,
            c => return Err(LinkError::Command(c)),
        };
        Ok(Request {
            seq: f[1],
            command,
            addr: u16::from_le_bytes([f[3], f[4]]),
            data: u32::from_le_bytes([f[5], f[6], f[7], f[8]]),
        })
    }
}

/// Most bytes in one bulk write.
pub const BULK_MAX: usize = multistep_core::tdm::stream::BULK_MAX as usize;
/// A bulk write's frame bytes besides its data.
pub const BULK_OVERHEAD: usize = multistep_core::tdm::stream::BULK_OVERHEAD as usize;

/// A bulk write: up to [`BULK_MAX`] bytes for one register (an axis's `StreamData`) in one
/// frame of `len` + [`BULK_OVERHEAD`] bytes, answered by one [`Reply`] whose data is the
/// buffer's free bytes after it (status `StreamFull` if it did not fit: nothing is kept).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BulkWrite {
    pub seq: u8,
    pub addr: u16,
    pub data: Vec<u8>,
}

impl BulkWrite {
    /// The frame, or an error for more than [`BULK_MAX`] bytes.
    pub fn encode(&self) -> Result<Vec<u8>, LinkError> {
        let n = self.data.len();
        if n > BULK_MAX {
            return Err(LinkError::Length {
                what: "bulk write's data",
                need: BULK_MAX,
                got: n,
            });
        }
        let mut f = Vec::with_capacity(n + BULK_OVERHEAD);
        f.extend_from_slice(&[REQUEST_SYNC, self.seq, Command::Bulk as u8]);
        f.extend_from_slice(&self.addr.to_le_bytes());
        f.push(n as u8);
        f.extend_from_slice(&self.data);
        let c = crc16(&f);
        f.extend_from_slice(&c.to_be_bytes());
        Ok(f)
    }

    /// Decodes one bulk frame (what the board's parser accepts).
    pub fn decode(f: &[u8]) -> Result<BulkWrite, LinkError> {
        let n = *f.get(5).ok_or(LinkError::Length {
            what: "bulk write",
            need: BULK_OVERHEAD,
            got: f.len(),
        })? as usize;
        let f = frame(f, n + BULK_OVERHEAD, REQUEST_SYNC, "bulk write")?;
        if f[2] != Command::Bulk as u8 {
            return Err(LinkError::Command(f[2]));
        }
        Ok(BulkWrite {
            seq: f[1],
            addr: u16::from_le_bytes([f[3], f[4]]),
            data: f[6..6 + n].to_vec(),
        })
    }
}

/// Checks length, sync byte and CRC.
fn frame<'a>(f: &'a [u8], len: usize, sync: u8, what: &'static str) -> Result<&'a [u8], LinkError> {
    if f.len() != len {
        return Err(LinkError::Length {
            what,
            need: len,
            got: f.len(),
        });
    }
    if f[0] != sync {
        return Err(LinkError::Sync {
            got: f[0],
            want: sync,
        });
    }
    let want = crc16(&f[..len - 2]);
    let got = u16::from_be_bytes([f[len - 2], f[len - 1]]);
    if got != want {
        return Err(LinkError::Crc { got, want });
    }
    Ok(f)
}

/// One reply frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reply {
    pub seq: u8,
    pub status: Status,
    pub data: u32,
}

impl Reply {
    pub fn encode(&self) -> [u8; REPLY_LEN] {
        let mut f = [0u8; REPLY_LEN];
        f[0] = REPLY_SYNC;
        f[1] = self.seq;
        f[2] = self.status as u8;
        f[3..7].copy_from_slice(&self.data.to_le_bytes());
        let c = crc16(&f[..7]);
        f[7..].copy_from_slice(&c.to_be_bytes());
        f
    }

    pub fn decode(f: &[u8]) -> Result<Reply, LinkError> {
        let f = frame(f, REPLY_LEN, REPLY_SYNC, "reply")?;
        Ok(Reply {
            seq: f[1],
            status: Status::from_code(f[2])?,
            data: u32::from_le_bytes([f[3], f[4], f[5], f[6]]),
        })
    }

    /// The reply's data if it answers `req` with `Ok`.
    pub fn answer(&self, req: &Request) -> Result<u32, LinkError> {
        if self.seq != req.seq {
            return Err(LinkError::Sequence {
                got: self.seq,
                want: req.seq,
            });
        }
        match self.status {
            Status::Ok => Ok(self.data),
            status => Err(LinkError::Refused {
                addr: req.addr,
                status,
            }),
        }
    }
}

/// Splits a byte stream from the board into replies: bytes before a sync byte are
/// skipped; a frame that fails its CRC is reported and the search restarts one byte after
/// its sync byte.
#[derive(Clone, Debug, Default)]
pub struct ReplyDecoder {
    buf: Vec<u8>,
}

impl ReplyDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds `bytes`; returns every complete reply (or error) found so far.
    pub fn push(&mut self, bytes: &[u8]) -> Vec<Result<Reply, LinkError>> {
        self.buf.extend_from_slice(bytes);
        let mut out = Vec::new();
        loop {
            match self.buf.iter().position(|&b| b == REPLY_SYNC) {
                None => {
                    self.buf.clear();
                    break;
                }
                Some(i) => {
                    self.buf.drain(..i);
                }
            }
            if self.buf.len() < REPLY_LEN {
                break;
            }
            match Reply::decode(&self.buf[..REPLY_LEN]) {
                Ok(r) => {
                    self.buf.drain(..REPLY_LEN);
                    out.push(Ok(r));
                }
                Err(e) => {
                    self.buf.drain(..1);
                    out.push(Err(e));
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AxisReg, AxisState};
    use proptest::prelude::*;

    #[test]
    fn crc_is_ccitt_false() {
        // the catalogue's check value
        assert_eq!(crc16(b"123456789"), 0x29B1);
    }

    #[test]
    fn frames_round_trip_and_end_in_a_zero_residue() {
        let r = Request::write(7, Reg::Axis(3, AxisReg::Position), 0xDEAD_BEEF);
        let f = r.encode();
        assert_eq!(f[..5], [0xA5, 7, 2, 0x31, 0x20]);
        assert_eq!(crc16(&f), 0, "the CRC appended high byte first leaves 0");
        assert_eq!(Request::decode(&f), Ok(r));
        let y = Reply {
            seq: 7,
            status: Status::Busy,
            data: 5,
        };
        assert_eq!(Reply::decode(&y.encode()), Ok(y));
        assert_eq!(
            y.answer(&r),
            Err(LinkError::Refused {
                addr: 0x2031,
                status: Status::Busy
            })
        );
    }

    /// A reply that lost a byte on the wire runs into the next one: the decoder reports
    /// the damaged candidate and finds the next reply from the byte after its sync byte,
    /// never skipping a whole frame's length (which would swallow the next reply's start).
    #[test]
    fn a_reply_short_of_a_byte_does_not_hide_the_next() {
        let a = Reply {
            seq: 1,
            status: Status::Ok,
            data: 0x0102_0304,
        };
        let b = Reply {
            seq: 2,
            status: Status::Ok,
            data: 0x0506_0708,
        };
        for lost in 1..REPLY_LEN {
            let mut stream: Vec<u8> = a.encode().to_vec();
            stream.remove(lost);
            stream.extend_from_slice(&b.encode());
            let got = ReplyDecoder::new().push(&stream);
            assert!(got[0].is_err(), "byte {lost} lost: {got:?}");
            assert_eq!(got.last(), Some(&Ok(b)), "byte {lost} lost: {got:?}");
        }
    }

    #[test]
    fn every_single_bit_error_is_caught() {
        let f = Reply {
            seq: 1,
            status: Status::Ok,
            data: 0x1234_5678,
        }
        .encode();
        for i in 0..f.len() * 8 {
            let mut g = f;
            g[i / 8] ^= 1 << (i % 8);
            assert!(Reply::decode(&g).is_err(), "bit {i}");
        }
    }

    proptest! {
        #[test]
        fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..64)) {
            let _ = Request::decode(&bytes);
            let _ = Reply::decode(&bytes);
            let _ = BulkWrite::decode(&bytes);
            let mut d = ReplyDecoder::new();
            let _ = d.push(&bytes);
            let _ = AxisState::decode(u32::from_le_bytes([
                bytes.first().copied().unwrap_or(0), 0, 0, 0]));
        }

        #[test]
        fn decoder_finds_replies_in_noise(
            noise in proptest::collection::vec(any::<u8>().prop_filter("no sync", |b| *b != REPLY_SYNC), 0..20),
            seq in any::<u8>(), data in any::<u32>(), split in 0usize..30,
        ) {
            let r = Reply { seq, status: Status::Ok, data };
            let mut stream = noise.clone();
            stream.extend_from_slice(&r.encode());
            stream.extend_from_slice(&r.encode());
            let mut d = ReplyDecoder::new();
            let split = split.min(stream.len());
            let mut got = d.push(&stream[..split]);
            got.extend(d.push(&stream[split..]));
            let ok: Vec<Reply> = got.into_iter().filter_map(Result::ok).collect();
            prop_assert_eq!(ok, vec![r, r]);
        }

        #[test]
        fn bulk_writes_round_trip(seq in any::<u8>(), addr in any::<u16>(),
                                  data in proptest::collection::vec(any::<u8>(), 0..=BULK_MAX)) {
            let w = BulkWrite { seq, addr, data };
            let f = w.encode().unwrap();
            prop_assert_eq!(f.len(), w.data.len() + BULK_OVERHEAD);
            prop_assert_eq!(BulkWrite::decode(&f), Ok(w));
        }

        #[test]
        fn requests_round_trip(seq in any::<u8>(), addr in any::<u16>(), data in any::<u32>(), wr in any::<bool>()) {
            let r = Request { seq, command: if wr { Command::Write } else { Command::Read }, addr, data };
            prop_assert_eq!(Request::decode(&r.encode()), Ok(r));
        }
    }
}
