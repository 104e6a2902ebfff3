//! The RTL's reference model: `ms_calc.v` operation by operation, in exact integer
//! arithmetic (u128 holds the radicand, see [`crate::Widths::wx`]).
//!
//! A segment is (n steps, d ticks, s = v0 * 2^F * d with v0 in steps/tick). In ticks tau
//! from the segment start its position is p(tau) = (B tau + A tau^2) / C with
//! A = n 2^F - s, B = s d, C = 2^F d^2 (so p(d) = n), and step i happens at the root
//! tau_i = 2 C i / (B + sqrt(B^2 + 4 A C i)) — DESIGN.md section 2's
//! t_i = 2i / (v0 + sqrt(v0^2 + 2 a i)) in ticks. The edge is the nearest tick to tau_i, found
//! exactly with one integer square root and one division (see `ms_calc.v`): the nearest
//! tick, an exact half tick going to the earlier one, as `multistep_core::int` rounds.
//!
//! This is not `multistep_core::int`'s operation sequence (a 128 x 128 -> 256-bit multiply,
//! a correction step): with integer segment registers (n, d, s) the radicand fits 114 bits
//! and the rounding is exact without a correction. The tests prove both give the same
//! edges (`tests/model.rs`).

use crate::{CoreParams, HdlError};
use multistep_core::Segment;

/// One segment as the core's registers hold it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SegRegs {
    /// Steps (>= 1).
    pub n: u32,
    /// Duration in ticks.
    pub d: u32,
    /// Start speed v0 * 2^F * d (v0 in steps/tick).
    pub s: u32,
}

/// One axis's move: direction and up to `segments` segments.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AxisMove {
    pub dir: bool,
    pub segs: Vec<SegRegs>,
}

/// Floor square root and remainder, two bits per round like `ms_isqrt.v`.
pub fn isqrt(x: u128) -> (u128, u128) {
    let (mut q, mut r) = (0u128, 0u128);
    for k in (0..64).rev() {
        r = (r << 2) | ((x >> (2 * k)) & 3);
        let t = (q << 2) | 1;
        q <<= 1;
        if r >= t {
            r -= t;
            q |= 1;
        }
    }
    (q, r)
}

impl SegRegs {
    /// The segment-local edge of step `i` (1..=n): `ms_calc.v`'s sequence, the nearest
    /// tick to the exact step time `ceil(tau_i - 1/2)`.
    pub fn local_edge(&self, i: u32, frac_bits: u32) -> u64 {
        let (n, d, s, i) = (self.n as u128, self.d as u128, self.s as u128, i as u128);
        let n_sh = n << frac_bits;
        let (aneg, amag) = if s > n_sh {
            (true, s - n_sh)
        } else {
            (false, n_sh - s)
        };
        let b = s * d; // mul s*d
        let dd = d * d; // mul d*d
        let bb = b * b; // mul B*B
        let ai = amag * i; // mul |A|*i
        let aidd = ai * dd; // mul |A|i*d^2
        let di = d * i; // mul d*i
        let acx = aidd << (frac_bits + 2); // 4 |A| C i
        let x = if aneg { bb - acx } else { bb + acx };
        let (root, rem) = isqrt(x);
        let ceil = root + u128::from(rem != 0);
        let (num, den) = if amag == 0 {
            (2 * di + n - 1, 2 * n)
        } else if aneg {
            (b + amag - root - 1, 2 * amag)
        } else {
            (ceil - b + amag - 1, 2 * amag)
        };
        (num / den) as u64
    }

    /// Checks the segment against the core's widths and speed range (<= 1/4 step per tick,
    /// never reversing).
    pub fn check(&self, p: &CoreParams, index: usize) -> Result<(), HdlError> {
        let err = |reason: String| HdlError::Segment { index, reason };
        let q = 1u128 << p.frac_bits;
        let (n, d, s) = (self.n as u128, self.d as u128, self.s as u128);
        if self.n == 0 || n >= 1 << p.step_bits {
            return Err(err(format!("steps {} not in 1..2^{}", self.n, p.step_bits)));
        }
        if self.d == 0 || d >= 1 << p.tick_bits {
            return Err(err(format!("ticks {} not in 1..2^{}", self.d, p.tick_bits)));
        }
        if s >= 1 << (p.tick_bits + p.frac_bits) {
            return Err(err(format!("start speed register {} too wide", self.s)));
        }
        // end speed register 2 n 2^F - s: the segment must not reverse
        if 2 * n * q < s {
            return Err(err("end speed would be negative".into()));
        }
        if 4 * s > q * d || 4 * (2 * n * q - s) > q * d {
            return Err(err("faster than 1/4 step per tick".into()));
        }
        Ok(())
    }

    /// From a core segment (v0 steps/s, duration s, steps) at `clock_hz`, rounding d and s.
    pub fn from_core(seg: &Segment, clock_hz: f64, frac_bits: u32) -> SegRegs {
        let d = (seg.duration * clock_hz).round();
        let s = (seg.v0 / clock_hz * f64::from(1u32 << frac_bits) * d).round();
        SegRegs {
            n: seg.steps as u32,
            d: d as u32,
            s: s as u32,
        }
    }

    /// The core segment these registers stand for (for cross-checks with the core).
    pub fn to_core(&self, clock_hz: f64, frac_bits: u32) -> Segment {
        let d = f64::from(self.d);
        Segment {
            v0: f64::from(self.s) * clock_hz / (f64::from(1u32 << frac_bits) * d),
            duration: d / clock_hz,
            steps: u64::from(self.n),
        }
    }
}

impl AxisMove {
    /// Segments given by (steps, ticks) that each start at the previous one's end speed
    /// (rounded to the start-speed register), the first at `s0`.
    pub fn chained(dir: bool, s0: u32, parts: &[(u32, u32)], frac_bits: u32) -> AxisMove {
        let mut segs = Vec::with_capacity(parts.len());
        let mut s = u64::from(s0);
        for (k, &(n, d)) in parts.iter().enumerate() {
            if k > 0 {
                let (pn, pd) = parts[k - 1];
                let end = (2 * u64::from(pn) << frac_bits).saturating_sub(s);
                s = (end * u64::from(d) + u64::from(pd) / 2) / u64::from(pd);
            }
            segs.push(SegRegs { n, d, s: s as u32 });
        }
        AxisMove { dir, segs }
    }

    /// Checks every segment and the segment count.
    pub fn check(&self, p: &CoreParams) -> Result<(), HdlError> {
        if self.segs.is_empty() || self.segs.len() > p.segments as usize {
            return Err(HdlError::Segment {
                index: self.segs.len(),
                reason: format!("a move has 1..={} segments", p.segments),
            });
        }
        self.segs
            .iter()
            .enumerate()
            .try_for_each(|(k, s)| s.check(p, k))
    }

    /// Every edge tick of the move (from its start), one per step.
    pub fn edges(&self, frac_bits: u32) -> Vec<u64> {
        let mut out = Vec::new();
        let mut t0 = 0u64;
        for seg in &self.segs {
            out.extend((1..=seg.n).map(|i| t0 + seg.local_edge(i, frac_bits)));
            t0 += u64::from(seg.d);
        }
        out
    }
}
