//! The constant-jerk piece of an S-curve ramp in integers: every step's nearest tick by the
//! exactness test itself, evaluated exactly at half ticks.
//!
//! A limits-mode S-curve (the 3rd-order curve seed 003 compares against: jerk ±J or 0 per
//! piece) has pieces `p(τ) = p0 + c1·τ + c2·τ² + c3·τ³`. A cubic has no closed-form root
//! cheap enough to take per step, so step i's edge is found as the least tick e, from
//! the last edge on, whose upper half tick has reached the step: `p((e + ½)/f) ≥ i`. That
//! is DESIGN.md §1's `p((e − ½)/f) < i ≤ p((e + ½)/f)` (p rises on the piece), an exact half
//! tick going to the earlier tick.
//!
//! # The test in integers
//! With the common scale 2^S that makes `p0, c1, c2, c3` integers `P0, C1, C2, C3`, and
//! `t0 = m/2^s0`: at tick e the upper half tick is `τ = w/D` with `D = h·f`, `h = 2^(s0+1)`
//! and the integer `w = 2^s0·(2e + 1) − 2f·m`. So `p ≥ i` is, times `2^S·D³ > 0`,
//!
//! `N_i(e) = C3·w³ + C2·D·w² + C1·D²·w + (P0 − i·2^S)·D³ ≥ 0`.
//!
//! Around a reference tick `e_r` (the piece's start, `⌊f·t0⌋`), `w = h·d + w_r` with
//! `d = e − e_r`, and `N_i` is a cubic in d with integer coefficients
//! - `A3 = C3·h³`,
//! - `A2 = h²·(3C3·w_r + C2·D)`,
//! - `A1 = h·(3C3·w_r² + 2C2·D·w_r + C1·D²)`,
//! - `A0(i) = C3·w_r³ + C2·D·w_r² + C1·D²·w_r + P0·D³ − i·K`, `K = 2^S·D³`.
//!
//! Dividing by `g = 2^z` (z the fewest trailing zeros of A1, A2, A3, K) with `A0` rounded
//! down keeps the sign: `A + A0 ≥ 0 ⟺ A/g + ⌊A0/g⌋ ≥ 0` when g divides A. Per step:
//! `A0 −= K` (one add), then Horner in d, `((A3·d + A2)·d + A1)·d + A0` (three multiplies by
//! the 64-bit |d|, four adds, in two's complement on as many 64-bit limbs as the piece
//! needs, checked on entry), for each tick tried.
//!
//! # The search
//! The caller passes a guess (the edges' quadratic extrapolation: edge times are smooth,
//! so it is usually right or one tick off); the search probes the guess and its neighbour,
//! gallops by doubling strides when they are not enough (a ramp's first steps) and
//! bisects the bracket, so a step costs two evaluations when the guess is right.

use super::track::{places, scaled, split, Si, W};
use crate::piece::Law;
use crate::profile::Profile;

/// Most 64-bit limbs of a per-step value (512 bits).
const LIMBS: usize = 8;

/// A signed integer in two's complement on `n ≤ LIMBS` limbs (little-endian; the limbs
/// above `n` are ignored).
type Tc = [u64; LIMBS];

fn tc(x: &Si) -> Option<Tc> {
    if x.mag.bits_vartime() > 64 * LIMBS as u32 - 2 {
        return None;
    }
    let b = x.mag.to_le_bytes();
    let mut v = [0u64; LIMBS];
    for (k, limb) in v.iter_mut().enumerate() {
        let mut w = [0u8; 8];
        w.copy_from_slice(&b[8 * k..8 * k + 8]);
        *limb = u64::from_le_bytes(w);
    }
    if x.neg {
        negate(&mut v, LIMBS);
    }
    Some(v)
}

#[inline(always)]
fn negate(v: &mut Tc, n: usize) {
    let mut carry = 1u64;
    for limb in v.iter_mut().take(n) {
        let (s, c) = (!*limb).overflowing_add(carry);
        *limb = s;
        carry = c as u64;
    }
}

/// `acc = acc·m + b` modulo 2^(64n) (exact while the value fits: checked on entry).
#[inline(always)]
fn mul_add(acc: &mut Tc, m: u64, b: &Tc, n: usize) {
    let (mut mc, mut ac) = (0u128, false);
    for k in 0..n {
        let t = acc[k] as u128 * m as u128 + mc;
        mc = t >> 64;
        let (s1, c1) = (t as u64).overflowing_add(b[k]);
        let (s2, c2) = s1.overflowing_add(ac as u64);
        acc[k] = s2;
        ac = c1 | c2;
    }
}

#[inline(always)]
fn sub_assign(a: &mut Tc, b: &Tc, n: usize) {
    let mut borrow = false;
    for k in 0..n {
        let (d1, b1) = a[k].overflowing_sub(b[k]);
        let (d2, b2) = d1.overflowing_sub(borrow as u64);
        a[k] = d2;
        borrow = b1 | b2;
    }
}

/// ⌊x/2^z⌋ of a signed value (a negative x rounds towards −∞).
fn shr_floor(x: Si, z: u32) -> Si {
    let mut mag = x.mag.shr_vartime(z);
    if x.neg && mag.shl_vartime(z) != x.mag {
        mag = mag.wrapping_add(&W::ONE);
    }
    Si {
        neg: x.neg && mag != W::ZERO,
        mag,
    }
}

/// One cubic piece's per-step state (see the module docs).
#[derive(Clone, Copy, Debug)]
pub(super) struct Cubic {
    /// A3, A2, A1 (for d ≥ 0) and −A3, A2, −A1 (for d < 0, Horner in |d|), reduced by g.
    pos: [Tc; 3],
    neg: [Tc; 3],
    /// ⌊A0(i)/g⌋ of the next step, and K/g.
    a0: Tc,
    k: Tc,
    e_r: u64,
    /// Limbs in use.
    n: usize,
    /// Ticks the search may try: `[0, hi]`, with `|e − e_r|` within the checked widths.
    hi: u64,
}

impl Cubic {
    /// Piece `k` of `profile` (c4 = 0) on a clock of `clock` Hz, its next step being `i`;
    /// edges up to `hi` ticks. `None`: not a cubic piece or too wide for 512 bits.
    pub(super) fn enter(profile: &Profile, clock: u64, k: usize, i: u64, hi: u64) -> Option<Cubic> {
        let p = profile.piece(k);
        let Law::Poly { c1, c2, c3, c4 } = p.law else {
            return None;
        };
        if c4 != 0.0 {
            return None;
        }
        let sc = places(p.p0)?
            .max(places(c1)?)
            .max(places(c2)?)
            .max(places(c3)?);
        let (pp, a1, a2, a3) = (
            scaled(p.p0, sc)?,
            scaled(c1, sc)?,
            scaled(c2, sc)?,
            scaled(c3, sc)?,
        );
        // t0 = m/2^s0
        let (tneg, tm, te) = split(p.t0)?;
        if tneg && tm != 0 {
            return None;
        }
        let (m, s0) = match (tm, te) {
            (0, _) => (Si::ZERO, 0),
            (_, e) if e >= 0 => (Si::pos(W::from_u64(tm)).shl(e as u32)?, 0),
            (_, e) => (Si::pos(W::from_u64(tm)), e.unsigned_abs()),
        };
        let f = Si::from_u128(clock as u128);
        let fm = f.mul(m)?;
        let e_r = super::track::to_u64(&fm.mag.shr_vartime(s0))?;
        let one = Si::pos(W::ONE);
        let h = one.shl(s0 + 1)?;
        let d = h.mul(f)?;
        let w = Si::from_u128(2 * e_r as u128 + 1)
            .shl(s0)?
            .sub(fm.shl(1)?)?;
        let three = Si::from_u128(3);
        let (d2, w2) = (d.mul(d)?, w.mul(w)?);
        let (d3, w3) = (d2.mul(d)?, w2.mul(w)?);
        let c3_3 = three.mul(a3)?;
        let big_a3 = a3.mul(h.mul(h)?.mul(h)?)?;
        let big_a2 = h.mul(h)?.mul(c3_3.mul(w)?.add(a2.mul(d)?)?)?;
        let big_a1 = h.mul(
            c3_3.mul(w2)?
                .add(a2.mul(d)?.mul(w)?.shl(1)?)?
                .add(a1.mul(d2)?)?,
        )?;
        let big_k = d3.shl(sc)?;
        let a0 = a3
            .mul(w3)?
            .add(a2.mul(d)?.mul(w2)?)?
            .add(a1.mul(d2)?.mul(w)?)?
            .add(pp.mul(d3)?)?
            .sub(big_k.mul(Si::from_u128(i as u128))?)?;
        let z = [big_a1, big_a2, big_a3, big_k]
            .iter()
            .filter(|x| !x.is_zero())
            .map(|x| x.mag.trailing_zeros_vartime())
            .min()?;
        let red = |x: Si| shr_floor(x, z);
        let (big_a3, big_a2, big_a1, a0, big_k) =
            (red(big_a3), red(big_a2), red(big_a1), red(a0), red(big_k));
        // widths: every Horner partial sum below 2^(64n − 1) for |d| ≤ dmax and every
        // A0 of the piece's steps (A0 falls by K a step: its extremes are the ends)
        let dmax = hi.max(e_r).saturating_add(1);
        let db = 64 - dmax.leading_zeros();
        let span = profile
            .steps()
            .min(super::track::floor_u64(profile.end_of(k)))
            .saturating_sub(i);
        let a0_last = a0.sub(big_k.mul(Si::from_u128(span as u128))?)?;
        let bits = [
            big_a3.mag.bits_vartime() + 3 * db,
            big_a2.mag.bits_vartime() + 2 * db,
            big_a1.mag.bits_vartime() + db,
            a0.mag.bits_vartime(),
            a0_last.mag.bits_vartime(),
        ]
        .into_iter()
        .max()?
            + 2;
        let n = (bits as usize + 1).div_ceil(64);
        if n > LIMBS {
            return None;
        }
        Some(Cubic {
            pos: [tc(&big_a3)?, tc(&big_a2)?, tc(&big_a1)?],
            neg: [tc(&big_a3.neg())?, tc(&big_a2)?, tc(&big_a1.neg())?],
            a0: tc(&a0)?,
            k: tc(&big_k)?,
            e_r,
            n,
            hi,
        })
    }

    /// Whether the upper half tick of tick e has reached the current step: `N_i(e) ≥ 0`.
    #[inline(always)]
    fn reached(&self, e: u64) -> bool {
        let (c, m) = if e >= self.e_r {
            (&self.pos, e - self.e_r)
        } else {
            (&self.neg, self.e_r - e)
        };
        let n = self.n;
        let mut acc = c[0];
        mul_add(&mut acc, m, &c[1], n);
        mul_add(&mut acc, m, &c[2], n);
        mul_add(&mut acc, m, &self.a0, n);
        acc[n - 1] >> 63 == 0
    }

    /// The next step's edge: the least tick from `lo` (the last edge) whose upper half
    /// tick has reached it, searched from `guess`; `hi` (the ramp's end) when none has.
    pub(super) fn edge(&mut self, lo: u64, guess: u64) -> u64 {
        let hi = self.hi.max(lo);
        let g = guess.clamp(lo, hi);
        // below: a tick known not reached (lo − 1 stands for every tick before lo);
        // above: a tick known reached (hi + 1: none up to hi)
        let (mut below, mut above) = (None::<u64>, hi + 1);
        if self.reached(g) {
            above = g;
            let mut step = 1u64;
            loop {
                match g.checked_sub(step).filter(|&c| c >= lo) {
                    None => break,
                    Some(c) if self.reached(c) => above = c,
                    Some(c) => {
                        below = Some(c);
                        break;
                    }
                }
                step = step.saturating_mul(2);
            }
        } else {
            below = Some(g);
            let mut step = 1u64;
            loop {
                match g.checked_add(step).filter(|&c| c <= hi) {
                    None => break,
                    Some(c) if self.reached(c) => {
                        above = c;
                        break;
                    }
                    Some(c) => below = Some(c),
                }
                step = step.saturating_mul(2);
            }
        }
        // bisect (below, above]: below None is lo − 1
        let mut b = below.map_or(lo, |x| x + 1); // least candidate
        while b < above {
            let mid = b + (above - b) / 2;
            if self.reached(mid) {
                above = mid;
            } else {
                b = mid + 1;
            }
        }
        let n = self.n;
        let k = self.k;
        sub_assign(&mut self.a0, &k, n);
        above.min(hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twos_complement_horner() {
        let n = 2;
        let v = |x: i128| {
            tc(&if x < 0 {
                Si::from_u128(x.unsigned_abs()).neg()
            } else {
                Si::from_u128(x as u128)
            })
            .unwrap()
        };
        let back = |a: &Tc| ((a[1] as u128) << 64 | a[0] as u128) as i128;
        let mut acc = v(-7);
        mul_add(&mut acc, 1000, &v(3), n);
        assert_eq!(back(&acc), -6997);
        mul_add(&mut acc, 1 << 40, &v(-5), n);
        assert_eq!(back(&acc), -6997 * (1i128 << 40) - 5);
        sub_assign(&mut acc, &v(-6997 * (1i128 << 40)), n);
        assert_eq!(back(&acc), -5);
        let s = shr_floor(Si::from_u128(7).neg(), 1);
        assert!(s.neg && s.mag == W::from_u64(4));
        let s = shr_floor(Si::from_u128(8).neg(), 2);
        assert!(s.neg && s.mag == W::from_u64(2));
    }
}
