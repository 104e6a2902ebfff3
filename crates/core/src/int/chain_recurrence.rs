//! The per-step recurrence on a forward-difference chain (chain.rs): the S-curve families'
//! edges found by jumping the chain's registers to a predicted tick and walking from
//! there, instead of advancing them a tick a clock.
//!
//! At tick `start + d` the registers are Newton's forward formula of those at `start`:
//! `R(start + d) = R + Σ C(d, l)·Δˡ` and `Δᵐ(start + d) = Σ_{l ≥ m} C(d, l − m)·Δˡ`, so a
//! jump is a few multiplies of the registers by binomials of the narrow d. Step i's edge is
//! the least tick from `start` (the tick after the last edge) with `R ≥ 0`, or the piece's
//! last tick `hi` if none comes before it, as the chain makes it. From the prediction
//! (recurrence.rs) the walk moves a tick at a time (a forward or backward difference
//! step: additions); with no prediction (a move's first two steps) or after
//! [`WALK_LIMIT`] moves it searches instead — doubling, then halving the interval —
//! each probe a jump. The chain has no closed form, so nothing is counted as one.

use super::chain::{Running, CHAIN_LIMBS};
use super::recurrence::{EdgeHistory, RecurrenceCount, WALK_LIMIT};
use super::ChainValue;
use crypto_bigint::{NonZero, U512};

fn wide(v: &ChainValue) -> U512 {
    U512::from_words(*v)
}

/// `C(d, l)` for `l ≤ 4`, d below 2^64 (exact: at most 2^256 before the divide).
fn binomial(d: u64, l: usize) -> U512 {
    let mut num = U512::ONE;
    for k in 0..l as u64 {
        num = num.wrapping_mul(&U512::from_u64(d.wrapping_sub(k)));
    }
    let (q, _) = num.div_rem_vartime(&FACTORIAL[l]);
    q
}

/// `l!` for `l ≤ 4`, the divisors of [`binomial`].
const FACTORIAL: [NonZero<U512>; 5] = [
    NonZero::<U512>::ONE,
    NonZero::<U512>::ONE,
    NonZero::<U512>::new_unwrap(U512::from_u64(2)),
    NonZero::<U512>::new_unwrap(U512::from_u64(6)),
    NonZero::<U512>::new_unwrap(U512::from_u64(24)),
];

impl Running {
    /// The registers `d` ticks after `self.e` (two's complement, wrapping: the true values
    /// fit, chain.rs's widths).
    fn at(&self, d: u64) -> (ChainValue, [ChainValue; 4]) {
        let c: [U512; 5] = core::array::from_fn(|l| binomial(d, l));
        let diff = core::array::from_fn(|m| {
            (m..4)
                .fold(U512::ZERO, |s, l| {
                    s.wrapping_add(&c[l - m].wrapping_mul(&wide(&self.diff[l])))
                })
                .to_words()
        });
        (self.r_with(&c).to_words(), diff)
    }

    /// R `d` ticks after `self.e` alone, as [`Running::at`] gives it: `R + Σ C(d, l)·Δₗ`
    /// (Newton's forward formula).
    fn r_at(&self, d: u64) -> ChainValue {
        let c: [U512; 5] = core::array::from_fn(|l| binomial(d, l));
        self.r_with(&c).to_words()
    }

    fn r_with(&self, c: &[U512; 5]) -> U512 {
        (c[1..].iter().zip(&self.diff)).fold(wide(&self.r), |r, (cl, dl)| {
            r.wrapping_add(&cl.wrapping_mul(&wide(dl)))
        })
    }

    /// Whether step i is due at tick `self.e + d`: `R ≥ 0` there.
    fn due(&self, d: u64) -> bool {
        self.r_at(d)[CHAIN_LIMBS - 1] >> 63 == 0
    }

    /// The next step's edge by the recurrence from the prediction `guess` (absolute); the
    /// registers end as [`Running::edge`] leaves them, at the tick after it.
    pub(super) fn edge_by_recurrence(
        &mut self,
        guess: Option<i128>,
        n: &mut RecurrenceCount,
    ) -> u64 {
        let (start, hi) = (self.e, self.piece.hi);
        if start >= hi {
            return start;
        }
        // the least d in 0..=span with due(d), span (the last tick) if none
        let span = hi - start;
        let test = |d: u64| d >= span || self.due(d);
        let d = match guess {
            Some(g) => {
                let mut d = (g - start as i128).clamp(0, span as i128) as u64;
                n.jumps += 1;
                let mut moves = 0;
                let found = loop {
                    let step = if !test(d) {
                        Some(d + 1)
                    } else if d > 0 && test(d - 1) {
                        Some(d - 1)
                    } else {
                        break Some(d);
                    };
                    if moves == WALK_LIMIT {
                        break None;
                    }
                    moves += 1;
                    n.moves += 1;
                    d = step.unwrap_or(d);
                };
                match found {
                    Some(d) => {
                        n.by_moves[(moves as usize).min(3)] += 1;
                        n.max_moves = n.max_moves.max(moves);
                        d
                    }
                    None => {
                        n.abandoned += 1;
                        search(span, &test, n)
                    }
                }
            }
            None => search(span, &test, n),
        };
        // as the chain leaves them: at the edge's next tick, K taken (none at the last tick)
        if d >= span {
            (self.r, self.diff) = self.at(span);
            self.e = hi;
            return hi;
        }
        let (r, diff) = self.at(d + 1);
        let r = wide(&r).wrapping_sub(&wide(&self.piece.k)).to_words();
        (self.r, self.diff) = (r, diff);
        self.e = start + d + 1;
        start + d
    }
}

/// The least `d ≤ span` with `test(d)` (`test(span)` holds) by probes, each a jump:
/// d = 0, then doubling until one holds, then halving the interval.
fn search(span: u64, test: &impl Fn(u64) -> bool, n: &mut RecurrenceCount) -> u64 {
    n.searched += 1;
    if test(0) {
        return 0;
    }
    let (mut no, mut yes) = (0u64, span);
    let mut step = 1u64;
    while no + step < yes {
        n.jumps += 1;
        if test(no + step) {
            yes = no + step;
            break;
        }
        no += step;
        step *= 2;
    }
    while yes - no > 1 {
        let mid = no + (yes - no) / 2;
        n.jumps += 1;
        if test(mid) {
            yes = mid;
        } else {
            no = mid;
        }
    }
    yes
}

/// The recurrence's state in a chain run: the edge history and the count.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct ChainRecurrence {
    pub(super) history: EdgeHistory,
    pub(super) count: RecurrenceCount,
}
