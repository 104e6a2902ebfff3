//! One constant-acceleration piece in exact integers, and its per-step kernel.
//!
//! In local ticks τ ∈ [0, D] from the piece's start tick `t0`, the position above the
//! piece's start `p0` is `(A·τ + B·τ²) / Den` steps. Step i is the target
//! `M = Den·i − C` (`C = Den·p0`) and happens at the root τ* of `A·τ + B·τ² = M`; its edge
//! is the nearest tick, an exact half tick going to the earlier one: `e = ⌈τ* − ½⌉`
//! (DESIGN.md §1). With `Y = A² + 4BM` (the squared speed `(Den·v)²` at the step) and
//! `τ* = (√Y − A)/(2B)` (or `(A − √Y)/(2b)`, `b = −B`, on deceleration; `M/A` at constant
//! speed), `⌈(x − y)/n⌉ = ⌈(⌈x⌉ − y)/n⌉` for integers y, n > 0 gives the edge exactly:
//!
//! ```text
//! Accel  (B > 0): e = ⌊(⌈√Y⌉ + B − A − 1) / 2B⌋
//! Decel  (B < 0): e = ⌊(A + b − 1 − ⌊√Y⌋) / 2b⌋
//! Cruise (B = 0): e = ⌊(2M + A − 1) / 2A⌋
//! ```
//!
//! In exact integers the difference √Y − A has no cancellation to fear (that is a float
//! concern, seed 000 eq. (10)/(11) vs DESIGN.md §2), and the square root's remainder makes
//! ⌈√Y⌉ exact, so no correction step is needed.

use super::isqrt::isqrt_u128;
use super::IntError;
use crate::accum::StepAccumulator;
use crypto_bigint::U256;

/// Bits every planning quantity (Den, A, B, C, 8M) must fit in.
const LIMIT: u32 = 124;

/// Which closed form a piece's steps use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelMode {
    Accel,
    Decel,
    Cruise,
}

/// The per-step datapath of one piece: for its j-th step (j = 0, 1, …)
///
/// ```text
/// Y   = y0 + j·dy   (Accel, Cruise)   or   y0 − j·dy   (Decel)     1 narrow multiply
/// num = ⌈√Y⌉ + k    (Accel)  ·  k − ⌊√Y⌋  (Decel)  ·  Y  (Cruise)   1 square root
/// e   = ⌊num / dv⌋  (local ticks)                                  1 divide
/// ```
///
/// This is what the FPGA calculator computes (crates/hdl): the host plans the piece, the
/// calculator runs the kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepKernel {
    pub mode: KernelMode,
    /// Y at the piece's first step: `A² + 4B·M₀`, or `2M₀ + A − 1` on Cruise.
    pub y0: u128,
    /// |ΔY| per step: `4|B|·Den`, or `2·Den` on Cruise.
    pub dy: u128,
    /// `B − A − 1` (Accel, may be negative), `A + b − 1` (Decel), 0 (Cruise).
    pub k: i128,
    /// `2B`, `2b` or `2A`.
    pub dv: u128,
}

impl StepKernel {
    /// `Y` of the j-th step.
    #[inline(always)]
    pub fn radicand(&self, j: u64) -> u128 {
        let d = j as u128 * self.dy;
        match self.mode {
            KernelMode::Decel => self.y0 - d,
            _ => self.y0 + d,
        }
    }

    /// The numerator from `Y` and `(⌊√Y⌋, Y is a square)`.
    #[inline(always)]
    fn numerator(&self, y: u128, root: u128, square: bool) -> u128 {
        match self.mode {
            KernelMode::Accel => (root as i128 + !square as i128 + self.k) as u128,
            KernelMode::Decel => self.k as u128 - root,
            KernelMode::Cruise => y,
        }
    }

    /// The local edge tick of the j-th step of the piece (no root on Cruise, where it
    /// is not used).
    #[inline]
    pub fn local_edge(&self, j: u64) -> u64 {
        let y = self.radicand(j);
        if self.mode == KernelMode::Cruise {
            return divide(y, self.dv);
        }
        let root = isqrt_u128(y);
        let num = self.numerator(y, root, root * root == y);
        divide(num, self.dv)
    }

    /// On Cruise, `(y, dy, dv)` with the j-th step's edge `⌊(y + j·dy)/dv⌋` in absolute
    /// ticks (from `t0`), reduced as in [`StepKernel::cruise_accumulator`].
    pub(crate) fn cruise_line(&self, t0: u64) -> Option<(u128, u128, u128)> {
        if self.mode != KernelMode::Cruise {
            return None;
        }
        let g = gcd(self.dy, self.dv).max(1);
        let (dy, dv) = (self.dy / g, self.dv / g);
        Some((
            (self.y0 / g).checked_add((t0 as u128).checked_mul(dv)?)?,
            dy,
            dv,
        ))
    }

    /// On Cruise, the edges from step j on as a [`StepAccumulator`] of absolute ticks
    /// (from `t0`): `⌊(y0 + j·dy)/dv⌋` with dy and dv reduced by their gcd, since
    /// `⌊(g·x + r)/(g·d)⌋ = ⌊x/d⌋` for `0 ≤ r < g`. `None` on the other modes or when
    /// the reduced divisor needs more than 63 bits.
    pub fn cruise_accumulator(&self, j: u64, t0: u64) -> Option<StepAccumulator> {
        if self.mode != KernelMode::Cruise {
            return None;
        }
        let g = gcd(self.dy, self.dv).max(1);
        let (dy, dv) = (self.dy / g, self.dv / g);
        let y = (self.y0 / g).checked_add(dy.checked_mul(j as u128)?)?;
        let t = (t0 as u128).checked_mul(dv)?;
        StepAccumulator::new(y.checked_add(t)?, dy, dv)
    }
}

/// `⌊num / dv⌋`; a 64-bit divide when the operands allow (software speed only).
#[inline(always)]
fn divide(num: u128, dv: u128) -> u64 {
    if (num | dv) >> 64 == 0 {
        num as u64 / dv as u64
    } else {
        (num / dv) as u64
    }
}

/// The radicand of a piece whose `Y` needs more than 128 bits (software only: the RTL
/// rejects such moves). Same sequence at 256 bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct WideRadicand {
    y0: U256,
    dy: U256,
}

/// 1.5·2^52: adding it rounds a non-negative x < 2^51 to an integer in the low mantissa.
const MAGIC: f64 = 6_755_399_441_055_744.0;

/// [`IntPiece::checked_guess`] for consecutive steps, its constants hoisted and the
/// target `4M` carried from step to step (one addition).
#[derive(Clone, Copy, Debug)]
pub(crate) struct IntRamp {
    a: f64,
    a_sq: f64,
    b4: f64,
    /// `1/(2B)`.
    h: f64,
    den: f64,
    m0: f64,
    last: f64,
    /// The step within the piece (below 2^53: as f64 it gives the per-step path's
    /// guess `m0 + j·den`); an integer, so that no float is carried from step to step.
    j: i64,
    m4: i128,
    dm4: i128,
    two_a: i128,
    four_a: i128,
    b: i128,
    eight_b: i128,
    /// `2A·t`, `|B|·t²`, `4A + 8|B|·D` and `4M` stay below 2^62 for every `t ≤ 2D + 1`.
    narrow: bool,
}

/// `4·P(t / 2) = 2A·t + B·t²`, as `t·(2A + B·t)`: at `t = 2e ± 1`, four times P at the
/// half ticks around e, the values of the exact edge test `P(e − ½) < M ≤ P(e + ½)`.
/// Every exact value of a planned piece lies below 2^127, so wrapping gives it exactly.
#[inline(always)]
pub(crate) fn four_p(two_a: i128, b: i128, t: i128) -> i128 {
    t.wrapping_mul(two_a.wrapping_add(b.wrapping_mul(t)))
}

impl IntRamp {
    /// The local edge of the current step if the f64 guess proves itself
    /// (`P(e − ½) < M ≤ P(e + ½)`, as [`IntPiece::checked_guess`]); moves on to the next
    /// step either way. `4·P(2e − 1)` follows from `4·P(2e + 1)` by the difference
    /// `4A + 8B·e`: every exact value lies below 2^127, so the wrapping arithmetic gives
    /// it exactly.
    #[inline(always)]
    pub(crate) fn next_local(&mut self) -> Option<u64> {
        let mf = self.m0 + (self.j as f64) * self.den;
        let m4 = self.m4;
        self.j += 1;
        self.m4 = m4.wrapping_add(self.dm4);
        // the root (√Y − A)/(2B) without a divide: only a guess, so the cancellation
        // at a decel's start (ε·A/|2B|, ~10⁻⁸ ticks) costs at most a kernel fallback
        let tau = (crate::real::fm::sqrt((self.a_sq + self.b4 * mf).max(0.0)) - self.a) * self.h;
        if !(tau >= 1.0 && tau < self.last) {
            return None;
        }
        // the nearest integer (ties to even: a guess, the check decides) by the magic
        // number 1.5·2^52, exact for τ < 2^51 (`ramp` checks D)
        let e = ((tau + MAGIC).to_bits() & ((1u64 << 52) - 1)) - (1u64 << 51);
        // 4·P at 2e + 1 as t·(2A + B·t): two wide multiplies by the 64-bit t
        if self.narrow {
            // the same in 64 bits: every exact value of this piece is below 2^62
            let (m4, t) = (m4 as i64, (2 * e + 1) as i64);
            let above =
                t.wrapping_mul((self.two_a as i64).wrapping_add((self.b as i64).wrapping_mul(t)));
            let below = above
                .wrapping_sub(self.four_a as i64)
                .wrapping_sub((self.eight_b as i64).wrapping_mul(e as i64));
            return (above >= m4 && below < m4).then_some(e);
        }
        let above = four_p(self.two_a, self.b, (2 * e + 1) as i128);
        let below = above
            .wrapping_sub(self.four_a)
            .wrapping_sub(self.eight_b.wrapping_mul(e as i128));
        (above >= m4 && below < m4).then_some(e)
    }
}

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
    /// The move's index (1-based) of this piece's first step, and its number of steps
    /// (step i belongs to the first piece whose end position is ≥ i; 0 if none).
    pub first: u64,
    pub steps: u64,
    kernel: StepKernel,
    wide: Option<WideRadicand>,
    /// `A`, `B`, `Den`, the first step's `M` and `D − 1` in f64 (as bits, so the piece
    /// stays `Eq`), for [`IntPiece::edge`]'s guess.
    guess: [u64; 5],
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

fn wide(x: u128) -> U256 {
    U256::from_u128(x)
}

/// A 256-bit value below 2^128 as u128.
fn narrow(x: &U256) -> Option<u128> {
    (x.bits() <= 128).then(|| {
        let b = x.to_le_bytes();
        let mut lo = [0u8; 16];
        lo.copy_from_slice(&b[..16]);
        u128::from_le_bytes(lo)
    })
}

impl IntPiece {
    /// A placeholder for unused slots of a profile.
    pub(super) const EMPTY: IntPiece = IntPiece {
        t0: 0,
        dur: 0,
        den: 1,
        a: 0,
        b: 0,
        c: 0,
        m_end: 0,
        first: 1,
        steps: 0,
        kernel: StepKernel {
            mode: KernelMode::Cruise,
            y0: 0,
            dy: 0,
            k: 0,
            dv: 1,
        },
        wide: None,
        guess: [0; 5],
    };

    /// Fills a profile's unused slots. Every byte is zero, so a profile's array starts as
    /// one memset instead of a copy of [`EMPTY`](Self::EMPTY) per slot (its den, first
    /// step and kernel are nonzero); no slot past a profile's length is ever read.
    pub(super) const UNUSED: IntPiece = IntPiece {
        t0: 0,
        dur: 0,
        den: 0,
        a: 0,
        b: 0,
        c: 0,
        m_end: 0,
        first: 0,
        steps: 0,
        kernel: StepKernel {
            mode: KernelMode::Accel,
            y0: 0,
            dy: 0,
            k: 0,
            dv: 0,
        },
        wide: None,
        guess: [0; 5],
    };

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
        mul(8, m_end)?;
        // the first step above p0 = C/Den, M₀ = Den·first − C ∈ (0, Den]
        let first = c / den + 1;
        let m0 = den * first - c;
        let steps = if m0 <= m_end {
            (m_end - m0) / den + 1
        } else {
            0
        };
        let b = if neg { -(bm as i128) } else { bm as i128 };
        let mut piece = IntPiece {
            t0,
            dur,
            den,
            a,
            b,
            c,
            m_end,
            first: u64::try_from(first).map_err(|_| IntError::TooWide)?,
            steps: u64::try_from(steps).map_err(|_| IntError::TooWide)?,
            ..IntPiece::EMPTY
        };
        if steps > 0 {
            piece.set_kernel(m0, m0 + (steps - 1) * den)?;
            piece.guess =
                [a as f64, b as f64, den as f64, m0 as f64, dur as f64 - 1.0].map(f64::to_bits);
        }
        Ok(piece)
    }

    /// The kernel constants for steps with targets `m0` … `m_last`.
    fn set_kernel(&mut self, m0: u128, m_last: u128) -> Result<(), IntError> {
        let (a, bm, den) = (self.a, self.b.unsigned_abs(), self.den);
        let kernel = &mut self.kernel;
        if bm == 0 {
            // Cruise: e = ⌊(2M + A − 1)/2A⌋, all below 2^126
            *kernel = StepKernel {
                mode: KernelMode::Cruise,
                y0: 2 * m0 + a - 1,
                dy: 2 * den,
                k: 0,
                dv: 2 * a,
            };
            return Ok(());
        }
        let (mode, k) = if self.b > 0 {
            (KernelMode::Accel, bm as i128 - a as i128 - 1)
        } else {
            (KernelMode::Decel, (a + bm - 1) as i128)
        };
        // Y = A² ± 4|B|M: every term below 2^252 (A, B, M < 2^124), so no overflow
        let a2 = wide(a).wrapping_mul(&wide(a));
        let dy = wide(4 * bm).wrapping_mul(&wide(den));
        let at = |m: u128| {
            let t = wide(4 * bm).wrapping_mul(&wide(m));
            if mode == KernelMode::Accel {
                a2.wrapping_add(&t)
            } else {
                a2.wrapping_sub(&t)
            }
        };
        let (y0, y_last) = (at(m0), at(m_last));
        *kernel = StepKernel {
            mode,
            y0: 0,
            dy: 0,
            k,
            dv: 2 * bm,
        };
        // Y is largest at the last step (Accel) or the first (Decel)
        match (narrow(&y0), narrow(&y_last), narrow(&dy)) {
            (Some(y0), Some(_), Some(dy)) => {
                kernel.y0 = y0;
                kernel.dy = dy;
            }
            _ => self.wide = Some(WideRadicand { y0, dy }),
        }
        Ok(())
    }

    /// The per-step kernel, or None when this piece's `Y` needs more than 128 bits.
    pub fn kernel(&self) -> Option<&StepKernel> {
        self.wide.is_none().then_some(&self.kernel)
    }

    /// `M = Den·i − C` for a step i past this piece's start (None if i is at or before it).
    pub fn target(&self, i: u64) -> Option<u128> {
        let m = self.den.checked_mul(i as u128)?.checked_sub(self.c)?;
        (m > 0).then_some(m)
    }

    /// Whether the piece is at constant speed.
    #[inline(always)]
    pub fn is_cruise(&self) -> bool {
        self.kernel.mode == KernelMode::Cruise
    }

    /// The constant-speed edges from step j on (absolute ticks), if this is a cruise
    /// piece whose accumulator fits ([`StepKernel::cruise_accumulator`]).
    pub fn cruise_accumulator(&self, j: u64) -> Option<StepAccumulator> {
        self.kernel().and_then(|k| k.cruise_accumulator(j, self.t0))
    }

    /// [`StepKernel::cruise_line`] of this piece, if it is a cruise on the 128-bit path.
    pub(crate) fn cruise_line(&self) -> Option<(u128, u128, u128)> {
        self.kernel().and_then(|k| k.cruise_line(self.t0))
    }

    /// The edge tick of the piece's j-th step (`j < steps`).
    #[inline]
    pub fn edge(&self, j: u64) -> u64 {
        let local = match &self.wide {
            None => match self.checked_guess(j) {
                Some(e) => e,
                None => self.kernel.local_edge(j),
            },
            Some(w) => self.wide_local_edge(w, j),
        };
        self.t0 + local
    }

    /// The local edge of step j from an f64 guess, proved in integers: e is the edge iff
    /// `P(e − ½) < M ≤ P(e + ½)` (`P(τ) = A·τ + B·τ²`, increasing on the piece), checked
    /// as `2A·t + B·t² ⋚ 4M` at `t = 2e ± 1` (two multiplies each, every value below
    /// 2^127 for `t ≤ 2D + 1` by the planning bounds). `None` (the kernel decides) when
    /// the check fails — near a half tick — or at the piece's first and last tick; always
    /// `None` on Cruise, whose kernel has no root.
    #[inline(always)]
    fn checked_guess(&self, j: u64) -> Option<u64> {
        if self.kernel.mode == KernelMode::Cruise {
            return None;
        }
        let [a, b, den, m0, last] = self.guess.map(f64::from_bits);
        let mf = m0 + j as f64 * den;
        // the stable root 2M/(A + √(A² + 4BM)) (no cancellation), rounded to a tick
        let tau = 2.0 * mf / (a + crate::real::fm::sqrt((a * a + 4.0 * b * mf).max(0.0)));
        if !(tau >= 1.0 && tau < last) {
            return None;
        }
        // in range for a plain (non-saturating) conversion
        let e = (tau + 0.5) as i64 as u64;
        let m = self
            .den
            .wrapping_mul((self.first + j) as u128)
            .wrapping_sub(self.c);
        let m4 = (4 * m) as i128;
        let p4 = |t: u64| four_p(2 * self.a as i128, self.b, t as i128);
        (p4(2 * e + 1) >= m4 && p4(2 * e - 1) < m4).then_some(e)
    }

    /// The guess-and-check state for a run of this piece's steps from step j, with the
    /// piece's constants in local variables; `None` on Cruise and on wide pieces.
    #[inline]
    pub(crate) fn ramp(&self, j: u64) -> Option<IntRamp> {
        if self.kernel.mode == KernelMode::Cruise || self.wide.is_some() {
            return None;
        }
        let [a, b, den, m0, last] = self.guess.map(f64::from_bits);
        if !(last < (1u64 << 50) as f64) {
            return None;
        }
        let m = self
            .den
            .wrapping_mul((self.first + j) as u128)
            .wrapping_sub(self.c);
        Some(IntRamp {
            a,
            a_sq: a * a,
            b4: 4.0 * b,
            h: 1.0 / (2.0 * b),
            den,
            m0,
            last,
            j: j as i64,
            m4: (4 * m) as i128,
            dm4: (4 * self.den) as i128,
            two_a: 2 * self.a as i128,
            four_a: 4 * self.a as i128,
            b: self.b,
            eight_b: self.b.wrapping_mul(8),
            narrow: self.fits_62(),
        })
    }

    /// Whether every value of [`IntRamp::next_local`]'s check fits in 62 bits.
    fn fits_62(&self) -> bool {
        let lim = 1u128 << 62;
        let small = |x: Option<u128>| x.is_some_and(|x| x < lim);
        let t = 2 * self.dur as u128 + 1;
        let b = self.b.unsigned_abs();
        small(self.a.checked_mul(2 * t))
            && small(b.checked_mul(t).and_then(|x| x.checked_mul(t)))
            && small(
                b.checked_mul(8 * self.dur as u128 + 8)
                    .and_then(|x| x.checked_add(4 * self.a)),
            )
            && small(
                self.m_end
                    .checked_add(self.den)
                    .and_then(|x| x.checked_mul(4)),
            )
    }

    /// The exact kernel's local edge, out of the ramp loop (rarely taken).
    #[cold]
    #[inline(never)]
    pub(crate) fn kernel_local_edge(&self, j: u64) -> u64 {
        self.kernel.local_edge(j)
    }

    /// [`StepKernel::local_edge`] with a 256-bit radicand (the root is below 2^126).
    fn wide_local_edge(&self, w: &WideRadicand, j: u64) -> u64 {
        let d = U256::from_u64(j).wrapping_mul(&w.dy);
        let y = if self.kernel.mode == KernelMode::Decel {
            w.y0.wrapping_sub(&d)
        } else {
            w.y0.wrapping_add(&d)
        };
        let r = y.floor_sqrt_vartime();
        let square = r.wrapping_mul(&r) == y;
        let root = narrow(&r).unwrap_or(u128::MAX);
        divide(self.kernel.numerator(0, root, square), self.kernel.dv)
    }

    /// Compares `Den·(p(τ) − p0)` at local time `tau2/2` ticks with `m`: exact, for tests.
    pub fn cmp_at_half_ticks(&self, tau2: u128, m: u128) -> core::cmp::Ordering {
        // 4(A·τ + B·τ²) = 2A·tau2 + B·tau2²
        let lhs = 2 * self.a as i128 * tau2 as i128 + self.b * (tau2 * tau2) as i128;
        lhs.cmp(&(4 * m as i128))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    impl IntPiece {
        /// The same piece on the 256-bit path.
        fn forced_wide(mut self) -> Self {
            if self.kernel.mode != KernelMode::Cruise {
                let k = &self.kernel;
                self.wide = Some(WideRadicand {
                    y0: wide(k.y0),
                    dy: wide(k.dy),
                });
            }
            self
        }
    }

    /// The first tick e with p(e + ½) ≥ the target, by scanning: the nearest tick with
    /// an exact half tick going down (p is non-decreasing).
    fn brute_edge(p: &IntPiece, m: u128) -> u64 {
        (0..=p.dur)
            .find(|&e| p.cmp_at_half_ticks(2 * e as u128 + 1, m).is_ge())
            .unwrap_or(p.dur)
    }

    proptest! {
        /// Small pieces, so exact squares and exact half ticks are frequent: every step of
        /// both the 128-bit and the 256-bit kernel equals the scan.
        #[test]
        fn kernels_match_a_scan(
            dur in 1u64..120, g in 1u128..12, u in 0u128..40, w in 0u128..40, s in 0u128..50,
        ) {
            let Ok(p) = IntPiece::new(0, dur, g, u, w, s) else { return Ok(()) };
            prop_assert!(p.kernel().is_some());
            let wide = p.forced_wide();
            // the ramp run's check, in 64 and in 128 bits: a tick it gives is the scan's
            let mut ramps = p.ramp(0).map(|r| [r, IntRamp { narrow: false, ..r }]);
            if let Some([r, _]) = &ramps {
                prop_assert!(r.narrow);
            }
            for j in 0..p.steps {
                let m = p.target(p.first + j).unwrap();
                let want = brute_edge(&p, m);
                if let Some(rs) = &mut ramps {
                    for r in rs.iter_mut() {
                        if let Some(e) = r.next_local() {
                            prop_assert_eq!(p.t0 + e, want, "ramp {:?} step {}", p, j);
                        }
                    }
                }
                prop_assert_eq!(p.edge(j), want, "{:?} step {}", p, j);
                prop_assert_eq!(p.t0 + p.kernel().unwrap().local_edge(j), want);
                prop_assert_eq!(wide.edge(j), want, "wide {:?} step {}", p, j);
            }
            // the steps are exactly those the piece covers
            prop_assert_eq!((p.first + p.steps) as u128, (p.c + p.m_end) / p.den + 1);
        }

        /// Constant-speed pieces: the accumulator from any step equals the exact nearest
        /// tick `t0 + ⌈M/A − ½⌉` (u128: ties down), in windows up to 2^32 steps on.
        #[test]
        fn cruise_accumulator_matches_exact_rationals(
            t0 in 0u64..1 << 40, g in 1u128..5000, u in 1u128..100_000, s in 0u128..1 << 20,
            far in 0u64..2, slow in 0u64..2,
        ) {
            // long enough for 2^32 + 3000 steps at u/g steps a tick
            let dur = ((1u128 << 33) * g / u + 10_000) as u64 * (1 + slow);
            let p = IntPiece::new(t0, dur, g, u, u, s).unwrap();
            prop_assume!(p.kernel().is_some());
            let j0 = if far == 1 { (1u64 << 32) - 7 } else { 0 };
            prop_assume!(p.steps > j0 + 3000);
            let mut acc = p.cruise_accumulator(j0).expect("cruise");
            for j in j0..j0 + 3000 {
                let m = p.target(p.first + j).unwrap();
                // ⌈M/A − ½⌉ = ⌈(2M − A)/2A⌉
                let (num, den) = (2 * m as i128 - p.a as i128, 2 * p.a as i128);
                let want = p.t0 as i128 + num.div_euclid(den) + (num.rem_euclid(den) != 0) as i128;
                let got = acc.next_edge();
                prop_assert_eq!(got as i128, want, "{:?} step {}", p, j);
                prop_assert_eq!(got, p.edge(j));
            }
        }
    }

    /// 32 000 steps/s at 50 MHz: 1562.5 ticks a step, every other step on an exact half
    /// tick, which goes to the earlier tick.
    #[test]
    fn half_tick_cruise_ties_go_down() {
        // speed u/g steps per tick = 32 000 / 50 M = 4 / 6250
        let p = IntPiece::new(0, 50_000_000, 6250, 4, 4, 0).unwrap();
        assert_eq!(p.steps, 32_000);
        let mut acc = p.cruise_accumulator(0).unwrap();
        for i in 1..=p.steps {
            let want = if i % 2 == 1 {
                (3125 * i - 1) / 2
            } else {
                3125 * i / 2
            };
            assert_eq!(acc.next_edge(), want, "step {i}");
        }
        assert!(IntPiece::new(0, 100, 1, 1, 3, 0)
            .unwrap()
            .cruise_accumulator(0)
            .is_none());
    }
}
