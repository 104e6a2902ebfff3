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
//! Only ticks whose upper half tick lies in the piece are tried (a step's exact time lies
//! in its piece; the cubic extended past the piece may turn back). The caller passes a
//! guess, `⌈x⌉` of the quadratic extrapolation x of the last three step times (smooth);
//! the search learns each step's time to 2^-32 tick from the two values around its edge
//! (`N_i(e − 1) < 0 ≤ N_i(e)`, linearly interpolated from their top bits), so the guess
//! is nearly always the edge. The search probes the guess and its neighbour, gallops by
//! doubling strides when they are not enough (a piece's first steps) and bisects the
//! bracket: two evaluations a step when the guess is right. Guesses only order the
//! work; every edge is decided by the signs of `N_i`.

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
        negate_l(&mut v);
    }
    Some(v)
}

/// `acc = acc·m + b` modulo 2^(64L) (exact while the value fits: checked on entry).
#[inline(always)]
fn mul_add<const L: usize>(acc: &mut [u64; L], m: u64, b: &[u64; L]) {
    let (mut mc, mut ac) = (0u128, false);
    for k in 0..L {
        let t = acc[k] as u128 * m as u128 + mc;
        mc = t >> 64;
        let (s1, c1) = (t as u64).overflowing_add(b[k]);
        let (s2, c2) = s1.overflowing_add(ac as u64);
        acc[k] = s2;
        ac = c1 | c2;
    }
}

/// `a −= b` on the first L limbs (a piece's values are read on L limbs only).
fn sub_assign<const L: usize>(a: &mut Tc, b: &Tc) {
    let mut borrow = false;
    for k in 0..L {
        let (d1, b1) = a[k].overflowing_sub(b[k]);
        let (d2, b2) = d1.overflowing_sub(borrow as u64);
        a[k] = d2;
        borrow = b1 | b2;
    }
}

/// ⌊x/2^z⌋ of a signed value (a negative x rounds towards −∞).
pub(super) fn shr_floor(x: Si, z: u32) -> Si {
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
    /// Ticks the search may try, `[lo, hi]`: those whose upper half tick lies in the
    /// piece, `f·t0 ≤ e + ½` and `e − ½ < f·(t0 + dur)` (the cubic's extension beyond the
    /// piece may turn back, so it is never consulted; a step's time lies in its piece).
    lo: u64,
    hi: u64,
}

impl Cubic {
    /// Piece `k` of `profile` (c4 = 0) on a clock of `clock` Hz, its next step being `i`;
    /// edges up to `end` ticks. `None`: not a cubic piece or too wide for 512 bits.
    pub(super) fn enter(
        profile: &Profile,
        clock: u64,
        k: usize,
        i: u64,
        end: u64,
    ) -> Option<Cubic> {
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
        let (lo, hi) = (
            nearest_tick(clock, p.t0, 0.0)?,
            nearest_tick(clock, p.t0, p.dur)?.min(end),
        );
        let dmax = end.max(e_r).saturating_add(1);
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
            lo,
            hi,
        })
    }

    /// `N_i(e)` on `L` limbs (`L ≥ n`: the values are sign-extended to every limb).
    #[inline(always)]
    fn value<const L: usize>(&self, e: u64) -> [u64; L] {
        let (c, m) = if e >= self.e_r {
            (&self.pos, e - self.e_r)
        } else {
            (&self.neg, self.e_r - e)
        };
        let part = |x: &Tc| -> [u64; L] { core::array::from_fn(|k| x[k]) };
        let mut acc = part(&c[0]);
        mul_add(&mut acc, m, &part(&c[1]));
        mul_add(&mut acc, m, &part(&c[2]));
        mul_add(&mut acc, m, &part(&self.a0));
        acc
    }

    /// The next step's edge and where in the tick before it the exact time lies (see
    /// [`Cubic::edge_on`]).
    pub(super) fn edge(&mut self, lo: u64, guess: u64) -> (u64, Option<u32>) {
        match self.n {
            0..=2 => self.edge_on::<2>(lo, guess),
            3 => self.edge_on::<3>(lo, guess),
            4 => self.edge_on::<4>(lo, guess),
            5 | 6 => self.edge_on::<6>(lo, guess),
            _ => self.edge_on::<LIMBS>(lo, guess),
        }
    }

    /// The least tick from `lo` (the last edge) whose upper half tick has reached the next
    /// step, searched from `guess` within the piece; the piece's last tick when none has
    /// (as the float generator clamps a step's time to its piece). With it, when
    /// the tick before was tried too, the fraction φ (in 2^-32) of the exact crossing
    /// `x* ≈ e − 1 + φ` of `N_i` between the two (linear interpolation of the two
    /// values, for the next guess only: the edge is decided by the signs).
    fn edge_on<const L: usize>(&mut self, lo: u64, guess: u64) -> (u64, Option<u32>) {
        let lo = lo.max(self.lo);
        let hi = self.hi.max(lo);
        let g = guess.clamp(lo, hi);
        let reached = |v: &[u64; L]| v[L - 1] >> 63 == 0;
        // below: a tick known not reached and its value (None: every tick before lo);
        // above: a tick known reached and its value (hi + 1: none up to hi)
        let mut below: Option<(u64, [u64; L])> = None;
        let mut above: (u64, Option<[u64; L]>) = (hi + 1, None);
        let v = self.value::<L>(g);
        let mut step = 1u64;
        if reached(&v) {
            above = (g, Some(v));
            while let Some(c) = g.checked_sub(step).filter(|&c| c >= lo) {
                let v = self.value::<L>(c);
                if !reached(&v) {
                    below = Some((c, v));
                    break;
                }
                above = (c, Some(v));
                step = step.saturating_mul(2);
            }
        } else {
            below = Some((g, v));
            while let Some(c) = g.checked_add(step).filter(|&c| c <= hi) {
                let v = self.value::<L>(c);
                if reached(&v) {
                    above = (c, Some(v));
                    break;
                }
                below = Some((c, v));
                step = step.saturating_mul(2);
            }
        }
        // bisect (below, above]
        loop {
            let b = below.map_or(lo, |(x, _)| x + 1); // the least candidate
            if b >= above.0 {
                break;
            }
            let mid = b + (above.0 - b) / 2;
            let v = self.value::<L>(mid);
            if reached(&v) {
                above = (mid, Some(v));
            } else {
                below = Some((mid, v));
            }
        }
        let frac = match (below, above) {
            (Some((b, vb)), (a, Some(va))) if b + 1 == a => fraction(&vb, &va),
            _ => None,
        };
        let k = self.k;
        sub_assign::<L>(&mut self.a0, &k);
        (above.0.min(hi), frac)
    }
}

/// `⌈f·(a + b) − ½⌉` (0 if negative), the tick nearest to the time a + b, exactly.
pub(super) fn nearest_tick(clock: u64, a: f64, b: f64) -> Option<u64> {
    let s = places(a)?.max(places(b)?);
    // 2^s·f·(a + b) = X; ⌈(2X − 2^s)/2^(s+1)⌉
    let one = Si::pos(W::ONE);
    let x = scaled(a, s)?
        .add(scaled(b, s)?)?
        .mul(Si::from_u128(clock as u128))?;
    let num = x.shl(1)?.sub(one.shl(s)?)?;
    if num.neg {
        return Some(0);
    }
    let up = num.add(one.shl(s + 1)?)?.sub(one)?;
    super::track::to_u64(&up.mag.shr_vartime(s + 1))
}

/// `φ = −vb/(va − vb)` in 2^-32 (vb < 0 ≤ va, two's complement) from the top bits of
/// both: the crossing's place between two ticks, for guessing only.
fn fraction<const L: usize>(vb: &[u64; L], va: &[u64; L]) -> Option<u32> {
    let mut num = *vb;
    negate_l(&mut num);
    let mut den = *va;
    add_l(&mut den, &num);
    // the top 62 bits of den and the same bits of num (num ≤ den)
    let top = (0..L).rev().find(|&k| den[k] != 0)?;
    let pair = |x: &[u64; L]| {
        let hi = x[top] as u128;
        let lo = if top > 0 { x[top - 1] as u128 } else { 0 };
        (hi << 64) | lo
    };
    let sh = 128 - (den[top].leading_zeros()) - 62;
    let (n62, d62) = ((pair(&num) >> sh) as u64, (pair(&den) >> sh) as u64);
    (d62 > 0).then(|| (((n62 as u128) << 32) / d62 as u128).min(u32::MAX as u128) as u32)
}

fn negate_l<const L: usize>(v: &mut [u64; L]) {
    let mut carry = 1u64;
    for limb in v.iter_mut() {
        let (s, c) = (!*limb).overflowing_add(carry);
        *limb = s;
        carry = c as u64;
    }
}

fn add_l<const L: usize>(a: &mut [u64; L], b: &[u64; L]) {
    let mut carry = false;
    for k in 0..L {
        let (s1, c1) = a[k].overflowing_add(b[k]);
        let (s2, c2) = s1.overflowing_add(carry as u64);
        a[k] = s2;
        carry = c1 | c2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn twos_complement_horner() {
        let v = |x: i128| {
            tc(&if x < 0 {
                Si::from_u128(x.unsigned_abs()).neg()
            } else {
                Si::from_u128(x as u128)
            })
            .unwrap()
        };
        let two = |x: &Tc| [x[0], x[1]];
        let back = |a: &[u64; 2]| ((a[1] as u128) << 64 | a[0] as u128) as i128;
        let mut acc = two(&v(-7));
        mul_add(&mut acc, 1000, &two(&v(3)));
        assert_eq!(back(&acc), -6997);
        mul_add(&mut acc, 1 << 40, &two(&v(-5)));
        assert_eq!(back(&acc), -6997 * (1i128 << 40) - 5);
        let mut w = v(-5);
        sub_assign::<LIMBS>(&mut w, &v(-6997 * (1i128 << 40)));
        assert_eq!(back(&two(&w)), 6997 * (1i128 << 40) - 5);
        let s = shr_floor(Si::from_u128(7).neg(), 1);
        assert!(s.neg && s.mag == W::from_u64(4));
        let s = shr_floor(Si::from_u128(8).neg(), 2);
        assert!(s.neg && s.mag == W::from_u64(2));
        assert_eq!(nearest_tick(10, 0.25, 0.0), Some(2)); // 2.5: a tie goes down
        assert_eq!(nearest_tick(10, 0.25, 0.125), Some(4)); // 3.75
        assert_eq!(nearest_tick(10, 0.0, 0.0), Some(0));
        assert_eq!(nearest_tick(3, 0.5, 0.5), Some(3));
        // the crossing of −1 → 3 is a quarter of the way
        assert_eq!(fraction(&two(&v(-1)), &two(&v(3))), Some(1 << 30));
        assert_eq!(
            fraction(&two(&v(-(3 << 100))), &two(&v(1 << 100))),
            Some(3 << 30)
        );
    }
}
