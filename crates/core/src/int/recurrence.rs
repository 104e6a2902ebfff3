//! The exact per-step recurrence: every edge predicted from the ones before it and proved
//! by an integer test, instead of a square root and a divide per step. This is the
//! algorithm a period calculator can run in a few clocks a step (docs/HDL.md, "The
//! per-step recurrence"); here it is a model, in exact integers, with its work counted.
//!
//! On a piece `P(τ) = A·τ + B·τ²` (piece.rs: positions in 1/Den steps above its start,
//! τ in ticks from `t0`) step i's edge is the one tick e with `P(e − ½) < M ≤ P(e + ½)`
//! (M its target, DESIGN.md §1's nearest tick, a half tick going to the earlier one)
//! wherever P increases, which it does on every tick of the piece but possibly its first
//! and its last. In doubled ticks `t = 2e + 1` the test's upper side is
//! `U(e) = 4·P(e + ½) = t·(2A + B·t)`, two multiplies by the narrow t, and its lower side
//! `U(e − 1) = U(e) − G(e)` with `G(e) = 4A + 8B·e`, an addition. A step:
//! 1. **predict** from the last four edges `e₁ … e₄` (periods `p₁ = e₁ − e₂`, …): the
//!    next period as the mean of the last two plus 1.5 times their mean second difference,
//!    `e = e₁ + ⌊(4·(p₁ + p₂) + 6·(p₁ − p₃))/8⌋`, which averages out the ticks' rounding
//!    (`e₁ + p₁` with two or three edges);
//! 2. **jump**: `U(e)` by the two multiplies;
//! 3. **walk**: while `U(e) < 4M`, e + 1 (U grows by `G(e + 1)`); while `U(e − 1) ≥ 4M`,
//!    e − 1 (U shrinks by `G(e)`). Additions only, a tick each. Below the edge
//!    `U(e) < 4M` and above it `U(e − 1) ≥ 4M`, so the walk ends at the edge, exactly.
//!
//! The closed form (the kernel's root and divide) is taken where the recurrence cannot
//! be: a move's first two steps (no period yet), a walk that reaches a piece's first or
//! last tick, a walk longer than its limit, and pieces wider than 128 bits. Every value
//! of the test lies below 2^127 for `t ≤ 2D + 1` (the planning bounds, as
//! [`IntPiece::edge`]'s check), so wrapping i128 arithmetic gives it exactly.

use super::gen::IntEdgeGenerator;
use super::piece::{four_p, IntPiece};
use super::plan::IntProfile;
use crate::MAX_PIECES;
use core::borrow::Borrow;

/// Tick moves after which a walk gives up and the step takes the closed form.
pub const WALK_LIMIT: u32 = 16;

/// What the recurrence did over the steps it made.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecurrenceCount {
    /// Steps made.
    pub steps: u64,
    /// Steps that took the closed form (the first two, a piece's boundary ticks, a walk
    /// over [`WALK_LIMIT`], a 256-bit piece).
    pub closed: u64,
    /// Steps whose walk gave up (counted in `closed` too, or in `searched` on a chain).
    pub abandoned: u64,
    /// Chain steps found by a search of probes (no prediction, or an abandoned walk).
    pub searched: u64,
    /// Jumps: one per step the recurrence tried, and one per probe of a chain's search.
    pub jumps: u64,
    /// Tick moves of all walks, abandoned ones included.
    pub moves: u64,
    /// Steps the recurrence made with 0, 1, 2 and 3 or more moves.
    pub by_moves: [u64; 4],
    /// The longest walk that found its edge.
    pub max_moves: u32,
}

/// Clocks a period calculator spends per operation of the recurrence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecurrenceClocks {
    /// A jump: the prediction and `U(e)`'s two multiplies.
    pub jump: u32,
    /// One tick of a walk, the test of the new candidate included.
    pub tick: u32,
    /// A step by the closed form.
    pub closed: u32,
}

impl RecurrenceClocks {
    /// The Verilog unit `ms_recur` (crates/hdl, 50 MHz on an ECP5): 5 clocks for the jump
    /// and the first test, one per tick moved; the closed form as the current core
    /// computes it at its default widths (`tdm::Latencies::RADIX4`: 51 clocks).
    pub const MODEL: RecurrenceClocks = RecurrenceClocks {
        jump: 5,
        tick: 1,
        closed: crate::tdm::Latencies::RADIX4.latency() as u32,
    };

    /// A model for a chain's jump: Newton's formula for R and Δ¹…Δ⁴ is ten products of
    /// a register by a binomial of the jump, one a clock through a pipelined multiplier;
    /// a tick a clock; the chain has no closed form.
    pub const CHAIN_MODEL: RecurrenceClocks = RecurrenceClocks {
        jump: 10,
        tick: 1,
        closed: 0,
    };
}

impl RecurrenceCount {
    /// Clocks for these steps at the given costs (an abandoned walk's jump and moves are
    /// spent before its closed form).
    pub fn clocks(&self, c: &RecurrenceClocks) -> u64 {
        self.jumps * c.jump as u64 + self.moves * c.tick as u64 + self.closed * c.closed as u64
    }

    /// Adds another count.
    pub fn add(&mut self, o: &RecurrenceCount) {
        self.steps += o.steps;
        self.closed += o.closed;
        self.abandoned += o.abandoned;
        self.searched += o.searched;
        self.jumps += o.jumps;
        self.moves += o.moves;
        for (a, b) in self.by_moves.iter_mut().zip(o.by_moves) {
            *a += b;
        }
        self.max_moves = self.max_moves.max(o.max_moves);
    }
}

/// The edges of an [`IntProfile`] by the recurrence, in absolute ticks: the same as
/// [`IntEdgeGenerator`]'s. It holds the profile (`Recurrence<IntProfile<N>, N>`) or a
/// reference to one, as [`IntEdgeGenerator`] does.
#[derive(Clone, Debug)]
pub struct Recurrence<P: Borrow<IntProfile<N>> = IntProfile, const N: usize = MAX_PIECES> {
    profile: P,
    piece: usize,
    /// The next step within the piece (0-based).
    j: u64,
    history: EdgeHistory,
    count: RecurrenceCount,
}

/// The last four edges of a move (absolute ticks), newest first: the prediction's input.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct EdgeHistory {
    last: [u64; 4],
    known: usize,
}

impl EdgeHistory {
    /// The predicted next edge, absolute (None before the second step). With four edges:
    /// the last edge plus the mean of the last two periods and 1.5 times the mean second
    /// difference over them (a floor of eighths), which averages the ticks' rounding
    /// noise; with two or three, the last period again.
    pub(super) fn predict(&self) -> Option<i128> {
        let [e1, e2, e3, e4] = self.last.map(|e| e as i128);
        match self.known {
            0 | 1 => None,
            2 | 3 => Some(2 * e1 - e2),
            _ => Some(e1 + ((4 * (e1 - e3) + 6 * (e1 - e2 - e3 + e4)) >> 3)),
        }
    }

    pub(super) fn push(&mut self, edge: u64) {
        self.last = [edge, self.last[0], self.last[1], self.last[2]];
        self.known = (self.known + 1).min(4);
    }
}

impl<P: Borrow<IntProfile<N>>, const N: usize> Recurrence<P, N> {
    /// The edges of `profile` (an `IntProfile` or a reference to one).
    pub fn new(profile: P) -> Self {
        Recurrence {
            profile,
            piece: 0,
            j: 0,
            history: EdgeHistory::default(),
            count: RecurrenceCount::default(),
        }
    }

    /// Back to the move's first step, with the count cleared.
    pub fn restart(&mut self) {
        self.piece = 0;
        self.j = 0;
        self.history = EdgeHistory::default();
        self.count = RecurrenceCount::default();
    }

    /// Steps of the whole move.
    pub fn steps(&self) -> u64 {
        self.profile.borrow().steps()
    }

    /// Tick of the move's end.
    pub fn end_tick(&self) -> u64 {
        self.profile.borrow().end_tick()
    }

    /// What it did so far.
    pub fn tally(&self) -> &RecurrenceCount {
        &self.count
    }
}

/// Step j of piece `p` by the recurrence after the edges in `history`: its local edge, or
/// None for the closed form; its work added to `count`.
fn walk(history: &EdgeHistory, count: &mut RecurrenceCount, p: &IntPiece, j: u64) -> Option<u64> {
    let guess = history.predict()?;
    let w = WalkInputs::new(p, j, guess - p.t0 as i128)?.walk();
    count.jumps += 1;
    count.moves += w.moves as u64;
    match w.edge {
        Some(e) => {
            count.by_moves[(w.moves as usize).min(3)] += 1;
            count.max_moves = count.max_moves.max(w.moves);
            Some(e)
        }
        None => {
            count.abandoned += w.abandoned as u64;
            None
        }
    }
}

/// What one step's walk starts from: the piece's `2A` and `B`, the step's `4M`, the
/// predicted local edge clamped to the ticks where P increases, `lo = 1 ..= hi = D − 1`.
/// These are the inputs of the Verilog unit (`ms_recur`), which gives [`Walk`]'s answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WalkInputs {
    /// `2A`.
    pub two_a: u128,
    /// `B` (negative on deceleration).
    pub b: i128,
    /// `4M`, M the step's target.
    pub m4: u128,
    /// The first candidate.
    pub e0: u64,
    /// The first tick the walk may visit.
    pub lo: u64,
    /// The last tick the walk may visit.
    pub hi: u64,
}

/// How a walk ended: at the edge, or not (the closed form decides), after `moves` ticks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Walk {
    /// The local edge, or None.
    pub edge: Option<u64>,
    /// Ticks moved.
    pub moves: u32,
    /// It stopped at [`WALK_LIMIT`] (else, without an edge, at `lo` or `hi`).
    pub abandoned: bool,
}

impl WalkInputs {
    /// Step j of piece `p` from the local tick `guess`; None on a piece with no tick
    /// where P surely increases or one wider than 128 bits.
    pub fn new(p: &IntPiece, j: u64, guess: i128) -> Option<WalkInputs> {
        p.kernel()?;
        let (lo, hi) = (1, p.dur.checked_sub(1)?);
        if hi < lo {
            return None;
        }
        let m = p.den.wrapping_mul((p.first + j) as u128).wrapping_sub(p.c);
        Some(WalkInputs {
            two_a: p.a.wrapping_mul(2),
            b: p.b,
            m4: m.wrapping_mul(4),
            e0: guess.clamp(lo as i128, hi as i128) as u64,
            lo,
            hi,
        })
    }

    /// The jump, `U(e0) = t·(2A + B·t)`, then the walk (module docs).
    pub fn walk(&self) -> Walk {
        let (two_a, b, m4) = (self.two_a as i128, self.b, self.m4 as i128);
        let (lo, hi) = (self.lo as i128, self.hi as i128);
        let mut e = self.e0 as i128;
        let t = 2 * e + 1;
        let bt = b.wrapping_mul(t);
        let mut u = four_p(two_a, b, t);
        // G(e) = U(e) − U(e − 1) = 4A + 8B·e = 4h with h = A + 2B·e = A + B·t − B
        let mut h = (two_a / 2).wrapping_add(bt).wrapping_sub(b);
        let mut moves = 0;
        let end = |edge, moves, abandoned| Walk {
            edge,
            moves,
            abandoned,
        };
        loop {
            let (up, down) = (u < m4, u.wrapping_sub(h.wrapping_mul(4)) >= m4);
            if !up && !down {
                return end(Some(e as u64), moves, false);
            }
            if (up && e == hi) || (down && e == lo) {
                return end(None, moves, false);
            }
            if moves == WALK_LIMIT {
                return end(None, moves, true);
            }
            if up {
                h = h.wrapping_add(b.wrapping_mul(2));
                u = u.wrapping_add(h.wrapping_mul(4));
                e += 1;
            } else {
                u = u.wrapping_sub(h.wrapping_mul(4));
                h = h.wrapping_sub(b.wrapping_mul(2));
                e -= 1;
            }
            moves += 1;
        }
    }
}

impl<P: Borrow<IntProfile<N>>, const N: usize> Iterator for Recurrence<P, N> {
    type Item = u64;

    fn next(&mut self) -> Option<u64> {
        let pieces = self.profile.borrow().pieces();
        while pieces.get(self.piece)?.steps <= self.j {
            self.piece += 1;
            self.j = 0;
        }
        let p = &pieces[self.piece];
        let edge = match walk(&self.history, &mut self.count, p, self.j) {
            Some(local) => p.t0 + local,
            None => {
                self.count.closed += 1;
                p.edge(self.j)
            }
        };
        self.j += 1;
        self.count.steps += 1;
        self.history.push(edge);
        Some(edge)
    }
}

/// Whether the recurrence gives `profile`'s edges (against [`IntEdgeGenerator`]), and
/// its count; the first step where they differ otherwise.
pub fn check<const N: usize>(profile: &IntProfile<N>) -> Result<RecurrenceCount, u64> {
    let mut r = Recurrence::new(profile);
    let mut g = IntEdgeGenerator::<&IntProfile<N>, N>::new(profile);
    let mut i = 0;
    loop {
        match (r.next(), g.next()) {
            (None, None) => return Ok(*r.tally()),
            (x, y) if x == y => i += 1,
            _ => return Err(i),
        }
    }
}

/// An edge stream made by a recurrence, with its work so far.
pub trait CountedEdges: Iterator<Item = u64> {
    /// What the recurrence did so far.
    fn counted(&self) -> RecurrenceCount;
}

impl<P: Borrow<IntProfile<N>>, const N: usize> CountedEdges for Recurrence<P, N> {
    fn counted(&self) -> RecurrenceCount {
        self.count
    }
}

impl CountedEdges for super::ChainEdges {
    fn counted(&self) -> RecurrenceCount {
        self.recurrence_tally().copied().unwrap_or_default()
    }
}

/// The calculator's busiest stretch of a move by a recurrence: over every `W` consecutive
/// steps, the clocks their edges cost (at `clocks`) per tick of time they span, the
/// largest such ratio. One calculator keeps `n` axes' FIFOs of `W` periods fed while the
/// sum of their loads stays below 1: with every axis on this move at its worst moment,
/// `n < 1 / peak`. Infinite if two edges share a tick.
pub fn peak_load<const W: usize>(edges: &mut impl CountedEdges, clocks: &RecurrenceClocks) -> f64 {
    let (mut cost, mut edge) = ([0u64; W], [0u64; W]);
    let (mut spent, mut peak) = (0u64, 0f64);
    let mut i = 0;
    loop {
        let before = edges.counted().clocks(clocks);
        let Some(e) = edges.next() else { return peak };
        let c = edges.counted().clocks(clocks) - before;
        // the window of steps i − W + 1 ..= i spans the ticks since step i − W's edge,
        // whose cost and edge the rings hold at i mod W until now
        spent += c;
        if i >= W {
            spent -= cost[i % W];
            let span = e - edge[i % W];
            peak = peak.max(if span == 0 {
                f64::INFINITY
            } else {
                spent as f64 / span as f64
            });
        }
        cost[i % W] = c;
        edge[i % W] = e;
        i += 1;
    }
}
