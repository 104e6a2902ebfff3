//! The UART between the host and the simulated board, bit by bit: host bytes onto the
//! board's `uart_rx` at the host's exact bit time (as a USB-UART sends them), and the
//! board's `uart_tx` sampled back into bytes at the board's own bit time.

use std::collections::VecDeque;

/// Host bytes as levels on `uart_rx`, 8N1, back to back.
#[derive(Clone, Debug)]
pub struct RxLine {
    /// Clock cycles per bit (fractional: the host's rate, not the board's rounded one).
    bit: f64,
    queue: VecDeque<u8>,
    /// The byte on the line: its start (cycles) and bits (start, 8 data, stop).
    cur: Option<(f64, [bool; 10])>,
    /// The end (cycles) of the last byte that left the line.
    last_end: f64,
}

impl RxLine {
    pub fn new(clock_hz: f64, baud: f64) -> RxLine {
        RxLine {
            bit: clock_hz / baud,
            queue: VecDeque::new(),
            cur: None,
            last_end: f64::NEG_INFINITY,
        }
    }

    pub fn push(&mut self, bytes: &[u8]) {
        self.queue.extend(bytes);
    }

    /// A byte on the line or waiting.
    pub fn busy(&self) -> bool {
        self.cur.is_some() || !self.queue.is_empty()
    }

    fn edge(&self, start: f64, j: usize) -> u64 {
        (start + j as f64 * self.bit).round() as u64
    }

    /// The line's level at `cycle`, starting the next byte if the line is free.
    pub fn level(&mut self, cycle: u64) -> bool {
        loop {
            match self.cur {
                None => {
                    let Some(b) = self.queue.pop_front() else {
                        return true;
                    };
                    let mut bits = [true; 10];
                    bits[0] = false;
                    for (i, bit) in bits[1..9].iter_mut().enumerate() {
                        *bit = b >> i & 1 == 1;
                    }
                    self.cur = Some((cycle as f64, bits));
                }
                Some((start, bits)) => {
                    let end = self.edge(start, 10);
                    if cycle >= end {
                        // back to back: the next byte starts where this one ends
                        self.cur = None;
                        self.last_end = end as f64;
                        if let Some(b) = self.queue.pop_front() {
                            let mut nb = [true; 10];
                            nb[0] = false;
                            for (i, bit) in nb[1..9].iter_mut().enumerate() {
                                *bit = b >> i & 1 == 1;
                            }
                            self.cur = Some((start + 10.0 * self.bit, nb));
                        }
                        continue;
                    }
                    let j = (0..10)
                        .rev()
                        .find(|&j| cycle >= self.edge(start, j))
                        .unwrap_or(0);
                    return bits[j];
                }
            }
        }
    }

    /// The next cycle after `cycle` at which the level may change.
    pub fn next_change(&self, cycle: u64) -> u64 {
        match self.cur {
            None => u64::MAX,
            Some((start, _)) => (1..=10)
                .map(|j| self.edge(start, j))
                .find(|&c| c > cycle)
                .unwrap_or(cycle + 1),
        }
    }

    /// The earliest cycle at which a byte can complete on the board's side (the start of
    /// its stop bit; the board samples the bit's middle): infinite with nothing to send.
    pub fn next_byte_end(&self, cycle: u64) -> f64 {
        match self.cur {
            Some((start, _)) => start + 9.0 * self.bit,
            None if !self.queue.is_empty() => cycle as f64 + 9.0 * self.bit,
            None => f64::INFINITY,
        }
    }

    /// The end (cycles) of the last byte that left the line (−∞ before the first).
    pub fn last_end(&self) -> f64 {
        self.last_end
    }

    /// Clock cycles per bit.
    pub fn bit(&self) -> f64 {
        self.bit
    }

    /// Drops every byte not yet on the line.
    pub fn clear_queue(&mut self) {
        self.queue.clear();
    }
}

/// `uart_tx` back into bytes: a falling edge on the idle line starts a frame; bit j is
/// sampled at start + j·div + div/2, as the board's own receiver does.
#[derive(Clone, Debug)]
pub struct TxDecoder {
    div: u64,
    level: bool,
    /// The frame's start cycle and the bits sampled so far.
    frame: Option<(u64, u16, u32)>,
}

impl TxDecoder {
    pub fn new(div: u32) -> TxDecoder {
        TxDecoder {
            div: u64::from(div),
            level: true,
            frame: None,
        }
    }

    pub fn busy(&self) -> bool {
        self.frame.is_some()
    }

    fn sample_at(&self, start: u64, j: u32) -> u64 {
        start + u64::from(j) * self.div + self.div / 2
    }

    /// The cycle by which [`Self::poll`] must be called to finish a frame.
    pub fn deadline(&self) -> u64 {
        match self.frame {
            Some((start, _, _)) => self.sample_at(start, 9),
            None => u64::MAX,
        }
    }

    /// Takes the samples due up to `cycle` (the level unchanged since the last call);
    /// returns a finished byte (frames with a bad stop bit are dropped).
    pub fn poll(&mut self, cycle: u64) -> Option<u8> {
        let (start, mut bits, mut j) = self.frame?;
        while j <= 9 && self.sample_at(start, j) <= cycle {
            if (1..=8).contains(&j) && self.level {
                bits |= 1 << (j - 1);
            }
            if j == 9 {
                self.frame = None;
                return self.level.then_some(bits as u8);
            }
            j += 1;
        }
        self.frame = Some((start, bits, j));
        None
    }

    /// The line took `level` at `cycle` (samples before it used the old level).
    pub fn change(&mut self, cycle: u64, level: bool) -> Option<u8> {
        let done = if cycle > 0 {
            self.poll(cycle - 1)
        } else {
            None
        };
        self.level = level;
        if self.frame.is_none() && !level {
            self.frame = Some((cycle, 0, 1));
        }
        done
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Bytes sent at `bit` cycles per bit, decoded at `div`.
    fn round_trip(bytes: &[u8], bit: f64, div: u32) -> Vec<u8> {
        let mut rx = RxLine::new(bit, 1.0);
        let mut dec = TxDecoder::new(div);
        rx.push(bytes);
        let mut got = Vec::new();
        let mut lvl = true;
        let end = ((bytes.len() + 2) as f64 * 10.0 * bit) as u64;
        for c in 0..end {
            let l = rx.level(c);
            if l != lvl {
                got.extend(dec.change(c, l));
                lvl = l;
            }
            got.extend(dec.poll(c));
        }
        got
    }

    proptest! {
        /// Any bytes, back to back, survive a host bit time up to 2.5 % off the board's.
        #[test]
        fn bytes_survive_a_baud_error(
            bytes in proptest::collection::vec(any::<u8>(), 1..24),
            div in 4u32..40, err in -0.025f64..0.025,
        ) {
            let got = round_trip(&bytes, f64::from(div) * (1.0 + err), div);
            prop_assert_eq!(got, bytes);
        }
    }

    #[test]
    fn bytes_go_out_and_come_back() {
        // the line of RxLine, watched by TxDecoder at the same bit time
        let mut rx = RxLine::new(17e6, 1e6);
        let mut dec = TxDecoder::new(17);
        rx.push(&[0x55, 0xA5, 0x00, 0xFF]);
        let mut got = Vec::new();
        let mut lvl = true;
        for c in 0..17 * 10 * 5 {
            let l = rx.level(c);
            if l != lvl {
                got.extend(dec.change(c, l));
                lvl = l;
            }
            got.extend(dec.poll(c));
        }
        assert_eq!(got, vec![0x55, 0xA5, 0x00, 0xFF]);
        assert!(!rx.busy() && !dec.busy());
    }
}
