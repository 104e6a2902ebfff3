//! Faults on the link for tests: a damaged reply or request. The host's requests are
//! followed as frames (11 bytes, a bulk write `8 + len`) and the board's replies counted
//! (9 bytes, one per request, in order), so the reply to a chosen request, or a byte of a
//! chosen request, can be damaged.

/// `corrupt-reply BYTE [ADDR]`: the reply to the next request (or the next write to
/// register `ADDR`) gets one bit of its byte `BYTE` (0 ..= 8) flipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CorruptReply {
    pub byte: usize,
    pub addr: Option<u16>,
}

/// `corrupt-rx BYTE [ADDR [TIMES]]`: byte `BYTE` of the host's next request (or of the
/// next write to register `ADDR`, then `BYTE` ≥ 5, past the address) gets one bit flipped
/// on its way to the board; so do the `TIMES − 1` such requests after it (a host's
/// retransmissions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CorruptRx {
    pub byte: usize,
    pub addr: Option<u16>,
    pub times: u32,
}

#[derive(Debug, Default)]
pub struct LinkFaults {
    /// Host bytes of a request not yet complete.
    frame: Vec<u8>,
    requests: u64,
    reply_bytes: u64,
    wanted: Option<CorruptReply>,
    /// The reply (by number) and byte to damage.
    armed: Option<(u64, usize)>,
    rx: Option<CorruptRx>,
}

const REQUEST_SYNC: u8 = 0xA5;
const REPLY_LEN: u64 = multistep_hdl::link::REPLY_LEN as u64;

impl LinkFaults {
    pub fn corrupt(&mut self, c: CorruptReply) {
        self.wanted = Some(c);
    }

    pub fn corrupt_rx(&mut self, c: CorruptRx) {
        self.rx = Some(c);
    }

    /// Bytes the host sends the board: followed as frames, and the one `corrupt-rx`
    /// chose damaged in place.
    pub fn from_host(&mut self, bytes: &mut [u8]) {
        for b in bytes {
            if self.frame.is_empty() && *b != REQUEST_SYNC {
                continue;
            }
            self.frame.push(*b);
            if let Some(c) = self.rx {
                let f = &self.frame;
                let write = f.get(2).is_some_and(|&c| c != 1);
                let to = |a: u16| write && f.len() > 4 && u16::from_le_bytes([f[3], f[4]]) == a;
                if f.len() == c.byte + 1 && c.addr.is_none_or(to) {
                    *b ^= 0x10;
                    self.rx = (c.times > 1).then_some(CorruptRx {
                        times: c.times - 1,
                        ..c
                    });
                }
            }
            let f = &self.frame;
            let len = match f.get(2) {
                Some(3) => f.get(5).map(|&n| 8 + usize::from(n)),
                Some(_) => Some(multistep_hdl::link::REQUEST_LEN),
                None => None,
            };
            if len == Some(f.len()) {
                let write = f[2] != 1;
                let addr = u16::from_le_bytes([f[3], f[4]]);
                if let Some(w) = self.wanted {
                    if w.addr.is_none_or(|a| write && a == addr) {
                        self.armed = Some((self.requests, w.byte));
                        self.wanted = None;
                    }
                }
                self.requests += 1;
                self.frame.clear();
            }
        }
    }

    /// A byte the board sends: returned as the host gets it.
    pub fn to_host(&mut self, b: u8) -> u8 {
        let (reply, at) = (self.reply_bytes / REPLY_LEN, self.reply_bytes % REPLY_LEN);
        self.reply_bytes += 1;
        match self.armed {
            Some((r, byte)) if r == reply && byte as u64 == at => {
                self.armed = None;
                b ^ 0x10
            }
            _ => b,
        }
    }

    /// A reset or a cut link: requests in progress are lost; the replies begun stand.
    pub fn resync(&mut self) {
        self.frame.clear();
        self.requests = self.reply_bytes.div_ceil(REPLY_LEN);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use multistep_hdl::link::{BoardReg, Reg, Request};

    #[test]
    fn the_reply_to_the_chosen_write_is_damaged() {
        let mut f = LinkFaults::default();
        f.corrupt(CorruptReply {
            byte: 4,
            addr: Some(0x09),
        });
        let mut read = Request::read(0, Reg::Board(BoardReg::Start)).encode();
        let mut start = Request::write(1, Reg::Board(BoardReg::Start), 1).encode();
        f.from_host(&mut [0x00]);
        f.from_host(&mut read[..5]);
        f.from_host(&mut read[5..]);
        f.from_host(&mut start);
        let out: Vec<u8> = (0..27).map(|_| f.to_host(0)).collect();
        let hit: Vec<usize> = (0..27).filter(|&i| out[i] != 0).collect();
        assert_eq!(hit, vec![13], "byte 4 of the second reply");
    }

    #[test]
    fn the_chosen_byte_of_the_chosen_request_is_damaged() {
        use multistep_hdl::link::{AxisReg, BulkWrite};
        let mut f = LinkFaults::default();
        f.corrupt_rx(CorruptRx {
            byte: 5,
            addr: Some(Reg::Axis(0, AxisReg::StreamData).addr()),
            times: 1,
        });
        let mut read = Request::read(0, Reg::Axis(0, AxisReg::StreamData)).encode();
        let bulk = BulkWrite {
            seq: 1,
            addr: Reg::Axis(0, AxisReg::StreamData).addr(),
            data: vec![0xA5; 20],
        }
        .encode()
        .unwrap();
        let (r0, b0) = (read, bulk.clone());
        f.from_host(&mut read);
        assert_eq!(read, r0, "a read is not a write");
        let mut b = bulk.clone();
        f.from_host(&mut b[..3]);
        f.from_host(&mut b[3..]);
        let hit: Vec<usize> = (0..b.len()).filter(|&i| b[i] != b0[i]).collect();
        assert_eq!(hit, vec![5]);
        // once only
        let mut again = bulk;
        f.from_host(&mut again);
        assert_eq!(again, b0);
    }
}
