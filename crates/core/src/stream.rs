//! A lossless byte code for a move's edge schedule, for boards that replay host-computed
//! edges instead of computing them (any profile family: the host runs the exact edge
//! generator, the board only adds up periods).
//!
//! The schedule is the sequence of periods `p0 = t0`, `pi = ti − t(i−1)` of the edge
//! ticks, each in `1..2^24`. It is coded in 4-bit nibbles, the low nibble of a byte first,
//! each period predicted by the one before (0 before the first):
//!
//! | nibble | period |
//! |---|---|
//! | `0` | none: padding (ends an odd nibble count) |
//! | `1`–`13` | the previous period + (nibble − 7), a change of −6..=6 ticks |
//! | `14` | the previous period + the signed 8-bit change in the next 2 nibbles |
//! | `15` | the next 6 nibbles: the period itself (24 bits) |
//!
//! At a steady or slowly changing speed consecutive periods differ by the rounding of the
//! edges to whole ticks (a few ticks), so most steps cost half a byte; steps at low speed,
//! where the period changes fast, cost 1.5 or 3.5 bytes but are few per second. Like the
//! interval/count/add runs of Klipper's stepcompress with a tolerance of 0, nothing is
//! approximated: decoding gives back every tick. `no_std`, no allocation.

/// The widest period: 24 bits.
pub const MAX_PERIOD: u32 = (1 << 24) - 1;

const PAD: u8 = 0;
const SMALL_BIAS: i64 = 7;
const SMALL_MAX: i64 = 6;
const DELTA8: u8 = 14;
const ABS24: u8 = 15;

/// What the code cannot hold, or a byte sequence that is not a schedule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StreamError {
    /// A period outside `1..=MAX_PERIOD` (edges not strictly increasing, or too far apart).
    Period {
        /// The step (0-based) whose period it is.
        step: u64,
        /// The period.
        ticks: u64,
    },
    /// A decoded period outside `1..=MAX_PERIOD`.
    BadCode {
        /// The nibble (0-based) that completed it.
        nibble: u64,
    },
}

impl core::fmt::Display for StreamError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            StreamError::Period { step, ticks } => write!(
                f,
                "step {step}: period of {ticks} ticks not in 1..={MAX_PERIOD}"
            ),
            StreamError::BadCode { nibble } => {
                write!(f, "nibble {nibble}: the code gives a period out of range")
            }
        }
    }
}

/// Encodes periods (or edge ticks) into bytes, handed to a callback as each completes.
#[derive(Clone, Copy, Debug, Default)]
pub struct StreamEncoder {
    prev: u32,
    last_edge: u64,
    steps: u64,
    half: Option<u8>,
    bytes: u64,
}

impl StreamEncoder {
    /// An encoder at the start of a schedule.
    pub fn new() -> Self {
        Self::default()
    }

    /// Bytes completed so far.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// Nibbles coded so far (the last byte is complete when even).
    pub fn nibbles(&self) -> u64 {
        2 * self.bytes + u64::from(self.half.is_some())
    }

    /// Periods coded so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    fn nibble(&mut self, n: u8, out: &mut impl FnMut(u8)) {
        match self.half.take() {
            None => self.half = Some(n),
            Some(lo) => {
                self.bytes += 1;
                out(lo | n << 4);
            }
        }
    }

    /// Codes the next edge at move tick `t` (after the previous one).
    pub fn edge(&mut self, t: u64, out: &mut impl FnMut(u8)) -> Result<(), StreamError> {
        let p = t.wrapping_sub(self.last_edge);
        if t <= self.last_edge && self.steps > 0 {
            return Err(StreamError::Period {
                step: self.steps,
                ticks: 0,
            });
        }
        self.period(p, out)?;
        self.last_edge = t;
        Ok(())
    }

    /// Codes the next period.
    pub fn period(&mut self, p: u64, out: &mut impl FnMut(u8)) -> Result<(), StreamError> {
        if p == 0 || p > u64::from(MAX_PERIOD) {
            return Err(StreamError::Period {
                step: self.steps,
                ticks: p,
            });
        }
        let d = p as i64 - i64::from(self.prev);
        if (-SMALL_MAX..=SMALL_MAX).contains(&d) {
            self.nibble((d + SMALL_BIAS) as u8, out);
        } else if (-128..=127).contains(&d) {
            self.nibble(DELTA8, out);
            let b = d as i8 as u8;
            self.nibble(b & 15, out);
            self.nibble(b >> 4, out);
        } else {
            self.nibble(ABS24, out);
            for k in 0..6 {
                self.nibble((p >> (4 * k)) as u8 & 15, out);
            }
        }
        self.prev = p as u32;
        self.last_edge = self.last_edge.wrapping_add(p);
        self.steps += 1;
        Ok(())
    }

    /// Completes the last byte (with a padding nibble if needed).
    pub fn finish(&mut self, out: &mut impl FnMut(u8)) {
        if self.half.is_some() {
            self.nibble(PAD, out);
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pending {
    Op,
    Delta { got: u8, acc: u32 },
    Abs { got: u8, acc: u32 },
}

/// Decodes bytes back into periods (the board's replay unit, `ms_replay.v`, does the same).
#[derive(Clone, Copy, Debug)]
pub struct StreamDecoder {
    prev: u32,
    edge: u64,
    nibbles: u64,
    pending: Pending,
}

impl Default for StreamDecoder {
    fn default() -> Self {
        StreamDecoder {
            prev: 0,
            edge: 0,
            nibbles: 0,
            pending: Pending::Op,
        }
    }
}

impl StreamDecoder {
    /// A decoder at the start of a schedule.
    pub fn new() -> Self {
        Self::default()
    }

    /// True between periods (not inside a 14 or 15 code).
    pub fn at_boundary(&self) -> bool {
        self.pending == Pending::Op
    }

    /// The tick of the last edge decoded.
    pub fn last_edge(&self) -> u64 {
        self.edge
    }

    fn emit(&mut self, p: i64, out: &mut impl FnMut(u32)) -> Result<(), StreamError> {
        if p < 1 || p > i64::from(MAX_PERIOD) {
            return Err(StreamError::BadCode {
                nibble: self.nibbles,
            });
        }
        self.prev = p as u32;
        self.edge += p as u64;
        out(p as u32);
        Ok(())
    }

    fn nibble(&mut self, n: u8, out: &mut impl FnMut(u32)) -> Result<(), StreamError> {
        let r = match self.pending {
            Pending::Op => match n {
                PAD => Ok(()),
                DELTA8 => {
                    self.pending = Pending::Delta { got: 0, acc: 0 };
                    Ok(())
                }
                ABS24 => {
                    self.pending = Pending::Abs { got: 0, acc: 0 };
                    Ok(())
                }
                _ => self.emit(i64::from(self.prev) + i64::from(n) - SMALL_BIAS, out),
            },
            Pending::Delta { got, acc } => {
                let acc = acc | u32::from(n) << (4 * got);
                if got == 1 {
                    self.pending = Pending::Op;
                    self.emit(i64::from(self.prev) + i64::from(acc as u8 as i8), out)
                } else {
                    self.pending = Pending::Delta { got: 1, acc };
                    Ok(())
                }
            }
            Pending::Abs { got, acc } => {
                let acc = acc | u32::from(n) << (4 * got);
                if got == 5 {
                    self.pending = Pending::Op;
                    self.emit(i64::from(acc), out)
                } else {
                    self.pending = Pending::Abs { got: got + 1, acc };
                    Ok(())
                }
            }
        };
        self.nibbles += 1;
        r
    }

    /// Decodes one byte: 0, 1 or 2 periods to `out`.
    pub fn byte(&mut self, b: u8, out: &mut impl FnMut(u32)) -> Result<(), StreamError> {
        self.nibble(b & 15, out)?;
        self.nibble(b >> 4, out)
    }
}

/// Codes a whole schedule of edge ticks, each byte to `out`; returns the bytes written.
pub fn encode_edges(
    edges: impl IntoIterator<Item = u64>,
    out: &mut impl FnMut(u8),
) -> Result<u64, StreamError> {
    let mut e = StreamEncoder::new();
    for t in edges {
        e.edge(t, out)?;
    }
    e.finish(out);
    Ok(e.bytes())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    fn encode(edges: &[u64]) -> Result<Vec<u8>, StreamError> {
        let mut v = Vec::new();
        encode_edges(edges.iter().copied(), &mut |b| v.push(b))?;
        Ok(v)
    }

    fn decode(bytes: &[u8]) -> Result<Vec<u64>, StreamError> {
        let mut d = StreamDecoder::new();
        let mut ps = Vec::new();
        for &b in bytes {
            d.byte(b, &mut |p| ps.push(p))?;
        }
        let mut t = 0u64;
        Ok(ps
            .into_iter()
            .map(|p| {
                t += u64::from(p);
                t
            })
            .collect())
    }

    #[test]
    fn each_code_and_its_size() {
        // 1000 (absolute, 3.5 bytes), 1003 (+3, half), 900 (−103, 1.5), 900 (0, half)
        let e = [1000, 2003, 2903, 3803];
        let b = encode(&e).unwrap();
        assert_eq!(b.len(), 6, "7 + 1 + 3 + 1 nibbles = 12");
        assert_eq!(b[0] & 15, ABS24);
        assert_eq!(decode(&b).unwrap(), e);
    }

    #[test]
    fn bad_schedules_are_refused() {
        assert!(matches!(
            encode(&[5, 5]),
            Err(StreamError::Period { step: 1, .. })
        ));
        assert!(encode(&[0]).is_err(), "a period of 0");
        assert!(encode(&[1 << 24]).is_err(), "a period wider than 24 bits");
        // a change of −7 from 1: period −6
        assert!(decode(&[0x1F, 0, 0, 0x10]).is_err());
        assert_eq!(decode(&[0x1F, 0, 0, 0]).unwrap(), [1]);
    }

    proptest! {
        #[test]
        fn decode_inverts_encode(ps in proptest::collection::vec(
            prop_oneof![1u64..20, 480u64..520, 1u64..=u64::from(MAX_PERIOD)], 0..300)) {
            let mut t = 0;
            let edges: Vec<u64> = ps.iter().map(|p| { t += p; t }).collect();
            let b = encode(&edges).unwrap();
            prop_assert_eq!(decode(&b).unwrap(), edges);
        }

        #[test]
        fn any_bytes_decode_without_panic(b in proptest::collection::vec(any::<u8>(), 0..200)) {
            if let Ok(e) = decode(&b) {
                // what decodes, re-encodes to a schedule with the same edges
                prop_assert_eq!(decode(&encode(&e).unwrap()).unwrap(), e);
            }
        }
    }
}
