//! One constant-acceleration piece in exact integers, and the per-step datapath.
//!
//! In local ticks τ ∈ [0, D] from the piece's start tick `t0`, the position above the
//! piece's start `p0` is `(A·τ + B·τ²) / Den` steps. Step i is the m-th step target
//! `M = Den·i − C` (`C = Den·p0`) and happens at `τ* = 2M / (A + √(A² + 4BM))` (seed 000's
//! merged accel/decel formula, DESIGN.md §2, no cancellation).

use super::isqrt::{isqrt_u128, isqrt_u64};
use super::wide::{mul_wide, shr};
use super::IntError;

/// Bits every per-step intermediate must fit in (checked once when the piece is built).
const LIMIT: u32 = 124;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntPiece {
    /// Start tick and duration in ticks.
    pub t0: u64,
    pub dur: u64,
    /// Position scale: positions are counted in 1/Den steps.
    pub den: u128,
    /// Den × start speed (steps/tick).
    pub a: u128,
    /// Den × half the acceleration (steps/tick²); negative on deceleration.
    pub b: i128,
    /// Den × start position.
    pub c: u128,
    /// `A·D + B·D²`: Den × the steps this piece covers.
    pub m_end: u128,
    /// The radicand `4r = (2·Den·v)²` is kept as `4r / 4^k` (k = 0 unless it needs more
    /// than 126 bits); `4A² / 4^k` rounded down is its per-piece part.
    pub k: u32,
    pub(super) a2k: u128,
}

fn gcd(mut x: u128, mut y: u128) -> u128 {
    while y != 0 {
        (x, y) = (y, x % y);
    }
    x
}

fn fits(x: u128) -> Result<u128, IntError> {
    if x >> LIMIT == 0 {
        Ok(x)
    } else {
        Err(IntError::TooWide)
    }
}

fn mul(x: u128, y: u128) -> Result<u128, IntError> {
    x.checked_mul(y).ok_or(IntError::TooWide).and_then(fits)
}

fn add(x: u128, y: u128) -> Result<u128, IntError> {
    x.checked_add(y).ok_or(IntError::TooWide).and_then(fits)
}

fn bits(x: u128) -> u32 {
    128 - x.leading_zeros()
}

impl IntPiece {
    /// A piece from speed `u/g` to speed `w/g` (steps/tick) over `dur` ticks, starting at
    /// position `s/(2g)` steps and tick `t0`: `Den = 2gD`, `A = 2Du`, `B = w − u`, `C = Ds`,
    /// reduced by their common divisor.
    pub fn new(t0: u64, dur: u64, g: u128, u: u128, w: u128, s: u128) -> Result<Self, IntError> {
        let d = dur as u128;
        let den = mul(mul(2, g)?, d)?;
        let a = mul(mul(2, d)?, u)?;
        let (bm, neg) = if w >= u {
            (w - u, false)
        } else {
            (u - w, true)
        };
        let c = mul(d, s)?;
        let g = gcd(gcd(den, a), gcd(bm, c)).max(1);
        let (den, a, bm, c) = (den / g, a / g, bm / g, c / g);
        // steps covered (×Den): A·D ± B·D²; never negative as the end speed is ≥ 0
        let ad = mul(a, d)?;
        let bd2 = mul(bm, mul(d, d)?)?;
        let m_end = if neg {
            ad.checked_sub(bd2).ok_or(IntError::TooWide)?
        } else {
            add(ad, bd2)?
        };
        // the divisor operand 8M and the check q·(2A + |B|q), q ≤ 2D + 1
        mul(8, m_end)?;
        let q = add(mul(2, d)?, 1)?;
        mul(q, add(mul(2, a)?, mul(bm, q)?)?)?;
        // √(4r) = 2·Den·v ≤ 2V, V = Den × the larger end speed: keep the root under 2^63
        let v = if neg {
            a
        } else {
            add(a, mul(2, mul(bm, d)?)?)?
        };
        let k = (bits(v) + 1).saturating_sub(63);
        if k > 0 {
            // rounding the radicand costs Δ < 2.5·2^k on the root; the estimate stays within
            // one of the answer if X = A + √r ≥ 5·2^k and 3|B| > 5·2^k (3A > 5D·2^k if B = 0)
            let x_min = if neg {
                a
            } else {
                a.max(2 * isqrt_u64(bm.min(u64::MAX as u128) as u64) as u128)
            };
            let unit = 5u128 << k;
            let ok = x_min >= unit
                && if bm == 0 {
                    3 * a > mul(unit, d)?
                } else {
                    3 * bm > unit
                };
            if !ok {
                return Err(IntError::TooWide);
            }
        }
        let (hi, lo) = mul_wide(2 * a, 2 * a);
        let a2k = shr(hi, lo, 2 * k, false);
        let b = if neg { -(bm as i128) } else { bm as i128 };
        Ok(IntPiece {
            t0,
            dur,
            den,
            a,
            b,
            c,
            m_end,
            k,
            a2k,
        })
    }

    /// `M = Den·i − C` for a step i past this piece's start (None if i is at or before it).
    pub fn target(&self, i: u64) -> Option<u128> {
        let m = self.den.checked_mul(i as u128)?.checked_sub(self.c)?;
        (m > 0).then_some(m)
    }

    /// `4r / 4^k = (4A² ± 16|B|M) / 4^k`, rounded down (1 multiply).
    #[inline(always)]
    fn radicand(&self, m: u128) -> u128 {
        let bm = self.b.unsigned_abs();
        let t = if self.k == 0 {
            (bm * m) << 4
        } else {
            let (hi, lo) = mul_wide(bm, m);
            // ⌊16|B|M/4^k⌋ when adding, ⌈…⌉ when subtracting: the sum never rounds up
            let n = 2 * self.k;
            if n >= 4 {
                shr(hi, lo, n - 4, self.b < 0)
            } else {
                lo << (4 - n)
            }
        };
        if self.b >= 0 {
            self.a2k + t
        } else {
            self.a2k.saturating_sub(t)
        }
    }

    /// The edge tick of the step with target `m` (0 < m ≤ m_end): the nearest tick to
    /// `t0 + τ*`, an exact half tick going down (module docs). 3 multiplies, 1 divide,
    /// 1 square root.
    #[inline]
    pub fn edge(&self, m: u128) -> u64 {
        if m == self.m_end {
            return self.t0 + self.dur;
        }
        // s·2^k ≈ √(4r) = 2·Den·v from below; q = ⌈8M / (2A + s·2^k)⌉ − 1 is
        // ⌈2τ*⌉ − 1 or one more
        let s = isqrt_u128(self.radicand(m));
        let (num, div) = ((m << 3) - 1, (self.a << 1) + (s << self.k));
        // same quotient; a 64-bit divide when the operands allow (software speed only)
        let q = if (num | div) >> 64 == 0 {
            (num as u64 / div as u64) as u128
        } else {
            num / div
        };
        // correction: keep q iff q < 2τ*, i.e. p(q/2) < target on the rising branch:
        // A + Bq ≥ 0 and q·(2A + Bq) < 4M (2 multiplies)
        let qi = q as i128;
        let bq = self.b * qi;
        let ok = self.a as i128 + bq >= 0 && qi * ((self.a << 1) as i128 + bq) < (m << 2) as i128;
        let q = if ok { q } else { q - 1 };
        // ⌈τ* − ½⌉ = ⌊⌈2τ*⌉ / 2⌋
        self.t0 + ((q as u64 + 1) >> 1)
    }

    /// Compares `Den·(p(τ) − p0)` at local time `tau2/2` ticks with `m`: exact, for tests.
    pub fn cmp_at_half_ticks(&self, tau2: u128, m: u128) -> core::cmp::Ordering {
        // 4(A·τ + B·τ²) = 2A·tau2 + B·tau2²
        let lhs = 2 * self.a as i128 * tau2 as i128 + self.b * (tau2 * tau2) as i128;
        lhs.cmp(&(4 * m as i128))
    }
}
