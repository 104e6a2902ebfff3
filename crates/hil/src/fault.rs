//! Faults on the link for tests: a damaged reply. The host's requests are followed as
//! frames (11 bytes, a bulk write `8 + len`) and the board's replies counted (9 bytes,
//! one per request, in order), so the reply to a chosen request can be damaged.

/// `corrupt-reply BYTE [ADDR]`: the reply to the next request (or the next write to
/// register `ADDR`) gets one bit of its byte `BYTE` (0 ..= 8) flipped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CorruptReply {
    pub byte: usize,
    pub addr: Option<u16>,
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
}

const REQUEST_SYNC: u8 = 0xA5;
const REPLY_LEN: u64 = multistep_hdl::link::REPLY_LEN as u64;

impl LinkFaults {
    pub fn corrupt(&mut self, c: CorruptReply) {
        self.wanted = Some(c);
    }

    /// Bytes the board receives from the host.
    pub fn from_host(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if self.frame.is_empty() && b != REQUEST_SYNC {
                continue;
            }
            self.frame.push(b);
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
        let read = Request::read(0, Reg::Board(BoardReg::Start)).encode();
        let start = Request::write(1, Reg::Board(BoardReg::Start), 1).encode();
        f.from_host(&[0x00]);
        f.from_host(&read[..5]);
        f.from_host(&read[5..]);
        f.from_host(&start);
        let out: Vec<u8> = (0..27).map(|_| f.to_host(0)).collect();
        let hit: Vec<usize> = (0..27).filter(|&i| out[i] != 0).collect();
        assert_eq!(hit, vec![13], "byte 4 of the second reply");
    }
}
