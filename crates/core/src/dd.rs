//! Double-double arithmetic: a value is the unevaluated sum `hi + lo` of two f64, giving a
//! ~106-bit significand. Algorithms from Dekker (1971), Knuth TAOCP vol. 2 §4.2.2 and
//! Hida, Li & Bailey, "Library for double-double and quad-double arithmetic" (QD, 2007).
//! Used only to settle edges that lie within f64 noise of a half tick.

use crate::real::{fm, Real};
use core::cmp::Ordering;
use core::ops::{Add, Div, Mul, Neg, Sub};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dd {
    pub hi: f64,
    pub lo: f64,
}

#[inline]
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

#[inline]
fn quick_two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    (s, b - (s - a))
}

/// Dekker's split of a into two 26-bit halves (no fused multiply-add needed).
#[inline]
fn split(a: f64) -> (f64, f64) {
    let t = 134_217_729.0 * a; // 2^27 + 1
    let hi = t - (t - a);
    (hi, a - hi)
}

#[inline]
fn two_prod(a: f64, b: f64) -> (f64, f64) {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    (p, ((ah * bh - p) + ah * bl + al * bh) + al * bl)
}

impl Dd {
    pub const ZERO: Dd = Dd { hi: 0.0, lo: 0.0 };
    pub const ONE: Dd = Dd { hi: 1.0, lo: 0.0 };
    // hi: the f64 constant; lo: the next 53 bits (their digits past f64 precision are meant)
    #[allow(clippy::excessive_precision)]
    const LN2: Dd = Dd {
        hi: core::f64::consts::LN_2,
        lo: 2.319_046_813_846_299_558e-17,
    };
    #[allow(clippy::excessive_precision)]
    const PI: Dd = Dd {
        hi: core::f64::consts::PI,
        lo: 1.224_646_799_147_353_207e-16,
    };
    #[allow(clippy::excessive_precision)]
    const HALF_PI: Dd = Dd {
        hi: core::f64::consts::FRAC_PI_2,
        lo: 6.123_233_995_736_766_036e-17,
    };

    #[inline]
    pub const fn new(x: f64) -> Dd {
        Dd { hi: x, lo: 0.0 }
    }

    /// The exact product of two f64.
    #[inline]
    pub fn mul_f64(a: f64, b: f64) -> Dd {
        let (hi, lo) = two_prod(a, b);
        Dd { hi, lo }
    }

    #[inline]
    fn scale(self, s: f64) -> Dd {
        // exact for powers of two
        Dd {
            hi: self.hi * s,
            lo: self.lo * s,
        }
    }

    /// Nearest integer, ties to +∞ (floor(x + ½)), as f64.
    pub fn round_half_up(self) -> f64 {
        let h = self + Dd::new(0.5);
        let f = fm::floor(h.hi);
        if f == h.hi {
            // hi is an integer: the fraction lives in lo
            if h.lo < 0.0 {
                f - 1.0
            } else {
                f
            }
        } else {
            f
        }
    }

    fn taylor_expm1_small(r: Dd) -> Dd {
        // |r| ≤ ln2/2/512: nine terms reach 1e-34.
        let mut term = r;
        let mut sum = r;
        let mut n = 2.0;
        while n <= 11.0 {
            term = term * r / Dd::new(n);
            sum = sum + term;
            n += 1.0;
        }
        sum
    }

    /// Returns (e^x − 1 for the reduced argument, k) with e^x = (s + 1)·2^k.
    fn exp_parts(self) -> (Dd, i32) {
        let k = fm::floor(self.hi / Self::LN2.hi + 0.5);
        let r = (self - Self::LN2 * Dd::new(k)).scale(1.0 / 512.0);
        let mut s = Self::taylor_expm1_small(r);
        for _ in 0..9 {
            // (1+s)^2 − 1 = 2s + s²
            s = s.scale(2.0) + s * s;
        }
        (s, k as i32)
    }

    fn sin_cos_taylor(x: Dd) -> (Dd, Dd) {
        // |x| ≤ π/4; 30 terms are far below 1e-32.
        let x2 = x * x;
        let mut sin = x;
        let mut cos = Dd::ONE;
        let mut ts = x;
        let mut tc = Dd::ONE;
        let mut n = 1.0;
        while n < 30.0 {
            ts = -(ts * x2) / Dd::new((n + 1.0) * (n + 2.0));
            tc = -(tc * x2) / Dd::new(n * (n + 1.0));
            sin = sin + ts;
            cos = cos + tc;
            n += 2.0;
        }
        (sin, cos)
    }

    fn sin_cos(self) -> (Dd, Dd) {
        let k = fm::floor(self.hi / Self::HALF_PI.hi + 0.5);
        let r = self - Self::HALF_PI * Dd::new(k);
        let (s, c) = Self::sin_cos_taylor(r);
        match (k as i64).rem_euclid(4) {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }
}

impl Add for Dd {
    type Output = Dd;
    #[inline]
    fn add(self, b: Dd) -> Dd {
        let (s, e) = two_sum(self.hi, b.hi);
        let (t, f) = two_sum(self.lo, b.lo);
        let (s, e) = quick_two_sum(s, e + t);
        let (hi, lo) = quick_two_sum(s, e + f);
        Dd { hi, lo }
    }
}

impl Neg for Dd {
    type Output = Dd;
    #[inline]
    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
}

impl Sub for Dd {
    type Output = Dd;
    #[inline]
    fn sub(self, b: Dd) -> Dd {
        self + (-b)
    }
}

impl Mul for Dd {
    type Output = Dd;
    #[inline]
    fn mul(self, b: Dd) -> Dd {
        let (p, e) = two_prod(self.hi, b.hi);
        let (hi, lo) = quick_two_sum(p, e + (self.hi * b.lo + self.lo * b.hi));
        Dd { hi, lo }
    }
}

impl Div for Dd {
    type Output = Dd;
    fn div(self, b: Dd) -> Dd {
        let q1 = self.hi / b.hi;
        let r = self - b * Dd::new(q1);
        let q2 = r.hi / b.hi;
        let r = r - b * Dd::new(q2);
        let q3 = r.hi / b.hi;
        let (hi, lo) = quick_two_sum(q1, q2);
        Dd { hi, lo } + Dd::new(q3)
    }
}

impl PartialOrd for Dd {
    fn partial_cmp(&self, o: &Dd) -> Option<Ordering> {
        match self.hi.partial_cmp(&o.hi) {
            Some(Ordering::Equal) => self.lo.partial_cmp(&o.lo),
            c => c,
        }
    }
}

impl Real for Dd {
    #[inline]
    fn from_f64(x: f64) -> Self {
        Dd::new(x)
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self.hi + self.lo
    }
    fn sqrt(self) -> Self {
        if self.hi <= 0.0 {
            return Dd::ZERO;
        }
        // One Newton step on the f64 root (QD's dd_real::sqrt).
        let x = 1.0 / fm::sqrt(self.hi);
        let ax = self.hi * x;
        let ax_dd = Dd::new(ax);
        let corr = (self - Dd::mul_f64(ax, ax)).hi * (x * 0.5);
        ax_dd + Dd::new(corr)
    }
    fn exp(self) -> Self {
        let (s, k) = self.exp_parts();
        (s + Dd::ONE).scale(pow2(k))
    }
    fn exp_m1(self) -> Self {
        let (s, k) = self.exp_parts();
        if k == 0 {
            s
        } else {
            (s + Dd::ONE).scale(pow2(k)) - Dd::ONE
        }
    }
    fn sin(self) -> Self {
        self.sin_cos().0
    }
    fn cos(self) -> Self {
        self.sin_cos().1
    }
    fn pi() -> Self {
        Self::PI
    }
}

fn pow2(k: i32) -> f64 {
    // 2^k for the range exp can produce without overflow
    let k = k.clamp(-1074, 1023);
    if k >= -1022 {
        f64::from_bits(((k + 1023) as u64) << 52)
    } else {
        f64::from_bits(1u64 << (k + 1074))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dd_identities() {
        let third = Dd::ONE / Dd::new(3.0);
        let back = third * Dd::new(3.0) - Dd::ONE;
        assert!(back.to_f64().abs() < 1e-31);
        let two = Dd::new(2.0).sqrt();
        assert!((two * two - Dd::new(2.0)).to_f64().abs() < 1e-31);
        // e^1 to 32 digits: 2.71828182845904523536028747135266
        let e = Dd::ONE.exp();
        assert_eq!(e.hi, core::f64::consts::E);
        assert!((e.lo - 1.445_646_891_729_250_2e-16).abs() < 1e-30);
        // sin(π) = 0 to dd precision; cos(π/3) = ½
        assert!(Dd::PI.sin().to_f64().abs() < 1e-31);
        let c = (Dd::PI / Dd::new(3.0)).cos() - Dd::new(0.5);
        assert!(c.to_f64().abs() < 1e-31);
        let m = Dd::new(1e-10).exp_m1() - Dd::new(1e-10);
        assert!((m.to_f64() - 5.000_000_000_166_667e-21).abs() < 1e-35);
    }

    #[test]
    fn round_half_up_uses_low_word() {
        let x = Dd {
            hi: 2.5,
            lo: -1e-20,
        };
        assert_eq!(x.round_half_up(), 2.0);
        let x = Dd { hi: 2.5, lo: 1e-20 };
        assert_eq!(x.round_half_up(), 3.0);
        assert_eq!(Dd::new(2.5).round_half_up(), 3.0);
    }
}
