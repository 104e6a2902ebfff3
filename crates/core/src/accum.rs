//! The constant-speed step accumulator: at constant speed the edges are
//! `e_j = ⌊(y + j·w) / den⌋` for integers y, w, den, which a quotient and a remainder
//! follow with two additions and one compare per step (no multiply, divide or root).
//!
//! Both generators plan `(y, w, den)` exactly from their piece: the integer datapath from
//! its cruise kernel ([`IntPiece`](crate::int::IntPiece)), the float generator from the
//! exact rational value of the f64 piece ([`float_cruise`]). The nearest tick with an exact
//! half tick going to the earlier tick, `⌈x − ½⌉`, is built into `y`, so ties cost nothing.

use crate::real::fm;
use crypto_bigint::U256;

/// Quotient and remainder of `(y + j·w) / den`, advanced one step at a time.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepAccumulator {
    /// `⌊(y + j·w) / den⌋` and the remainder, for the current j.
    q: u64,
    r: u64,
    /// `⌊w / den⌋` and `w mod den`.
    dq: u64,
    dr: u64,
    den: u64,
}

impl StepAccumulator {
    /// The accumulator at `⌊y / den⌋` with steps of `w / den`; `None` unless `den` is
    /// below 2^63 (so `r + dr` cannot overflow) and the quotients fit in u64.
    pub fn new(y: u128, w: u128, den: u128) -> Option<Self> {
        if den == 0 || den >> 63 != 0 {
            return None;
        }
        Some(StepAccumulator {
            q: u64::try_from(y / den).ok()?,
            r: (y % den) as u64,
            dq: u64::try_from(w / den).ok()?,
            dr: (w % den) as u64,
            den: den as u64,
        })
    }

    /// The current edge; moves on to the next step.
    #[inline(always)]
    pub fn next_edge(&mut self) -> u64 {
        let e = self.q;
        self.r += self.dr;
        self.q = self.q.wrapping_add(self.dq);
        if self.r >= self.den {
            self.r -= self.den;
            self.q = self.q.wrapping_add(1);
        }
        e
    }

    /// The accumulator two steps at a time from the step after this one: `w/den` doubled.
    #[inline(always)]
    fn doubled_from_next(&self) -> (Self, Self) {
        // 2·dr < 2^64 (dr < den < 2^63): one carry at most
        let (dr, carry) = (2 * self.dr, (2 * self.dr >= self.den) as u64);
        let step = StepAccumulator {
            dq: self.dq.wrapping_mul(2).wrapping_add(carry),
            dr: dr - carry * self.den,
            ..*self
        };
        let mut odd = *self;
        odd.next_edge();
        (
            step,
            StepAccumulator {
                q: odd.q,
                r: odd.r,
                ..step
            },
        )
    }

    /// Folds the next `n` edges into `init` and moves past them. Even and odd steps run
    /// on two accumulators of twice the step, so the two carry chains interleave instead
    /// of every edge waiting for the one before.
    #[inline(always)]
    pub fn fold_run<B>(&mut self, n: u64, init: B, mut f: impl FnMut(B, u64) -> B) -> B {
        let mut out = init;
        let (mut even, mut odd) = self.doubled_from_next();
        for _ in 0..n / 2 {
            out = f(out, even.next_edge());
            out = f(out, odd.next_edge());
        }
        // the even lane stands at step 2·⌊n/2⌋ from here
        (self.q, self.r) = (even.q, even.r);
        if n % 2 == 1 {
            out = f(out, self.next_edge());
        }
        out
    }

    /// Writes the next `out.len()` edges and moves past them ([`StepAccumulator::fold_run`]).
    #[inline(always)]
    pub fn fill_run(&mut self, out: &mut [u64]) {
        let (mut even, mut odd) = self.doubled_from_next();
        let mut pairs = out.chunks_exact_mut(2);
        for pair in &mut pairs {
            pair[0] = even.next_edge();
            pair[1] = odd.next_edge();
        }
        (self.q, self.r) = (even.q, even.r);
        if let [last] = pairs.into_remainder() {
            *last = self.next_edge();
        }
    }

    /// The current edge and the least and greatest of the `n − 1` periods between it
    /// and the `n − 1` edges after it (`None` for n ≤ 1), without moving: every period
    /// is `⌊w/den⌋` plus one on a carry, and the `n − 1` steps carry
    /// `⌊(r + (n − 1)·(w mod den))/den⌋` times.
    pub fn period_range(&self, n: u64) -> Option<(u64, u64)> {
        let steps = n.checked_sub(1).filter(|&k| k > 0)?;
        let carries = (self.r as u128 + steps as u128 * self.dr as u128) / self.den as u128;
        let lo = if carries < steps as u128 {
            self.dq
        } else {
            self.dq + 1
        };
        let hi = if carries > 0 { self.dq + 1 } else { self.dq };
        Some((lo, hi))
    }

    /// The edge `n` steps after the current one (without moving).
    pub fn edge_after(&self, n: u64) -> u64 {
        let r = self.r as u128 + n as u128 * self.dr as u128;
        let q = self.q as u128 + n as u128 * self.dq as u128 + r / self.den as u128;
        q as u64
    }
}

/// `x = m·2^e` with m odd (or 0), for finite x ≥ 0.
fn dyadic(x: f64) -> (u64, i32) {
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    let frac = bits & ((1u64 << 52) - 1);
    let (m, e) = if exp == 0 {
        (frac, -1074)
    } else {
        (frac | 1 << 52, exp - 1075)
    };
    if m == 0 {
        return (0, 0);
    }
    let tz = m.trailing_zeros();
    (m >> tz, e + tz as i32)
}

/// `m·2^(e + k)` as U256 (e + k ≥ 0, the result below 2^256 by the caller's bounds).
fn scaled(m: u128, e: i32, k: i32) -> U256 {
    U256::from_u128(m).shl_vartime((e + k) as u32)
}

/// A constant-speed piece of the float generator as an exact rational edge sequence.
///
/// The piece is `p(t) = p0 + c1·(t − t0)`, with its f64 values taken exactly (they are the
/// profile), at an integer clock f. Step i happens at `t0 + (i − p0)/c1`, so with
/// `c1 = C/2^a` (C an integer) and `W = f·2^a`,
/// `C·(f·t_i − ½) = B + W·i`, `B = f·C·t0 − W·p0 − C/2`, and the edge
/// `⌈f·t_i − ½⌉ = ⌈(B + W·i)/C⌉ = ⌊(⌊B⌋ + W·i + C − 1 + [B ∉ ℤ]) / C⌋`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FloatCruise {
    /// `⌊B⌋ + C − 1 + [B ∉ ℤ]`.
    base: i128,
    w: u128,
    den: u128,
}

impl FloatCruise {
    /// The line `⌊(y + (i − first)·w)/den⌋` (an integer cruise, i the absolute step).
    pub(crate) fn from_line(y: u128, w: u128, den: u128, first: u64) -> Option<FloatCruise> {
        let base = i128::try_from(y)
            .ok()?
            .checked_sub(i128::try_from(w.checked_mul(first as u128)?).ok()?)?;
        Some(FloatCruise { base, w, den })
    }

    /// The accumulator at step `i` (absolute, 1-based).
    pub fn at(&self, i: u64) -> Option<StepAccumulator> {
        let y = (self.w.checked_mul(i as u128)? as i128).checked_add(self.base)?;
        StepAccumulator::new(u128::try_from(y).ok()?, self.w, self.den)
    }
}

/// The exact edge sequence of the constant-speed piece `(t0, p0, c1)` at `clock` Hz, or
/// `None` when the clock is not an integer or the exact values need more bits than the
/// accumulator has (the generator then keeps its general path).
pub fn float_cruise(t0: f64, p0: f64, c1: f64, clock: f64) -> Option<FloatCruise> {
    let ok = |x: f64| x.is_finite() && x >= 0.0;
    if !(ok(t0) && ok(p0) && ok(c1) && c1 > 0.0 && fm::floor(clock) == clock) {
        return None;
    }
    if !(clock >= 1.0 && clock < (1u64 << 53) as f64) {
        return None;
    }
    let f = clock as u128;
    let (mc, ec) = dyadic(c1);
    let (c, a) = if ec >= 0 {
        if ec > 62 || (mc as u128) << ec >> 62 != 0 {
            return None;
        }
        ((mc as u128) << ec, 0)
    } else {
        (mc as u128, -ec)
    };
    if a > 64 || c >> 62 != 0 {
        return None;
    }
    let w = f.checked_shl(a as u32).filter(|w| w >> 120 == 0)?;
    // both parts of B stay below 2^116, and their fraction needs k ≤ 135 bits
    let (ft, wp) = (clock * c as f64 * t0, w as f64 * p0);
    if !(ft < (1u128 << 115) as f64 && wp < (1u128 << 115) as f64) {
        return None;
    }
    let (mt, et) = dyadic(t0);
    let (mp, ep) = dyadic(p0);
    let k = 1.max(-et).max(-ep);
    if k > 135 {
        return None;
    }
    // B·2^k = pos − neg, both non-negative and below 2^252
    let pos = U256::from_u128(f * c).wrapping_mul(&scaled(mt as u128, et, k));
    let neg = U256::from_u128(w)
        .wrapping_mul(&scaled(mp as u128, ep, k))
        .wrapping_add(&U256::from_u128(c).shl_vartime((k - 1) as u32));
    let mask = U256::ONE.shl_vartime(k as u32).wrapping_sub(&U256::ONE);
    let (d, negative) = if pos >= neg {
        (pos.wrapping_sub(&neg), false)
    } else {
        (neg.wrapping_sub(&pos), true)
    };
    let whole = d.shr_vartime(k as u32);
    let fractional = d.bitand(&mask) != U256::ZERO;
    if whole.bits() > 120 {
        return None;
    }
    let whole = u128::from_le_bytes(whole.to_le_bytes()[..16].try_into().ok()?) as i128;
    // ⌊B⌋ = whole or −(whole + [fraction])
    let floor_b = if negative {
        -(whole + fractional as i128)
    } else {
        whole
    };
    Some(FloatCruise {
        base: floor_b + c as i128 - 1 + fractional as i128,
        w,
        den: c,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The nearest tick of `f·(t0 + (i − p0)/c1)`, ties down, by exact rationals on
    /// integer inputs: `⌈(2(f·t0n·c1 + f·(i − p0)·t0d)·... ⌉` written directly with
    /// `t0 = t0n/t0d`, `p0 = p0n/p0d`, `c1 = cn/cd`.
    fn reference(t0: (u128, u128), p0: (u128, u128), c1: (u128, u128), f: u128, i: u128) -> u64 {
        // x = f·t0n/t0d + f·(i·p0d − p0n)·cd/(p0d·cn); x − ½ over a common denominator
        let den = t0.1 * p0.1 * c1.0 * 2;
        let num_x = 2 * f * t0.0 * p0.1 * c1.0 + 2 * f * (i * p0.1 - p0.0) * c1.1 * t0.1;
        let num = num_x as i128 - (den / 2) as i128;
        // ⌈num/den⌉
        let q = num.div_euclid(den as i128);
        (q + (num.rem_euclid(den as i128) != 0) as i128) as u64
    }

    #[test]
    fn matches_exact_rationals_with_half_tick_ties() {
        // (t0, p0, c1) as dyadic rationals (num, den) so that f64 holds them exactly
        type Dyadic = (u128, u128);
        let cases: &[(Dyadic, Dyadic, Dyadic)] = &[
            ((0, 1), (0, 1), (32_000, 1)),  // 1562.5 ticks a step: ties every other
            ((1, 64), (3, 4), (32_000, 1)), // offset start, fractional p0
            ((5, 1024), (1001, 8), (20_000_000, 1)), // 2.5 ticks a step
            ((7, 2), (17, 2), (80_001, 256)), // a fractional speed
            ((0, 1), (0, 1), (3, 1)),       // very slow: 16.6 M ticks a step
            ((123, 1), (5, 1), (50_000_000, 1)), // one tick a step, every x − ½ a tie
        ];
        let f = 50_000_000u128;
        for &(t0, p0, c1) in cases {
            let (t0f, p0f, c1f) = (
                t0.0 as f64 / t0.1 as f64,
                p0.0 as f64 / p0.1 as f64,
                c1.0 as f64 / c1.1 as f64,
            );
            let plan = float_cruise(t0f, p0f, c1f, f as f64).expect("fits");
            let i0 = p0.0 / p0.1 + 1;
            let mut acc = plan.at(i0 as u64).unwrap();
            for i in i0..i0 + 5000 {
                let want = reference(t0, p0, c1, f, i);
                assert_eq!(acc.next_edge(), want, "{t0:?} {p0:?} {c1:?} step {i}");
            }
            // windows 2^32 steps on, against the same reference and edge_after
            let far = i0 + (1 << 32);
            let mut acc = plan.at(far as u64).unwrap();
            let start = plan.at(i0 as u64).unwrap();
            assert_eq!(start.edge_after(1 << 32), reference(t0, p0, c1, f, far));
            for i in far..far + 2000 {
                assert_eq!(acc.next_edge(), reference(t0, p0, c1, f, i), "step {i}");
            }
        }
    }

    proptest::proptest! {
        /// Random dyadic pieces (so f64 holds them exactly) and clocks: every edge of a
        /// window equals the exact rational nearest tick, ties down; many speeds put
        /// steps exactly on half ticks (f/c1 with a small odd denominator).
        #[test]
        fn random_pieces_match_exact_rationals(
            t0n in 0u128..1 << 20, t0k in 0u32..12, p0n in 0u128..1 << 20, p0k in 0u32..8,
            cn in 1u128..4096, ck in 0u32..6, f in 1u128..100_000_000, skip in 0u128..1 << 30,
        ) {
            let (t0, p0, c1) = ((t0n, 1u128 << t0k), (p0n, 1u128 << p0k), (cn, 1u128 << ck));
            let fl = |x: (u128, u128)| x.0 as f64 / x.1 as f64;
            let plan = float_cruise(fl(t0), fl(p0), fl(c1), f as f64).expect("fits");
            let i0 = p0.0 / p0.1 + 1 + skip;
            let mut acc = plan.at(i0 as u64).unwrap();
            for i in i0..i0 + 300 {
                proptest::prop_assert_eq!(acc.next_edge(), reference(t0, p0, c1, f, i), "step {}", i);
            }
        }
    }

    proptest::proptest! {
        /// `period_range` is the least and greatest difference of the edges it skips.
        #[test]
        fn period_range_matches_the_edges(
            y in 0u128..1 << 40, w in 1u128..1 << 20, den in 1u128..1 << 20, n in 0u64..300,
        ) {
            let acc = StepAccumulator::new(y, w, den).unwrap();
            let mut a = acc;
            let e: std::vec::Vec<u64> = (0..n).map(|_| a.next_edge()).collect();
            let want = e.windows(2).map(|p| p[1] - p[0]).fold(None, |m, p| match m {
                None => Some((p, p)),
                Some((lo, hi)) => Some((p.min(lo), p.max(hi))),
            });
            proptest::prop_assert_eq!(acc.period_range(n), want);
        }
    }

    proptest::proptest! {
        /// Two lanes of twice the step give the edges one accumulator gives, and leave it
        /// where it would be; dr near den makes the doubled step carry.
        #[test]
        fn runs_are_the_steps_one_at_a_time(
            y in 0u128..1 << 80, w in 1u128..1 << 70, den in 1u128..1 << 63, n in 0u64..300,
            near in proptest::bool::ANY,
        ) {
            let w = if near { w / den * den + den - 1 } else { w };
            let Some(acc) = StepAccumulator::new(y, w, den) else { return Ok(()) };
            let mut one = acc;
            let want: std::vec::Vec<u64> = (0..n).map(|_| one.next_edge()).collect();
            let mut folded = acc;
            let got = folded.fold_run(n, std::vec::Vec::new(), |mut v, e| {
                v.push(e);
                v
            });
            proptest::prop_assert_eq!(&got, &want);
            proptest::prop_assert_eq!(folded, one);
            let mut filled = acc;
            let mut out = std::vec![0u64; n as usize];
            filled.fill_run(&mut out);
            proptest::prop_assert_eq!(&out, &want);
            proptest::prop_assert_eq!(filled, one);
        }
    }

    #[test]
    fn refuses_what_it_cannot_hold_exactly() {
        assert!(float_cruise(0.0, 0.0, 32_000.0, 50e6 + 0.5).is_none());
        assert!(float_cruise(-1.0, 0.0, 32_000.0, 50e6).is_none());
        assert!(float_cruise(0.0, 0.0, 0.0, 50e6).is_none());
        assert!(float_cruise(1e-300, 0.0, 1.0, 50e6).is_none());
        assert!(StepAccumulator::new(0, 1, 1 << 63).is_none());
    }
}
