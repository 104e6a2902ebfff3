//! Polynomial pieces (S-curves: cubic; scurve4, seed 003's jerk-continuous curve: quartic)
//! by an integer forward-difference chain, one tick at a time: no root is ever taken or
//! approximated, and every edge is DESIGN.md §1's nearest tick.
//!
//! # The chain
//! On a piece `p(τ) = p0 + c1·τ + … + c_n·τⁿ` (n ≤ 4, f64 coefficients taken as the binary
//! rationals they are) starting at `t0 = m/2^s0`, the upper half tick of tick `e` is
//! `τ = w/D` with `D = h·f`, `h = 2^(s0+1)` and `w = 2^s0·(2e + 1) − 2f·m` (as in `cubic.rs`).
//! So `Q(e) = 2^S·Dⁿ·p(τ)` is an integer polynomial in `d = e − lo` (lo the piece's first
//! tick), `Q = Σ A_j·d^j` with `A_j = h^j·Σ_{k≥j} C(k,j)·C_k·D^(n−k)·w_lo^(k−j)` (`C_k` the
//! coefficients times 2^S), and its forward differences `Δ^m Q(0) = Σ_k A_k·m!·S(k,m)`
//! (Stirling numbers of the second kind) are integers. Per tick the chain adds
//! `Q += Δ¹, Δ¹ += Δ², …` (n wide additions, all from the old values).
//!
//! Step i's edge is the least tick e (from the last edge) with `p((e + ½)/f) ≥ i`, i.e.
//! `R = Q(e) − i·K ≥ 0` with `K = 2^S·Dⁿ`: exactly `p((e − ½)/f) < i ≤ p((e + ½)/f)`, an
//! exact half tick going to the earlier tick. The chain keeps `R` (not Q): an edge takes K
//! from it, in the same tick's advance (`R += Δ¹ − K`): a piece must make less than one step
//! a tick (`max|Δ¹| < K`, checked), so the next step is never due at the same tick. A piece
//! whose chain reaches its last tick without the step puts its remaining steps there. Every value is divided by the largest power of two g dividing Δ¹…Δⁿ and K,
//! with `R` rounded down (the sign of `R + multiple of g` is kept). Steps belong to pieces
//! as the float generator assigns them (up to ⌊end of the piece⌋); a piece's steps stay
//! within its ticks (its last tick when the chain reaches it first), and step N is at
//! `round(f·T)`.
//!
//! # Widths
//! Each register's width is a bound over the piece's ticks (`|Δ^m(d)| ≤ Σ_j d^j·|Δ^(m+j)(0)|`;
//! R within `|R(lo)| + K + d·max|Δ¹|`), plus a sign bit. A piece needing more than the
//! caller's widths is a typed error, never a wrong edge.

use super::chain_recurrence::ChainRecurrence;
use super::cubic::{nearest_tick, shr_floor};
use super::recurrence::RecurrenceCount;
use super::track::{floor_u64, places, round_ticks, scaled, split, Si, W};
use crate::piece::Law;
use crate::profile::Profile;
use thiserror::Error;

/// 64-bit limbs of a chain value as the reference holds it (512 bits).
pub const CHAIN_LIMBS: usize = 8;

/// A chain value: two's complement, little-endian limbs.
pub type ChainValue = [u64; CHAIN_LIMBS];

/// Bits of each register of a chain (two's complement, sign included).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChainWidths {
    /// `R = Q − i·K`.
    pub r: u32,
    /// `Δ¹ … Δ⁴`.
    pub diff: [u32; 4],
    /// K (positive).
    pub k: u32,
}

impl ChainWidths {
    /// The widest register.
    pub fn max(&self) -> u32 {
        self.diff.iter().copied().fold(self.r.max(self.k), u32::max)
    }

    /// The register-by-register maximum of two.
    pub fn union(self, o: ChainWidths) -> ChainWidths {
        ChainWidths {
            r: self.r.max(o.r),
            diff: core::array::from_fn(|m| self.diff[m].max(o.diff[m])),
            k: self.k.max(o.k),
        }
    }

    /// Whether every register of `self` fits in `limit`'s.
    pub fn fits(&self, limit: &ChainWidths) -> bool {
        self.union(*limit) == *limit
    }

    /// Every register `bits` wide.
    pub const fn uniform(bits: u32) -> ChainWidths {
        ChainWidths {
            r: bits,
            diff: [bits; 4],
            k: bits,
        }
    }
}

/// Why a profile cannot run on a chain.
#[derive(Clone, Copy, Debug, Error, PartialEq, Eq)]
pub enum ChainError {
    #[error("piece {piece} is not a polynomial of degree at most 4")]
    /// A shaped (non-polynomial) piece, a negative start time or a non-finite value.
    NotPolynomial {
        /// The piece (0-based).
        piece: usize,
    },
    #[error("piece {piece} needs registers of {needed:?} bits, more than {limit:?}")]
    /// A piece's chain needs wider registers than the limit (or than 512 bits).
    TooWide {
        /// The piece (0-based).
        piece: usize,
        /// The widths it needs (0 where beyond 512 bits).
        needed: ChainWidths,
        /// The widths allowed.
        limit: ChainWidths,
    },
    #[error("piece {piece} may make more than one step in a tick")]
    /// A piece whose speed bound reaches a step per tick: the chain makes at most one
    /// edge per tick as it advances.
    TooFast {
        /// The piece (0-based).
        piece: usize,
    },
    #[error("the move is longer than 2^50 ticks")]
    /// The move's end tick does not fit.
    TooLong,
}

/// One piece's chain, as a board loads it: steps `first..=last` start their search at
/// tick `lo` and end at tick `hi` at the latest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainPiece {
    /// The piece (0-based) of the profile.
    pub piece: usize,
    /// Its first step.
    pub first: u64,
    /// Its last step.
    pub last: u64,
    /// The tick of the initial values.
    pub lo: u64,
    /// The last tick a step may take.
    pub hi: u64,
    /// The polynomial's degree (1 to 4): the differences above it are zero.
    pub degree: u8,
    /// `R = Q(lo) − first·K`, reduced by g.
    pub r: ChainValue,
    /// `Δ¹ … Δ⁴` at lo, reduced by g.
    pub diff: [ChainValue; 4],
    /// K, reduced by g.
    pub k: ChainValue,
    /// Widths the piece needs.
    pub widths: ChainWidths,
}

/// Stirling numbers times m!: `Δ^m d^k` at d = 0 (row k, column m − 1).
const DIFF_OF_POWER: [[u32; 4]; 5] = [
    [0, 0, 0, 0],
    [1, 0, 0, 0],
    [1, 2, 0, 0],
    [1, 6, 6, 0],
    [1, 14, 36, 24],
];

fn binom(k: usize, j: usize) -> u128 {
    const B: [[u128; 5]; 5] = [
        [1, 0, 0, 0, 0],
        [1, 1, 0, 0, 0],
        [1, 2, 1, 0, 0],
        [1, 3, 3, 1, 0],
        [1, 4, 6, 4, 1],
    ];
    B[k][j]
}

fn pow(x: Si, n: usize) -> Option<Si> {
    (0..n).try_fold(Si::from_u128(1), |acc, _| acc.mul(x))
}

fn to_value(x: &Si) -> ChainValue {
    let b = x.mag.to_le_bytes();
    let mut v: ChainValue = core::array::from_fn(|k| {
        let mut w = [0u8; 8];
        w.copy_from_slice(&b[8 * k..8 * k + 8]);
        u64::from_le_bytes(w)
    });
    if x.neg {
        let mut carry = 1u64;
        for limb in v.iter_mut() {
            let (s, c) = (!*limb).overflowing_add(carry);
            *limb = s;
            carry = c as u64;
        }
    }
    v
}

/// Bits of a two's complement register holding any value of magnitude ≤ `x`.
fn signed_bits(x: &Si) -> u32 {
    x.mag.bits_vartime() + 1
}

impl ChainPiece {
    /// Piece `k` of `profile` on a clock of `clock` Hz for its steps `first..=last`.
    pub fn new(
        profile: &Profile,
        clock: u64,
        k: usize,
        first: u64,
        last: u64,
    ) -> Result<ChainPiece, ChainError> {
        let not_poly = ChainError::NotPolynomial { piece: k };
        let too_wide = ChainError::TooWide {
            piece: k,
            needed: ChainWidths::default(),
            limit: ChainWidths::uniform(64 * CHAIN_LIMBS as u32),
        };
        let p = profile.pieces().get(k).ok_or(not_poly)?;
        let Law::Poly { c1, c2, c3, c4 } = p.law else {
            return Err(not_poly);
        };
        let coef = [p.p0, c1, c2, c3, c4];
        let degree = coef.iter().rposition(|&c| c != 0.0).unwrap_or(0).max(1);
        let sc = coef
            .iter()
            .try_fold(0, |s: u32, &c| places(c).map(|q| s.max(q)))
            .ok_or(not_poly)?;
        let mut cs = [Si::ZERO; 5];
        for (s, &c) in cs.iter_mut().zip(&coef) {
            *s = scaled(c, sc).ok_or(not_poly)?;
        }
        let (tneg, tm, te) = split(p.t0).ok_or(not_poly)?;
        if tneg && tm != 0 {
            return Err(not_poly);
        }
        let lo = nearest_tick(clock, p.t0, 0.0).ok_or(not_poly)?;
        let hi = nearest_tick(clock, p.t0, p.dur).ok_or(not_poly)?;
        let wide = |x: Option<Si>| x.ok_or(too_wide);
        // t0 = m/2^s0
        let (m, s0) = match (tm, te) {
            (0, _) => (Si::ZERO, 0),
            (_, e) if e >= 0 => (wide(Si::pos(W::from_u64(tm)).shl(e as u32))?, 0),
            (_, e) => (Si::pos(W::from_u64(tm)), e.unsigned_abs()),
        };
        let f = Si::from_u128(clock as u128);
        let h = wide(Si::from_u128(1).shl(s0 + 1))?;
        let dd = wide(h.mul(f))?;
        let fm2 = wide(f.mul(m).and_then(|x| x.shl(1)))?;
        let w_lo = wide(
            Si::from_u128(2 * lo as u128 + 1)
                .shl(s0)
                .and_then(|x| x.sub(fm2)),
        )?;
        let n = degree;
        let mut a = [Si::ZERO; 5];
        for (j, aj) in a.iter_mut().enumerate().take(n + 1) {
            let mut sum = Si::ZERO;
            for (kk, ck) in cs.iter().enumerate().take(n + 1).skip(j) {
                let t = pow(dd, n - kk)
                    .and_then(|x| x.mul(*ck))
                    .and_then(|x| x.mul(pow(w_lo, kk - j)?))
                    .and_then(|x| x.mul(Si::from_u128(binom(kk, j))));
                sum = wide(t.and_then(|t| sum.add(t)))?;
            }
            *aj = wide(pow(h, j).and_then(|x| x.mul(sum)))?;
        }
        let big_k = wide(pow(dd, n).and_then(|x| x.shl(sc)))?;
        let mut diff = [Si::ZERO; 4];
        for (m, dm) in diff.iter_mut().enumerate() {
            for (kk, ak) in a.iter().enumerate().skip(1) {
                let c = DIFF_OF_POWER[kk][m];
                if c != 0 {
                    *dm = wide(ak.mul(Si::from_u128(c as u128)).and_then(|t| dm.add(t)))?;
                }
            }
        }
        let r = wide(
            big_k
                .mul(Si::from_u128(first as u128))
                .and_then(|x| a[0].sub(x)),
        )?;
        let z = diff
            .iter()
            .chain(core::iter::once(&big_k))
            .filter(|x| !x.is_zero())
            .map(|x| x.mag.trailing_zeros_vartime())
            .min()
            .unwrap_or(0);
        let r = shr_floor(r, z);
        let big_k = shr_floor(big_k, z);
        let diff = diff.map(|x| shr_floor(x, z));
        // widths over d ∈ [0, dmax]
        let dmax = Si::from_u128(hi.saturating_sub(lo) as u128 + 1);
        let mut bound = [Si::ZERO; 4];
        for m in 0..4 {
            let mut b = Si::ZERO;
            let mut dj = Si::from_u128(1);
            for dm in &diff[m..] {
                b = wide(dj.mul(Si::pos(dm.mag)).and_then(|t| b.add(t)))?;
                dj = wide(dj.mul(dmax))?;
            }
            bound[m] = b;
        }
        let r_bound = wide(
            dmax.mul(bound[0])
                .and_then(|x| x.add(Si::pos(r.mag)))
                .and_then(|x| x.add(big_k)),
        )?;
        // |Δ¹| < K: less than one step per tick, so an edge and the next tick's advance
        // may share a clock (R + Δ¹ − K)
        if bound[0].mag >= big_k.mag {
            return Err(ChainError::TooFast { piece: k });
        }
        let widths = ChainWidths {
            r: signed_bits(&r_bound),
            diff: core::array::from_fn(|m| if m < n { signed_bits(&bound[m]) } else { 0 }),
            k: signed_bits(&big_k),
        };
        if widths.max() > 64 * CHAIN_LIMBS as u32 - 2 {
            return Err(ChainError::TooWide {
                piece: k,
                needed: widths,
                limit: ChainWidths::uniform(64 * CHAIN_LIMBS as u32 - 2),
            });
        }
        Ok(ChainPiece {
            piece: k,
            first,
            last,
            lo,
            hi,
            degree: n as u8,
            r: to_value(&r),
            diff: diff.map(|x| to_value(&x)),
            k: to_value(&big_k),
            widths,
        })
    }
}

fn add_to(a: &mut ChainValue, b: &ChainValue) {
    let mut carry = false;
    for (x, y) in a.iter_mut().zip(b) {
        let (s1, c1) = x.overflowing_add(*y);
        let (s2, c2) = s1.overflowing_add(carry as u64);
        *x = s2;
        carry = c1 | c2;
    }
}

fn sub_from(a: &mut ChainValue, b: &ChainValue) {
    let mut borrow = false;
    for (x, y) in a.iter_mut().zip(b) {
        let (d1, b1) = x.overflowing_sub(*y);
        let (d2, b2) = d1.overflowing_sub(borrow as u64);
        *x = d2;
        borrow = b1 | b2;
    }
}

/// A chain running: the registers at tick `e`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Running {
    pub(super) piece: ChainPiece,
    pub(super) e: u64,
    pub(super) r: ChainValue,
    pub(super) diff: [ChainValue; 4],
}

impl Running {
    /// The next step's edge (before the last-edge floor), a clock of the board's chain per
    /// loop: at the piece's last tick the chain holds; else an edge takes K and the chain
    /// advances in the same clock.
    fn edge(&mut self) -> u64 {
        loop {
            if self.e >= self.piece.hi {
                return self.e;
            }
            let emit = self.r[CHAIN_LIMBS - 1] >> 63 == 0;
            if emit {
                sub_from(&mut self.r, &self.piece.k);
            }
            // Q += Δ¹, Δ¹ += Δ², … from the old values
            add_to(&mut self.r, &self.diff[0]);
            for m in 0..3 {
                let next = self.diff[m + 1];
                add_to(&mut self.diff[m], &next);
            }
            self.e += 1;
            if emit {
                return self.e - 1;
            }
        }
    }
}

/// Every edge of a profile of polynomial pieces by the chain, as a board computes them:
/// the same edges as [`EdgeGenerator`](crate::EdgeGenerator) on that profile.
#[derive(Clone, Debug)]
pub struct ChainEdges {
    profile: Profile,
    clock: u64,
    next: u64,
    end_tick: u64,
    last_edge: u64,
    piece: usize,
    run: Option<Running>,
    widths: ChainWidths,
    /// Edges by the per-step recurrence instead of a tick at a time
    /// ([`ChainEdges::by_recurrence`]).
    recurrence: Option<ChainRecurrence>,
}

impl ChainEdges {
    /// The chain of `profile` at `clock` Hz with registers no wider than `limit`: every
    /// piece is entered now, so a move too wide is refused before it starts.
    pub fn new(profile: Profile, clock: u64, limit: ChainWidths) -> Result<ChainEdges, ChainError> {
        let end_tick = round_ticks(clock, profile.duration()).ok_or(ChainError::TooLong)?;
        if end_tick > 1 << 50 {
            return Err(ChainError::TooLong);
        }
        let mut widths = ChainWidths::default();
        for c in pieces(&profile, clock) {
            let c = c?;
            if !c.widths.fits(&limit) {
                return Err(ChainError::TooWide {
                    piece: c.piece,
                    needed: c.widths,
                    limit,
                });
            }
            widths = widths.union(c.widths);
        }
        Ok(ChainEdges {
            profile,
            clock,
            next: 1,
            end_tick,
            last_edge: 0,
            piece: 0,
            run: None,
            widths,
            recurrence: None,
        })
    }

    /// The same edges by the per-step recurrence (chain_recurrence.rs), its work counted
    /// in [`ChainEdges::recurrence_tally`].
    pub fn by_recurrence(mut self) -> Self {
        self.recurrence = Some(ChainRecurrence::default());
        self
    }

    /// Back to the move's first step, with the recurrence's count cleared.
    pub fn restart(&mut self) {
        self.next = 1;
        self.last_edge = 0;
        self.piece = 0;
        self.run = None;
        if self.recurrence.is_some() {
            self.recurrence = Some(ChainRecurrence::default());
        }
    }

    /// Steps of the move.
    pub fn steps(&self) -> u64 {
        self.profile.steps()
    }

    /// The clock (Hz) its ticks count.
    pub fn clock(&self) -> u64 {
        self.clock
    }

    /// What the recurrence did so far (None without it).
    pub fn recurrence_tally(&self) -> Option<&RecurrenceCount> {
        self.recurrence.as_ref().map(|r| &r.count)
    }

    /// The widest each register gets over the move.
    pub fn widths(&self) -> ChainWidths {
        self.widths
    }

    /// The tick of step N, `round(f·T)`.
    pub fn end_tick(&self) -> u64 {
        self.end_tick
    }
}

/// The chains of a profile's pieces that hold steps (step N excepted: it is at
/// `round(f·T)`), in order.
pub fn pieces(
    profile: &Profile,
    clock: u64,
) -> impl Iterator<Item = Result<ChainPiece, ChainError>> + '_ {
    let n = profile.steps();
    let mut first = 1u64;
    (0..profile.len()).filter_map(move |k| {
        let last = floor_u64(profile.end_of(k)).min(n.saturating_sub(1));
        if first > last {
            return None;
        }
        let c = ChainPiece::new(profile, clock, k, first, last);
        first = last + 1;
        Some(c)
    })
}

impl Iterator for ChainEdges {
    type Item = u64;

    fn next(&mut self) -> Option<u64> {
        let i = self.next;
        let n = self.profile.steps();
        if i > n {
            return None;
        }
        self.next += 1;
        if i == n {
            self.last_edge = self.end_tick.max(self.last_edge);
            if let Some(rc) = &mut self.recurrence {
                rc.count.steps += 1;
            }
            return Some(self.last_edge);
        }
        if self.run.map_or(true, |r| r.piece.last < i) {
            let mut k = self.piece;
            while floor_u64(self.profile.end_of(k)) < i && k + 1 < self.profile.len() {
                k += 1;
            }
            self.piece = k;
            let last = floor_u64(self.profile.end_of(k)).min(n - 1);
            // checked in `new`: every piece's chain fits
            let piece = ChainPiece::new(&self.profile, self.clock, k, i, last).ok()?;
            self.run = Some(Running {
                piece,
                e: piece.lo,
                r: piece.r,
                diff: piece.diff,
            });
        }
        let run = self.run.as_mut()?;
        let e = match &mut self.recurrence {
            Some(rc) => {
                let guess = rc.history.predict();
                run.edge_by_recurrence(guess, &mut rc.count)
            }
            None => run.edge(),
        }
        .max(self.last_edge);
        self.last_edge = e;
        if let Some(rc) = &mut self.recurrence {
            rc.history.push(e);
            rc.count.steps += 1;
        }
        Some(e)
    }
}
