//! Open-ended motion in integers: [`IntTracker`] is the [`Tracker`](crate::Tracker) with its
//! ramps run by [`IntRamp`], so every edge comes from integer arithmetic only and equals the
//! float tracker's edge for the same inputs.
//!
//! A tracker's cruise is already integer (quotient + remainder in u128). Its ramps are
//! limits-mode trapezoids or S-curves planned by the float planner (the same plan as the
//! float tracker: planning is not the per-step path); [`IntRamp`] takes that plan's f64
//! coefficients as the exact binary rationals they are (decomposed bit by bit, no float
//! arithmetic). On a constant-acceleration piece it finds each step's nearest tick
//! exactly, with no correction step, by the same identity as the integer kernel (module
//! docs of [`crate::int`]): `⌈(x − y)/n⌉ = ⌈(⌈x⌉ − y)/n⌉`. A constant-jerk piece of an
//! S-curve (cubic in time) has no such closed form; its edges come from the exactness test
//! itself, evaluated in integers at half ticks (`int/cubic.rs`).
//!
//! # One piece `p(τ) = p0 + c1·τ + c2·τ²` starting at `t0` (all f64, so binary rationals)
//! With the common scale 2^S that makes `p0, c1, c2` integers, u the local time in ticks and
//! f the clock: `B·u² + A·u = M_i` with `B = c2·2^S`, `A = c1·2^S·f`,
//! `M_i = (i·2^S − p0·2^S)·f²`. The origin less half a tick is `f·t0 − ½ = G/2^s`. Step i's
//! edge `⌈f·t0 + u* − ½⌉` is then, with `Y' = 4^s·(A² + 4B·M_i)` (linear in i, so one add
//! per step):
//! - accelerating (B > 0): `⌈(⌈√Y'⌉ − (2^s·A − 2B·G)) / 2^(s+1)·B⌉`;
//! - decelerating (B < 0): `⌈(2|B|·G + 2^s·A − ⌊√Y'⌋) / 2^(s+1)·|B|⌉`;
//! - constant speed (B = 0): `⌈(G·A + 2^s·M_i) / 2^s·A⌉`.
//!
//! Per step: one add, one square root with remainder, one divide; in u128 when every value
//! of the piece fits (a ramp from rest), else in 512 bits. The widths are checked when a
//! piece is entered (an error, never a wrong edge).

use super::cubic::Cubic;
use super::isqrt::isqrt_u128;
use crate::piece::Law;
use crate::profile::Profile;
use crate::track::{RampEdges, TrackError, TrackerOf};
use crypto_bigint::{NonZero, U512};

pub(super) type W = U512;

/// The float [`Tracker`](crate::Tracker)'s motion with every edge in integers: ramps by
/// [`IntRamp`], cruises by the shared quotient + remainder accumulator.
pub type IntTracker = TrackerOf<IntRamp>;

/// Bits a value may use so that sums of two stay below 2^512.
const MAX_BITS: u32 = 510;

/// A signed 512-bit value, for planning a piece (the per-step path is unsigned).
#[derive(Clone, Copy, Debug)]
pub(super) struct Si {
    pub(super) neg: bool,
    pub(super) mag: W,
}

impl Si {
    pub(super) const ZERO: Si = Si {
        neg: false,
        mag: W::ZERO,
    };

    pub(super) fn pos(mag: W) -> Si {
        Si { neg: false, mag }
    }

    pub(super) fn from_u128(x: u128) -> Si {
        Si::pos(W::from_u128(x))
    }

    pub(super) fn is_zero(&self) -> bool {
        self.mag == W::ZERO
    }

    pub(super) fn neg(self) -> Si {
        Si {
            neg: !self.neg && !self.is_zero(),
            mag: self.mag,
        }
    }

    pub(super) fn mul(self, o: Si) -> Option<Si> {
        if self.mag.bits_vartime() + o.mag.bits_vartime() > MAX_BITS {
            return None;
        }
        let mag = self.mag.wrapping_mul(&o.mag);
        Some(Si {
            neg: (self.neg != o.neg) && mag != W::ZERO,
            mag,
        })
    }

    pub(super) fn shl(self, k: u32) -> Option<Si> {
        if self.mag.bits_vartime() + k > MAX_BITS {
            return None;
        }
        Some(Si {
            neg: self.neg,
            mag: self.mag.shl_vartime(k),
        })
    }

    pub(super) fn add(self, o: Si) -> Option<Si> {
        if self.mag.bits_vartime().max(o.mag.bits_vartime()) >= MAX_BITS {
            return None;
        }
        if self.neg == o.neg {
            return Some(Si {
                neg: self.neg,
                mag: self.mag.wrapping_add(&o.mag),
            });
        }
        let (big, small) = if self.mag >= o.mag {
            (self, o)
        } else {
            (o, self)
        };
        let mag = big.mag.wrapping_sub(&small.mag);
        Some(Si {
            neg: big.neg && mag != W::ZERO,
            mag,
        })
    }

    pub(super) fn sub(self, o: Si) -> Option<Si> {
        self.add(o.neg())
    }
}

/// `x = ±m·2^e` exactly (m < 2^53 odd, or 0), from the bits; `None` for infinities and NaN.
pub(super) fn split(x: f64) -> Option<(bool, u64, i32)> {
    let bits = x.to_bits();
    let neg = bits >> 63 == 1;
    let exp = ((bits >> 52) & 0x7ff) as i32;
    let frac = bits & ((1u64 << 52) - 1);
    let (m, e) = match exp {
        0x7ff => return None,
        0 => (frac, -1074),
        _ => (frac | (1 << 52), exp - 1075),
    };
    // odd m (or zero): the fewest binary places
    let z = if m == 0 { 0 } else { m.trailing_zeros() };
    Some((neg, m >> z, e + z as i32))
}

/// Binary places an f64 needs to be an integer (0 for zero and integers).
pub(super) fn places(x: f64) -> Option<u32> {
    let (_, m, e) = split(x)?;
    Some(if m == 0 || e >= 0 { 0 } else { (-e) as u32 })
}

/// `x·2^s` as an exact integer (`s` at least [`places`] of x).
pub(super) fn scaled(x: f64, s: u32) -> Option<Si> {
    let (neg, m, e) = split(x)?;
    if m == 0 {
        return Some(Si::ZERO);
    }
    let sh = u32::try_from(e + s as i32).ok()?;
    let v = Si::pos(W::from_u64(m)).shl(sh)?;
    Some(if neg { v.neg() } else { v })
}

/// ⌊x⌋ of a non-negative f64 in integers (saturating; 0 below 1 and for negatives).
pub(super) fn floor_u64(x: f64) -> u64 {
    match split(x) {
        Some((false, m, e)) if m != 0 => {
            if e >= 0 {
                if e >= 11 {
                    u64::MAX
                } else {
                    m << e
                }
            } else if e <= -64 {
                0
            } else {
                m >> (-e) as u32
            }
        }
        Some((false, _, _)) => 0,
        Some((true, _, _)) => 0,
        None => u64::MAX,
    }
}

/// `round(f·T)` with a half tick going up (the tick of a profile's last step), in integers.
pub(super) fn round_ticks(clock: u64, t: f64) -> Option<u64> {
    let (neg, m, e) = split(t)?;
    if neg || m == 0 {
        return Some(0);
    }
    let x = clock as u128 * m as u128;
    let r = if e >= 0 {
        x.checked_shl(e as u32).filter(|v| v >> e as u32 == x)?
    } else {
        let s = (-e) as u32;
        if s >= 127 {
            0 // f·T < 2^106 · 2^-127: under half a tick
        } else {
            (x >> s) + ((x >> (s - 1)) & 1)
        }
    };
    u64::try_from(r).ok()
}

pub(super) fn to_u64(x: &W) -> Option<u64> {
    low_bits(x, 64).map(|v| v as u64)
}

/// x as u128 when it is below 2^bits (bits ≤ 128).
fn low_bits(x: &W, bits: u32) -> Option<u128> {
    (x.bits_vartime() <= bits).then(|| {
        let b = x.to_le_bytes();
        let mut lo = [0u8; 16];
        lo.copy_from_slice(&b[..16]);
        u128::from_le_bytes(lo)
    })
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Mode {
    Accel,
    Decel,
    Linear,
}

/// The current piece's per-step state.
#[derive(Clone, Copy, Debug)]
pub(super) struct Kernel {
    pub(super) mode: Mode,
    /// `Y'` of the next step (accel/decel), or the linear numerator plus n.
    y: W,
    /// Added to (accel, linear) or taken from (decel) `y` per step.
    dy: W,
    /// Accel: `n − (2^s·A − 2B·G)`; decel: `2|B|·G + 2^s·A + n`.
    off: Si,
    n: NonZero<W>,
    /// The same state in u128 when every value of the piece fits (pieces from tick 0
    /// with short binary fractions, such as a ramp from rest): the same steps, with
    /// the crate's integer square root.
    narrow: Option<Narrow>,
}

#[derive(Clone, Copy, Debug)]
struct Narrow {
    y: u128,
    dy: u128,
    off: i128,
    n: u128,
}

impl Narrow {
    /// [`Kernel::edge`] in u128 (every value below 2^126, checked on entry).
    #[inline]
    fn edge(&mut self, mode: Mode) -> Option<u64> {
        let num = match mode {
            Mode::Accel => {
                let r = isqrt_u128(self.y);
                let up = r + (r * r != self.y) as u128;
                self.y += self.dy;
                up as i128 + self.off
            }
            Mode::Decel => {
                let r = isqrt_u128(self.y);
                self.y = self.y.saturating_sub(self.dy);
                self.off - r as i128
            }
            Mode::Linear => {
                let y = self.y;
                self.y += self.dy;
                y as i128
            }
        };
        if num <= 0 {
            return Some(0);
        }
        u64::try_from((num as u128 - 1) / self.n).ok()
    }
}

/// x as u128 when it is below 2^126.
fn narrow(x: &W) -> Option<u128> {
    low_bits(x, 126)
}

impl Kernel {
    /// The piece `k` of `profile`, its next step being `i`.
    pub(super) fn enter(profile: &Profile, clock: u64, k: usize, i: u64) -> Option<Kernel> {
        let p = profile.piece(k);
        let (c1, c2) = p.quadratic()?;
        let sc = places(p.p0)?.max(places(c1)?).max(places(c2)?);
        let (pp, a1, b) = (scaled(p.p0, sc)?, scaled(c1, sc)?, scaled(c2, sc)?);
        let f = Si::from_u128(clock as u128);
        let f2 = f.mul(f)?;
        let a = a1.mul(f)?;
        // f·t0 − ½ = G/2^s
        let (tneg, tm, te) = split(p.t0)?;
        if tneg && tm != 0 {
            return None;
        }
        let (t, s0) = if tm == 0 {
            (Si::ZERO, 0)
        } else if te >= 0 {
            (Si::pos(W::from_u64(tm)).shl(te as u32)?, 0)
        } else {
            (Si::pos(W::from_u64(tm)), (-te) as u32)
        };
        let s = s0 + 1;
        let g = t.mul(f)?.shl(1)?.sub(Si::pos(W::ONE).shl(s0)?)?;
        // M_i = (i·2^S − P)·f²
        let m = Si::from_u128(i as u128).shl(sc)?.sub(pp)?.mul(f2)?;
        let dm = Si::pos(W::ONE).shl(sc)?.mul(f2)?;
        let two_s = Si::pos(W::ONE).shl(s)?;
        let (mode, y, dy, off, n) = if b.is_zero() {
            if a.neg || a.is_zero() {
                return None;
            }
            let n = two_s.mul(a)?;
            let y = g.mul(a)?.add(two_s.mul(m)?)?.add(n)?;
            // a step before the piece's origin: the clamp to the last edge decides
            let y = if y.neg { W::ZERO } else { y.mag };
            (Mode::Linear, y, two_s.mul(dm)?.mag, Si::ZERO, n.mag)
        } else {
            let four_s = Si::pos(W::ONE).shl(2 * s)?;
            let y = a.mul(a)?.add(b.mul(m)?.shl(2)?)?.mul(four_s)?;
            let y = if y.neg { W::ZERO } else { y.mag };
            let dy = four_s.mul(b)?.mul(dm)?.shl(2)?.mag;
            let bb = Si::pos(b.mag);
            let n = bb.shl(s + 1)?;
            let two_bg = bb.mul(g)?.shl(1)?;
            let sa = two_s.mul(a)?;
            if b.neg {
                (Mode::Decel, y, dy, two_bg.add(sa)?.add(n)?, n.mag)
            } else {
                (Mode::Accel, y, dy, n.sub(sa.sub(two_bg)?)?, n.mag)
            }
        };
        // the widest per-step value: y at the piece's last step (or the ramp's)
        let span = profile
            .steps()
            .min(floor_u64(profile.end_of(k)))
            .saturating_sub(i);
        if dy.bits_vartime() + 64 > MAX_BITS || y.bits_vartime() > MAX_BITS - 1 {
            return None;
        }
        let y_end = y.wrapping_add(&dy.wrapping_mul(&W::from_u64(span)));
        if y_end.bits_vartime() > MAX_BITS || off.mag.bits_vartime() >= MAX_BITS {
            return None;
        }
        let small = || {
            // y only grows (accel, linear) or shrinks (decel) from y or to y_end
            narrow(&y_end)?;
            let m = narrow(&off.mag)? as i128;
            Some(Narrow {
                y: narrow(&y)?,
                dy: narrow(&dy)?,
                off: if off.neg { -m } else { m },
                n: narrow(&n).filter(|&n| n > 0)?,
            })
        };
        Some(Kernel {
            mode,
            y,
            dy,
            off,
            n: NonZero::new(n).into_option()?,
            narrow: small(),
        })
    }

    /// The next step's edge, ticks from the ramp's start (`None`: past the 64-bit range).
    #[inline]
    fn edge(&mut self) -> Option<u64> {
        if let Some(nw) = &mut self.narrow {
            return nw.edge(self.mode);
        }
        // the numerator of ⌈num/n⌉ − 1, which is 0 when num ≤ 0 (a clamped step)
        let num = match self.mode {
            Mode::Accel => {
                let r = self.y.floor_sqrt_vartime();
                let up = if r.wrapping_mul(&r) == self.y {
                    r
                } else {
                    r.wrapping_add(&W::ONE)
                };
                self.y = self.y.wrapping_add(&self.dy);
                Si::pos(up).add(self.off)?
            }
            Mode::Decel => {
                let r = self.y.floor_sqrt_vartime();
                self.y = self.y.saturating_sub(&self.dy);
                self.off.sub(Si::pos(r))?
            }
            Mode::Linear => {
                let y = self.y;
                self.y = self.y.wrapping_add(&self.dy);
                Si::pos(y)
            }
        };
        if num.neg || num.is_zero() {
            return Some(0);
        }
        let (q, _) = num.mag.wrapping_sub(&W::ONE).div_rem_vartime(&self.n);
        to_u64(&q)
    }
}

/// A piece's per-step state: the closed form (constant acceleration) or the search by
/// the exactness test (constant jerk, [`Cubic`]).
#[derive(Clone, Copy, Debug)]
enum PieceKernel {
    Quadratic(Kernel),
    Cubic(Cubic),
}

impl PieceKernel {
    fn enter(r: &IntRamp, k: usize, i: u64) -> Option<PieceKernel> {
        match r.profile.piece(k).quadratic() {
            Some(_) => Kernel::enter(&r.profile, r.clock, k, i).map(PieceKernel::Quadratic),
            None => Cubic::enter(&r.profile, r.clock, k, i, r.end_tick).map(PieceKernel::Cubic),
        }
    }
}

/// A tracker's ramp (a trapezoid or S-curve [`Profile`] from the float planner) with every
/// edge in integers: the same edges as [`EdgeGenerator`](crate::EdgeGenerator) on that
/// profile.
#[derive(Clone, Debug)]
pub struct IntRamp {
    profile: Profile,
    clock: u64,
    /// The next step (1-based) and the last one, whose edge is `round(f·T)`.
    next: u64,
    end_tick: u64,
    last_edge: u64,
    /// The exact times of the last three steps (newest first), ticks in 2^-32 (to the
    /// precision the search learns them; a tick's middle otherwise), and how many are
    /// known: the cubic search starts from their quadratic extrapolation.
    times: [i128; 3],
    known: u8,
    piece: usize,
    /// ⌊end of the current piece⌋: steps up to it belong to it (as the float generator
    /// assigns them).
    piece_end: u64,
    kernel: Option<PieceKernel>,
}

impl IntRamp {
    /// The ramp `profile` on a clock of `clock_hz` (pieces of constant acceleration or
    /// constant jerk).
    pub fn new(profile: Profile, clock_hz: u64) -> Result<IntRamp, TrackError> {
        let cubic = |p: &crate::piece::Piece| matches!(p.law, Law::Poly { c4, .. } if c4 == 0.0);
        if !profile.pieces().iter().all(cubic) {
            return Err(TrackError::NotInteger);
        }
        let end_tick = round_ticks(clock_hz, profile.duration()).ok_or(TrackError::TooLong)?;
        if end_tick > 1 << 50 {
            return Err(TrackError::TooLong);
        }
        Ok(IntRamp {
            piece_end: floor_u64(profile.end_of(0)),
            profile,
            clock: clock_hz,
            next: 1,
            end_tick,
            last_edge: 0,
            // tick 0 is the edge of the step before the ramp
            times: [0; 3],
            known: 1,
            piece: 0,
            kernel: None,
        })
    }

    /// The profile played.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// Where the next edge probably is: ⌈x⌉ of the step times' quadratic extrapolation x
    /// (step times are smooth), or the tick after the last edge (the search gallops).
    fn guess(&self) -> u64 {
        let [x1, x2, x3] = self.times;
        let x = match self.known {
            3 => 3 * (x1 - x2) + x3,
            2 => 2 * x1 - x2,
            _ => return self.last_edge + 1,
        };
        let up = (x + (1 << 32) - 1) >> 32;
        up.clamp(self.last_edge as i128, u64::MAX as i128) as u64
    }
}

impl Iterator for IntRamp {
    type Item = u64;

    fn next(&mut self) -> Option<u64> {
        let i = self.next;
        let n = self.profile.steps();
        if i >= n {
            if i > n {
                return None;
            }
            self.next += 1;
            self.last_edge = self.end_tick.max(self.last_edge);
            return Some(self.last_edge);
        }
        self.next += 1;
        if self.piece_end < i || self.kernel.is_none() {
            let mut k = self.piece;
            while floor_u64(self.profile.end_of(k)) < i && k + 1 < self.profile.len() {
                k += 1;
            }
            self.piece = k;
            self.piece_end = floor_u64(self.profile.end_of(k));
            self.kernel = Some(PieceKernel::enter(self, k, i)?);
        }
        let guess = match self.kernel {
            Some(PieceKernel::Cubic(_)) => self.guess(),
            _ => 0,
        };
        let e = match &mut self.kernel {
            Some(PieceKernel::Quadratic(q)) => {
                // the closed form needs no history: the cubic search's first step after
                // this piece gallops from the last edge
                self.known = 0;
                q.edge()?
            }
            Some(PieceKernel::Cubic(c)) => {
                let (e, frac) = c.edge(self.last_edge, guess);
                let e = e.max(self.last_edge);
                // the step's time: e − 1 + φ, or half a tick before its edge
                let x = ((e as i128) << 32) - frac.map_or(1 << 31, |f| (1i128 << 32) - f as i128);
                self.times = [x, self.times[0], self.times[1]];
                self.known = (self.known + 1).min(3);
                e
            }
            None => return None,
        };
        let e = e.max(self.last_edge);
        self.last_edge = e;
        Some(e)
    }
}

impl RampEdges for IntRamp {
    fn start(profile: Profile, clock_hz: u64) -> Result<Self, TrackError> {
        let r = IntRamp::new(profile, clock_hz)?;
        // enter every piece now, at its first step, so a ramp too wide for the datapath
        // is refused when it is asked for, not cut short while it runs
        let mut first = 1;
        for k in 0..r.profile.len() {
            let end = floor_u64(r.profile.end_of(k));
            if first < r.profile.steps() && first <= end {
                PieceKernel::enter(&r, k, first).ok_or(TrackError::NotInteger)?;
                first = end.saturating_add(1);
            }
        }
        Ok(r)
    }

    fn next_edge(&mut self) -> Option<u64> {
        self.next()
    }

    fn profile(&self) -> &Profile {
        &self.profile
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floats_split_exactly() {
        assert_eq!(floor_u64(2.999), 2);
        assert_eq!(floor_u64(3.0), 3);
        assert_eq!(floor_u64(0.5), 0);
        assert_eq!(floor_u64(1e300), u64::MAX);
        assert_eq!(floor_u64(-2.0), 0);
        assert_eq!(round_ticks(10, 0.25), Some(3)); // 2.5 → 3
        assert_eq!(round_ticks(10, 0.24), Some(2));
        assert_eq!(round_ticks(50_000_000, 1.0), Some(50_000_000));
        assert_eq!(places(0.375), Some(3));
        assert_eq!(places(12.0), Some(0));
        let v = scaled(-0.375, 4).unwrap();
        assert!(v.neg && v.mag == W::from_u64(6));
    }

    /// Every piece of a few ramps, stepped by its u128 kernel where it has one and by the
    /// 512-bit kernel: the same edges; and both paths are taken.
    #[test]
    fn narrow_and_wide_kernels_agree() {
        use crate::track::{Rate, TrackLimits, Tracker};
        let (mut narrow_pieces, mut wide_pieces) = (0, 0);
        for (start, rate, amax) in [
            (0.0, Rate::new(15041, 324).unwrap(), 200.0),
            (1000.3, Rate::new(10, 3).unwrap(), 3000.0),
            (0.0, Rate::new(319_999, 10).unwrap(), 64_000.0),
            (77.7, Rate::new(123_457, 1000).unwrap(), 50.0),
        ] {
            let limits = TrackLimits { amax, jmax: None };
            let t = Tracker::new(50e6, limits, start, rate).unwrap();
            let p = t.ramp_profile().unwrap();
            let mut first = 1;
            for k in 0..p.len() {
                let end = floor_u64(p.end_of(k)).min(p.steps() - 1);
                if first > end {
                    continue;
                }
                let mut auto = Kernel::enter(p, 50_000_000, k, first).unwrap();
                let mut wide = auto;
                wide.narrow = None;
                if auto.narrow.is_some() {
                    narrow_pieces += 1;
                } else {
                    wide_pieces += 1;
                }
                for i in first..=end {
                    assert_eq!(auto.edge(), wide.edge(), "piece {k} step {i}");
                }
                first = end + 1;
            }
        }
        assert!(
            narrow_pieces > 0 && wide_pieces > 0,
            "{narrow_pieces} {wide_pieces}"
        );
    }

    #[test]
    fn signed_sums() {
        let a = Si::from_u128(5);
        let b = Si::from_u128(7).neg();
        let s = a.add(b).unwrap();
        assert!(s.neg && s.mag == W::from_u64(2));
        let z = a.sub(a).unwrap();
        assert!(!z.neg && z.is_zero());
        let p = b.mul(b).unwrap();
        assert!(!p.neg && p.mag == W::from_u64(49));
        assert!(Si::pos(W::ONE).shl(600).is_none());
    }
}
