//! The edge generator: step i happens at `t_i = min{t : p(t) = i}` and its edge is the
//! nearest tick, `ceil(f·t_i − ½)`: an exact half tick goes to the earlier tick
//! (DESIGN.md §1), as in the exactness test below and in `int`.
//!
//! Each step is solved in f64 (closed form on constant-acceleration pieces, safeguarded
//! Newton elsewhere) together with a bound on its rounding error in ticks. When `f·t_i` lies
//! within that bound of a half tick, the edge is settled in double-double arithmetic and
//! checked against `p((e − ½)/f) < i ≤ p((e + ½)/f)`, so every edge is the nearest tick,
//! not only most of them. On the other pieces most steps skip Newton: the tick
//! extrapolated from the last steps is proved by that same condition, computed in f64
//! beyond a bound on its rounding (`curve_run`). Memory is O(1); nothing allocates.

use core::borrow::Borrow;

use crate::accum::{float_cruise, FloatCruise, StepAccumulator};
use crate::dd::Dd;
use crate::error::{positive, PlanError};
use crate::jet::{self, LocalCubic};
use crate::piece::Law;
use crate::piece::Piece;
use crate::profile::Profile;
use crate::real::fm;
use crate::shape::ShapedLaw;

mod extremes;

const EPS: f64 = f64::EPSILON;
/// Most ticks a move may span: half-tick decisions stay meaningful in f64 and u64.
pub const MAX_TICKS: f64 = (1u64 << 50) as f64;

/// How far (in units of ε·(f·N + x·v), ticks·steps/s) a step of a profile with an integer
/// move behind it ([`crate::int::ExactMove`]) may lie from that move's: the profile is the
/// move in f64, each constant and piece start a few roundings from its exact value, so
/// positions move by a few ε·(N + v·t) steps and times by that over the speed. A step
/// that close to a half tick is settled on the integer move.
const DEV_ULPS: f64 = 1024.0;

/// 1.5·2^52: adding it rounds a non-negative x < 2^51 to an integer held in the low
/// mantissa bits (the classic magic-number rounding; SSE2 has no cheap floor).
const MAGIC: f64 = 6_755_399_441_055_744.0;

/// The nearest tick to x ≥ 0 and |frac(x) − ½|, the distance from the half tick where
/// the choice of tick would flip. `x + MAGIC` has MAGIC's exponent, so its bits are
/// MAGIC's plus the tick (one subtract).
#[inline(always)]
fn nearest_tick(x: f64) -> (u64, f64) {
    let (tick, off) = nearest_tick_offset(x);
    (tick, 0.5 - off)
}

/// The nearest tick to x ≥ 0 and `|x − tick|`.
#[inline(always)]
fn nearest_tick_offset(x: f64) -> (u64, f64) {
    let y = x + MAGIC;
    let tick = y.to_bits().wrapping_sub(MAGIC.to_bits());
    (tick, (x - (y - MAGIC)).abs())
}

/// Where a piece starts (time and position) and how long it lasts.
#[derive(Clone, Copy, Debug)]
struct Span {
    t0: f64,
    p0: f64,
    dur: f64,
}

impl Span {
    #[inline(always)]
    fn of(p: &Piece) -> Span {
        Span {
            t0: p.t0,
            p0: p.p0,
            dur: p.dur,
        }
    }
}

/// A constant-acceleration piece `advance = c1·τ + c2·τ²` (c2 ≠ 0) with its per-step
/// constants hoisted, and a per-piece bound that decides most steps with one multiply.
#[derive(Clone, Copy, Debug)]
struct Ramp {
    c1: f64,
    /// `c1²` and `4·c2` (exact: a power of two), so `r` is the same value as `c1·c1 + 4·c2·n`.
    c1_sq: f64,
    c2_4: f64,
    /// `1/(2·c2)`, for the divide-free root `τ = (s − c1)/(2c2)` where `fast`.
    h: f64,
    /// A bound on the tick error times the speed s, maximised over the piece, for the
    /// formula in use: a step whose `dist·s` exceeds it is decided without the per-step
    /// bound (∞: never).
    quick: f64,
    fast: bool,
    /// [`DEV_ULPS`]' deviation times the speed, for a profile with an integer move (else 0).
    dev: f64,
}

impl Ramp {
    const NONE: Ramp = Ramp {
        c1: 0.0,
        c1_sq: 0.0,
        c2_4: 0.0,
        h: 0.0,
        quick: f64::INFINITY,
        fast: false,
        dev: 0.0,
    };

    /// The constants of piece `p` (`c1`, `c2` its quadratic coefficients) at `clock`, for
    /// steps `i ≤ i_max`.
    ///
    /// Merged form `τ = 2n/(c1 + s)`: its per-step test ([`Ramp::exact`]) divided by
    /// `den = c1 + s > 0` reads `dist·s > k_err·(τ·(5s + R/den) + i) + (8ε·x + 2·10⁻⁹)·s`;
    /// over the piece τ ≤ dur, i ≤ i_max, x ≤ f·(t0 + dur), s ≤ s_max, and R/den ≤ s_max
    /// when c2 > 0 (R = s²) or ≤ R_max/c1 when c2 < 0.
    ///
    /// Divide-free form `τ = (s − c1)·h`, `h = fl(1/(2c2))`: r carries
    /// `Δr ≤ 2ε·R + 4|c2|·ε·i` (its three roundings and n's), so
    /// `|Δs| ≤ Δr/s + ε·s/2` (`|√a − √b| ≤ |a − b|/√b`, with the computed s), and the
    /// difference, h and the product add `2ε·τ`: `Δτ·s ≤ ε·(R/|c2| + 2i + s²/(4|c2|) +
    /// 2·dur·s)`, plus the sum and product of x as in the merged form. Near `s ≈ c1`
    /// (a decel's start) this is the cancellation `ε·c1/|c2|` in absolute time, which the
    /// bound carries; where that makes it larger than the merged form's, the merged
    /// form (one divide more) is used.
    ///
    /// `quick` is twice the right side at those maxima (with a relative margin for the
    /// rounding of its own terms), so `dist·s > quick` decides the tick.
    ///
    /// With an integer move behind the profile (`exact`), `dev` (the profile's own
    /// deviation from it, [`DEV_ULPS`]) is added to both bounds.
    fn new(p: &Piece, c1: f64, c2: f64, clock: f64, i_max: f64, exact: bool) -> Ramp {
        let n_max = (i_max - p.p0).max(0.0) * (1.0 + 1e-9);
        let r_max = (c1 * c1 + 4.0 * c2.abs() * n_max) * (1.0 + 1e-9);
        let s_max = fm::sqrt(if c2 > 0.0 { r_max } else { c1 * c1 }) * (1.0 + 1e-6);
        let rd_max = if c2 > 0.0 {
            s_max
        } else if c1 > 0.0 {
            r_max / c1 * (1.0 + 1e-6)
        } else {
            f64::INFINITY
        };
        let i_max = i_max * (1.0 + 1e-6);
        let dev = if exact {
            DEV_ULPS * EPS * clock * (i_max + s_max * (p.t0 + p.dur))
        } else {
            0.0
        };
        let x_term = (8.0 * EPS * (p.t0 + p.dur) * clock * (1.0 + 1e-6) + 2e-9) * s_max;
        let k_err = 2.0 * clock * EPS;
        let merged = 2.0 * (k_err * (p.dur * (5.0 * s_max + rd_max) + i_max) + x_term);
        let c2a = c2.abs();
        let free = 2.0
            * (0.5
                * k_err
                * (1.0 + 1e-6)
                * (r_max / c2a + 2.0 * i_max + s_max * s_max / (4.0 * c2a) + 2.0 * p.dur * s_max)
                + x_term);
        let ok = |q: f64| c1 >= 0.0 && q.is_finite() && p.dur.is_finite() && i_max.is_finite();
        let fast = c2 != 0.0 && ok(free) && (!ok(merged) || free <= 4.0 * merged);
        let quick = match (fast, ok(merged)) {
            (true, _) => free + 2.0 * dev,
            (false, true) => merged + 2.0 * dev,
            (false, false) => f64::INFINITY,
        };
        Ramp {
            c1,
            c1_sq: c1 * c1,
            c2_4: 4.0 * c2,
            h: 1.0 / (2.0 * c2),
            quick,
            fast,
            dev,
        }
    }

    /// The root `s = √(c1² + 4c2·n)` of step i as computed: monotone in i (each rounding
    /// is), so its least value over a run of steps is at one of the run's ends.
    #[inline(always)]
    fn root(&self, p: Span, i: f64) -> f64 {
        let r = self.c1_sq + self.c2_4 * (i - p.p0);
        // `r.max(0.0)` in one instruction (maxsd): a NaN radicand cannot occur here
        fm::sqrt(if r > 0.0 { r } else { 0.0 })
    }

    /// How many of the `left` steps from step i to run with one decision limit, and that
    /// limit: the steps whose root stays within about a factor 2 of step i's, and
    /// `½ − quick/s_lo` with `s_lo` below the least root among them, so that a step's
    /// `|f·t − nearest tick| < limit` implies its `dist·s > quick` ([`Ramp::new`]) without
    /// a multiply by its own root.
    fn run_limit(&self, p: Span, i: f64, left: f64) -> (f64, f64) {
        let r0 = self.c1_sq + self.c2_4 * (i - p.p0);
        // steps until r is 4·r0 (accelerating) or r0/4 (decelerating): s doubles or halves
        let target = if self.c2_4 > 0.0 { 4.0 * r0 } else { 0.25 * r0 };
        let len = fm::floor((target - r0) / self.c2_4);
        // NaN-safe: at least one step, at most `left`
        let len = if len >= 1.0 { len.min(left) } else { 1.0 };
        let s_lo = self.root(p, i).min(self.root(p, i + (len - 1.0))) * (1.0 - 1e-6);
        (len, 0.5 - self.quick / s_lo)
    }

    /// Local time of step i, its nearest tick, and whether f64 decides that tick: the
    /// piece's closed form and bound first (`|f·t − tick| < limit`, [`Ramp::run_limit`]),
    /// the merged form with its per-step bound where that cannot decide.
    /// `FAST` is `self.fast`, as a parameter so that a loop over steps has no branch on it.
    #[inline(always)]
    fn locate<const FAST: bool>(
        &self,
        p: Span,
        i: f64,
        k_err: f64,
        clock: f64,
        limit: f64,
    ) -> (f64, u64, bool) {
        let n = i - p.p0;
        let s = self.root(p, i);
        let tau = if FAST {
            (s - self.c1) * self.h
        } else {
            2.0 * n / (self.c1 + s)
        };
        // `tau.min(dur)` in one instruction (a NaN τ gives dur in both)
        let tau = if tau < p.dur { tau } else { p.dur };
        let x = (p.t0 + tau) * clock;
        let (tick, off) = nearest_tick_offset(x);
        if off < limit {
            return (tau, tick, true);
        }
        // the piece's start and length as scalars: a `Span` argument was stored to the
        // stack on every step for this rare call
        self.exact(p.t0, p.dur, i, n, s, k_err, clock)
    }

    /// [`Ramp::locate`] outside a ramp loop (a piece's first and last steps): out of line,
    /// so that the general path, which the curves' steps take, stays small.
    #[inline(never)]
    fn locate_once(&self, p: Span, i: f64, k_err: f64, clock: f64) -> (f64, u64, bool) {
        let limit = self.run_limit(p, i, 1.0).1;
        if self.fast {
            self.locate::<true>(p, i, k_err, clock, limit)
        } else {
            self.locate::<false>(p, i, k_err, clock, limit)
        }
    }

    /// Seed 000's merged closed form `τ = 2n/(c1 + √(c1² + 4c2·n))` (one root, one
    /// divide, no cancellation) with its per-step error bound.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn exact(
        &self,
        t0: f64,
        dur: f64,
        i: f64,
        n: f64,
        s: f64,
        k_err: f64,
        clock: f64,
    ) -> (f64, u64, bool) {
        let c1 = self.c1;
        let den = c1 + s;
        let tau = (2.0 * n / den).min(dur);
        let x = (t0 + tau) * clock;
        let (tick, dist) = nearest_tick(x);
        // Error bound (ticks) times s·den, so no division is needed: the radicand's
        // rounding (R = c1² + 4|c2|n, over s), the root and quotient (≤ 5 ulp, using
        // s ≤ den), n's own rounding (ε·i, over the speed s), and the final sum and
        // product (4ε·x); doubled for safety.
        let big_r = c1 * c1 + self.c2_4.abs() * n;
        let sd = s * den;
        let bound = k_err * (tau * (5.0 * sd + big_r) + i * den) + (8.0 * EPS * x + 2e-9) * sd;
        (tau, tick, dist * sd > bound + self.dev * den)
    }
}

/// Streams the edge tick of every step of a profile, in order.
///
/// It owns its profile (`EdgeGenerator<Profile>`, the default: about 5 KB) or borrows it
/// (`EdgeGenerator<&Profile>`: a few hundred bytes, and no copy of the pieces).
#[derive(Clone, Debug)]
pub struct EdgeGenerator<P: Borrow<Profile> = Profile> {
    profile: P,
    clock: f64,
    /// Next step to produce (1-based), also as f64 (u64 → f64 is slow on baseline x86-64).
    next: u64,
    next_f: f64,
    /// N as f64: the last step, whose edge is round(f·T) by definition.
    last_f: f64,
    /// Current piece, a copy of it, and where it ends.
    piece: usize,
    cur: Piece,
    cur_end: f64,
    /// The current piece has constant acceleration: `advance = c1·τ + c2·τ²`.
    quad: bool,
    /// ... with zero acceleration and positive speed: `τ = n/c1`.
    cruise: bool,
    /// Constant acceleration, not cruise: the closed form with its per-piece constants.
    ramp: Ramp,
    /// Last step (as f64) a ramp run may give in the current piece: inside it, before N.
    ramp_hi: f64,
    inv_c1: f64,
    /// On a cruise piece, [`DEV_ULPS`]' deviation in ticks (0 without an integer move).
    cruise_dev: f64,
    /// Local times of the last three steps in the current piece (newest first) and how
    /// many of them are valid: the next step's Newton guess extrapolates them.
    hist: [f64; 3],
    nhist: u8,
    /// The current piece's law with its constants hoisted, if it is shaped.
    shaped: Option<ShapedLaw>,
    /// A bound on |acceleration| over the current (Newton) piece; NaN if none is known.
    shaped_amax: f64,
    v_prev: f64,
    /// Predicted steps on a Newton piece ([`EdgeGenerator::curve_run`]): off in the
    /// reference generator ([`EdgeGenerator::without_prediction`]); the margin (steps)
    /// beyond which a computed position's sign is proved.
    pred_off: bool,
    pred_m: f64,
    /// On an exponential or sine piece, the law as a local cubic for those steps.
    cubic: LocalCubic,
    last_edge: u64,
    settled: u64,
    /// The current piece's exact constant-speed sequence and the steps it may run
    /// (inside the piece by a step and a tick on both sides, before step N).
    cruise_exact: Option<FloatCruise>,
    run_lo: u64,
    run_hi: u64,
    /// Steps the accumulator still gives before `next` (which is already past them).
    run_left: u64,
    acc: StepAccumulator,
}

/// A move of `duration` seconds fits a generator on a `clock` of ticks per second.
pub(crate) fn check_ticks(clock: f64, duration: f64) -> Result<(), PlanError> {
    let ticks = clock * duration;
    if !(ticks <= MAX_TICKS) {
        return Err(PlanError::TooManyTicks {
            ticks,
            max: MAX_TICKS,
        });
    }
    Ok(())
}

/// The tick of a move's last step: `round(f·T)`.
pub(crate) fn last_tick(clock: f64, duration: f64) -> u64 {
    Dd::mul_f64(clock, duration).round_half_up() as u64
}

impl<P: Borrow<Profile>> EdgeGenerator<P> {
    /// A generator for `profile` (owned or borrowed) at `clock_hz` ticks per second.
    pub fn new(profile: P, clock_hz: f64) -> Result<Self, PlanError> {
        let clock = positive("clock", clock_hz)?;
        let pr = profile.borrow();
        check_ticks(clock, pr.duration())?;
        let cur = *pr.piece(0);
        let last_f = pr.steps() as f64;
        let cur_end = pr.end_of(0);
        Ok(EdgeGenerator {
            profile,
            clock,
            next: 1,
            next_f: 1.0,
            last_f,
            piece: 0,
            cur,
            cur_end,
            quad: cur.quadratic().is_some(),
            cruise: false,
            ramp: Ramp::NONE,
            ramp_hi: 0.0,
            inv_c1: 0.0,
            cruise_dev: 0.0,
            hist: [0.0; 3],
            nhist: 0,
            shaped: None,
            shaped_amax: f64::NAN,
            v_prev: 0.0,
            pred_off: false,
            pred_m: 0.0,
            cubic: LocalCubic::NONE,
            last_edge: 0,
            settled: 0,
            cruise_exact: None,
            run_lo: 1,
            run_hi: 0,
            run_left: 0,
            acc: StepAccumulator::default(),
        }
        .entered(0))
    }

    /// The profile being played.
    pub fn profile(&self) -> &Profile {
        self.profile.borrow()
    }

    /// The integer move behind the profile, when it was planned on this generator's clock:
    /// its ticks are not this clock's otherwise.
    fn exact(&self) -> Option<crate::int::ExactMove> {
        self.profile().exact.filter(|x| x.on_clock(self.clock))
    }

    /// Ticks per second.
    pub fn clock(&self) -> f64 {
        self.clock
    }

    /// Steps not produced yet.
    pub fn remaining(&self) -> u64 {
        self.profile().steps() + 1 - self.next + self.run_left
    }

    /// How many edges needed the double-double settle so far (a diagnostic).
    pub fn settled_count(&self) -> u64 {
        self.settled
    }

    /// The tick of the last step: `round(f·T)`.
    pub fn last_edge_tick(&self) -> u64 {
        last_tick(self.clock, self.profile().duration())
    }

    /// Moves the generator so that its next item is the edge of `step` (1-based); steps
    /// beyond the move end the stream. Costs O(pieces), not O(steps).
    pub fn seek(&mut self, step: u64) {
        self.next = step.clamp(1, self.profile().steps() + 1);
        self.next_f = self.next as f64;
        self.run_left = 0;
        self.enter(0);
        self.last_edge = 0;
    }

    /// The same generator without the predicted steps on curved pieces: every such step
    /// by safeguarded Newton, as before they existed. The edges are the same (a test
    /// compares the two); this is the reference for that test.
    #[doc(hidden)]
    pub fn without_prediction(mut self) -> Self {
        self.pred_off = true;
        self.enter(self.piece);
        self
    }

    /// Turns this edge stream into a stream of periods `edge_i − edge_{i−1}`.
    pub fn periods(self) -> Periods<P> {
        Periods {
            edges: self,
            last: 0,
        }
    }

    /// Writes up to `out.len()` edges; returns how many were written.
    pub fn fill(&mut self, out: &mut [u64]) -> usize {
        let mut k = 0;
        while k < out.len() {
            if self.run_left > 0 {
                let n = (self.run_left as usize).min(out.len() - k);
                let mut acc = self.acc;
                acc.fill_run(&mut out[k..k + n]);
                self.acc = acc;
                self.run_left -= n as u64;
                k += n;
                continue;
            }
            if self.next_f <= self.ramp_hi && self.quad {
                let n = (self.ramp_hi - self.next_f + 1.0).min((out.len() - k) as f64) as usize;
                let (slots, _) = out[k..].split_at_mut(n);
                let mut it = slots.iter_mut();
                self.ramp_steps(n as u64, 0u8, |z, e| {
                    if let Some(slot) = it.next() {
                        *slot = e;
                    }
                    z
                });
                k += n;
                continue;
            }
            if self.next_f <= self.ramp_hi && !self.quad && self.nhist == 3 {
                let before = self.next;
                let room = (out.len() - k) as u64;
                let mut it = out[k..].iter_mut();
                self.curve_run(room, 0u8, &mut |z, e| {
                    if let Some(slot) = it.next() {
                        *slot = e;
                    }
                    z
                });
                let n = (self.next - before) as usize;
                k += n;
                if n > 0 {
                    continue;
                }
            }
            match self.step_general() {
                Some(e) => {
                    out[k] = e;
                    k += 1;
                }
                None => break,
            }
        }
        k
    }

    /// Folds every remaining edge into `init` (what `for e in generator` and
    /// [`Iterator::fold`] run): constant-speed runs go through the accumulator held in
    /// local variables.
    #[inline]
    pub fn fold_edges<B>(&mut self, init: B, mut f: impl FnMut(B, u64) -> B) -> B {
        let mut out = init;
        loop {
            if self.run_left > 0 {
                let mut acc = self.acc;
                out = acc.fold_run(self.run_left, out, &mut f);
                self.acc = acc;
                self.run_left = 0;
            }
            if self.next_f <= self.ramp_hi {
                if self.quad {
                    out = self.ramp_run(out, &mut f);
                } else if self.nhist == 3 {
                    out = self.curve_run(u64::MAX, out, &mut f);
                }
            }
            match self.step_general() {
                Some(e) => out = f(out, e),
                None => return out,
            }
        }
    }

    /// The least and greatest period between the remaining edges (the first measured
    /// from tick `last`) and the last edge, as folding them one by one finds them, but
    /// each constant-speed run in O(1) from its accumulator. `None` when no step remains.
    // out of line, as period_extremes_for: the ramp loop keeps its registers
    #[inline(never)]
    pub fn period_extremes(&mut self, last: u64) -> Option<(u64, u64, u64)> {
        self.extremes::<false>(last, u64::MAX)
    }

    /// [`period_extremes`](Self::period_extremes) over the next `edges` edges or more (a
    /// constant-speed run counts whole), so a long move can be summarised in parts with
    /// progress shown between them. `None` when no step remains.
    // out of line: inlined into its caller's loop, the ramp loop ran 4 instructions per
    // edge more (registers the caller's state took)
    #[inline(never)]
    pub fn period_extremes_for(&mut self, last: u64, edges: u64) -> Option<(u64, u64, u64)> {
        self.extremes::<true>(last, edges)
    }

    /// `PARTS`: stop after `edges`; without, the part's tests are compiled out (they cost
    /// the whole run 4–6 instructions per edge).
    #[inline(always)]
    fn extremes<const PARTS: bool>(&mut self, last: u64, edges: u64) -> Option<(u64, u64, u64)> {
        let (mut lo, mut hi, mut last, mut any) = (u64::MAX, 0u64, last, false);
        // with no run pending, the part ends when `next` reaches this step
        let stop =
            (self.profile().steps() + 1).saturating_sub(self.remaining().saturating_sub(edges));
        loop {
            if self.run_left > 0 {
                let (acc, n) = (self.acc, self.run_left);
                let first = acc.edge_after(0);
                let (a, b) = acc.period_range(n).unwrap_or((u64::MAX, 0));
                lo = lo.min(first - last).min(a);
                hi = hi.max(first - last).max(b);
                last = acc.edge_after(n - 1);
                any = true;
                self.run_left = 0;
            }
            if self.next_f <= self.ramp_hi && self.quad {
                let run = (self.ramp_hi - self.next_f + 1.0) as u64;
                let n = if PARTS {
                    run.min(stop.saturating_sub(self.next).max(1))
                } else {
                    run
                };
                (lo, hi, last) = self.ramp_extremes(n, (lo, hi, last));
                any = true;
            }
            if self.next_f <= self.ramp_hi
                && !self.quad
                && self.nhist == 3
                && (!PARTS || self.next < stop)
            {
                let f = |(lo, hi, last): (u64, u64, u64), e: u64| {
                    (lo.min(e - last), hi.max(e - last), e)
                };
                let limit = if PARTS { stop - self.next } else { u64::MAX };
                let before = self.next;
                (lo, hi, last) = self.curve_run(limit, (lo, hi, last), &mut { f });
                any |= self.next > before;
            }
            if PARTS && self.next >= stop {
                return any.then_some((lo, hi, last));
            }
            match self.step_general() {
                Some(e) => {
                    (lo, hi, last) = (lo.min(e - last), hi.max(e - last), e);
                    any = true;
                }
                None => return any.then_some((lo, hi, last)),
            }
        }
    }

    fn entered(mut self, k: usize) -> Self {
        self.enter(k);
        self
    }

    fn enter(&mut self, k: usize) {
        self.piece = k;
        self.cur = *self.profile().piece(k);
        self.cur_end = self.profile().end_of(k);
        let q = self.cur.quadratic();
        self.quad = q.is_some();
        let (c1, c2) = q.unwrap_or((0.0, 0.0));
        self.cruise = self.quad && c2 == 0.0 && c1 > 0.0;
        self.inv_c1 = if self.cruise { 1.0 / c1 } else { 0.0 };
        self.nhist = 0;
        self.v_prev = 0.0;
        self.shaped = match self.cur.law {
            Law::Shaped {
                shape,
                mirrored,
                base,
                span,
            } => Some(ShapedLaw::new(shape, mirrored, base, span, self.cur.dur)),
            Law::Poly { .. } => None,
        };
        self.shaped_amax = match self.cur.law {
            Law::Shaped { .. } => self
                .shaped
                .and_then(|l| l.max_abs_acceleration())
                .unwrap_or(f64::NAN),
            // |2c2 + 6c3·τ + 12c4·τ²| on τ ∈ [0, dur], with a margin for rounding
            Law::Poly { c2, c3, c4, .. } => {
                let d = self.cur.dur;
                1.001 * (2.0 * c2.abs() + 6.0 * c3.abs() * d + 12.0 * c4.abs() * d * d)
            }
        };
        self.ramp = Ramp::NONE;
        self.ramp_hi = 0.0;
        self.cubic = LocalCubic::NONE;
        if !self.quad && !self.pred_off && self.exact().is_none() {
            self.plan_prediction();
        }
        if self.quad && !self.cruise {
            // steps of a piece before the last are ≤ its end; the last piece's are < N
            let last_piece = k + 1 >= self.profile().len();
            let i_max = if last_piece {
                self.cur_end.max(self.last_f)
            } else {
                self.cur_end
            };
            let exact = self.exact().is_some();
            self.ramp = Ramp::new(&self.cur, c1, c2, self.clock, i_max, exact);
            self.ramp_hi = fm::floor(self.cur_end).min(self.last_f - 1.0);
        }
        self.cruise_exact = None;
        self.cruise_dev = 0.0;
        if self.cruise {
            let p = self.cur;
            if self.exact().is_some() {
                let i_max = self.cur_end.max(self.last_f);
                self.cruise_dev = DEV_ULPS * EPS * self.clock * (i_max / c1 + p.t0 + p.dur);
            }
            // a step (and a tick) inside the piece on both sides, so that float rounding
            // of its ends never matters; step N keeps its own rule
            let margin = 1.0 + c1 / self.clock;
            let lo = fm::floor(p.p0 + margin) + 1.0;
            let hi = (fm::ceil(self.cur_end - margin) - 1.0).min(self.last_f - 1.0);
            if lo <= hi && hi < MAX_TICKS {
                // the integer move's own cruise line where there is one
                let pr = self.profile();
                self.cruise_exact = match self.exact() {
                    Some(x) => x.cruise(pr, k),
                    None => float_cruise(p.t0, p.p0, c1, self.clock),
                };
                (self.run_lo, self.run_hi) = (lo as u64, hi as u64);
            }
        }
    }

    /// Every step of the current constant-acceleration piece from `next` to `ramp_hi`,
    /// folded into `out`.
    #[inline(always)]
    fn ramp_run<B>(&mut self, out: B, f: &mut impl FnMut(B, u64) -> B) -> B {
        let n = (self.ramp_hi - self.next_f + 1.0) as u64;
        self.ramp_steps(n, out, f)
    }

    /// `n` steps of the current constant-acceleration piece (all inside it and before
    /// step N), with the piece's constants and the last edge in local variables: the
    /// closed form, and the settle only where the bound cannot decide.
    #[inline(always)]
    fn ramp_steps<B>(&mut self, n: u64, out: B, f: impl FnMut(B, u64) -> B) -> B {
        if self.ramp.fast {
            self.ramp_loop::<B, true>(n, out, f)
        } else {
            self.ramp_loop::<B, false>(n, out, f)
        }
    }

    /// [`EdgeGenerator::ramp_steps`] with `FAST` = `self.ramp.fast`. Every edge is the
    /// nearest tick (decided or settled), so they never go backwards: no clamp.
    #[inline(always)]
    fn ramp_loop<B, const FAST: bool>(
        &mut self,
        n: u64,
        mut out: B,
        mut f: impl FnMut(B, u64) -> B,
    ) -> B {
        let ramp = self.ramp;
        let (k_err, clock) = (self.k_err(), self.clock);
        let span = Span::of(&self.cur);
        let mut last = self.last_edge;
        // runs of steps with one decision limit ([`Ramp::run_limit`]); within a run, i is a
        // float counted up by one (exact below 2^53): one add instead of a conversion
        let first = self.next as i64;
        let mut k = 0;
        while k < n as i64 {
            let (len, limit) = ramp.run_limit(span, (first + k) as f64, (n as i64 - k) as f64);
            let mut i = (first + k) as f64;
            for _ in 0..len as i64 {
                let (tau, tick, decided) = ramp.locate::<FAST>(span, i, k_err, clock, limit);
                let e = if decided {
                    tick
                } else {
                    self.settle(self.piece, i, tau)
                };
                last = e;
                out = f(out, e);
                i += 1.0;
            }
            k += len as i64;
        }
        self.last_edge = last;
        self.next += n;
        self.next_f = self.next as f64;
        out
    }

    /// Up to `limit` steps of the current Newton piece without Newton, folded into `out`:
    /// the tick nearest to the quadratic extrapolation of the last three steps' times,
    /// proved by the exactness condition itself, `p((e − ½)/f) < i ≤ p((e + ½)/f)`
    /// (DESIGN.md §1), with the two positions computed in f64 and their signs taken only
    /// beyond [`plan_prediction`](Self::plan_prediction)'s margin; where a side fails, the
    /// tick moves by one, reusing the half tick they share (the jump-and-correct of the
    /// integer ramps). Stops before the first step this does not prove, which Newton takes.
    /// The law's coefficients and the history stay in local variables.
    #[inline(always)]
    fn curve_run<B>(&mut self, limit: u64, out: B, f: &mut impl FnMut(B, u64) -> B) -> B {
        let w = 1.0 / self.clock;
        match (self.shaped, self.cur.law) {
            // the exponential and the sine through their local cubic, re-expanded by
            // `jet::expand` (out of line) every window
            (Some(law), _) if self.cubic.active() => {
                let mut c = self.cubic;
                let out = match law.kind() {
                    2 => self.curve_loop(limit, out, f, |s| {
                        c.eval(s, |a| jet::expand::<2>(&law, a, w))
                    }),
                    3 => self.curve_loop(limit, out, f, |s| {
                        c.eval(s, |a| jet::expand::<3>(&law, a, w))
                    }),
                    4 => self.curve_loop(limit, out, f, |s| {
                        c.eval(s, |a| jet::expand::<4>(&law, a, w))
                    }),
                    _ => self.curve_loop(limit, out, f, |s| {
                        c.eval(s, |a| jet::expand::<5>(&law, a, w))
                    }),
                };
                self.cubic = c;
                out
            }
            // one loop per formula, each with its law inlined
            (Some(law), _) => match law.kind() {
                0 => self.curve_loop(limit, out, f, move |s| law.advance_of::<0>(s * w)),
                1 => self.curve_loop(limit, out, f, move |s| law.advance_of::<1>(s * w)),
                2 => self.curve_loop(limit, out, f, move |s| law.advance_of::<2>(s * w)),
                3 => self.curve_loop(limit, out, f, move |s| law.advance_of::<3>(s * w)),
                4 => self.curve_loop(limit, out, f, move |s| law.advance_of::<4>(s * w)),
                _ => self.curve_loop(limit, out, f, move |s| law.advance_of::<5>(s * w)),
            },
            (None, Law::Poly { c1, c2, c3, c4 }) => {
                // the law in ticks: c_j/f^j (a few roundings of each coefficient, within the
                // margin's 64ε of the terms)
                let (k1, k2, k3, k4) = (c1 * w, c2 * w * w, c3 * w * w * w, c4 * w * w * w * w);
                self.curve_loop(limit, out, f, move |s| {
                    s * (k1 + s * (k2 + s * (k3 + s * k4)))
                })
            }
            _ => out,
        }
    }

    /// [`EdgeGenerator::curve_run`] with the law `adv` taking local time in ticks, so that
    /// the half ticks are `e − (x0 + ½)` and that plus one (x0 = `f·t0`).
    #[inline(always)]
    fn curve_loop<B>(
        &mut self,
        limit: u64,
        mut out: B,
        f: &mut impl FnMut(B, u64) -> B,
        mut adv: impl FnMut(f64) -> f64,
    ) -> B {
        let steps = ((self.ramp_hi - self.next_f + 1.0) as u64).min(limit);
        let (clock, m, p0, t0, d) = (
            self.clock,
            self.pred_m,
            self.cur.p0,
            self.cur.t0,
            self.cur.dur,
        );
        let w = 1.0 / clock;
        let x0 = t0 * clock;
        let x0h = x0 + 0.5;
        // a guess this far inside the piece puts both half ticks of its nearest tick inside
        // by `inside` (the tick is within half a tick of it, the half ticks half a tick either
        // side, each within a few ε·f·(t0 + dur) of its computed value), so that the piece's
        // law is the profile's position there
        let inside = 8.0 * EPS * (t0 + d + w);
        let reach = 3.0 * w + 2.0 * inside;
        let (glo, ghi) = (reach * clock, (d - reach) * clock);
        let [mut h0, mut h1, mut h2] = self.hist.map(|h| h * clock);
        let mut last = self.last_edge;
        // i as f64, exact (< 2^53); no call in the loop, so nothing is spilled around one
        let mut i = self.next_f;
        let i_end = i + steps as f64;
        'run: while i < i_end {
            let n = i - p0;
            let guess = 3.0 * (h0 - h1) + h2;
            if !(guess >= glo && guess <= ghi) {
                break;
            }
            let mut y = (x0 + guess) + MAGIC;
            let mut sa = (y - MAGIC) - x0h;
            let (mut pa, mut pb) = (adv(sa) - n, adv(sa + 1.0) - n);
            if !(pa < -m && pb >= m) {
                // one move by a tick, reusing the half tick it keeps (the guess's range
                // leaves room for it); a step that still is not proved goes to Newton
                if pa >= m {
                    (y, sa, pb) = (y - 1.0, sa - 1.0, pa);
                    pa = adv(sa) - n;
                } else if pb < -m {
                    (y, sa, pa) = (y + 1.0, sa + 1.0, pb);
                    pb = adv(sa + 1.0) - n;
                }
                if !(pa < -m && pb >= m) {
                    break 'run;
                }
                (h2, h1, h0) = (h1, h0, sa + pa / (pa - pb));
                last = y.to_bits().wrapping_sub(MAGIC.to_bits());
                out = f(out, last);
                i += 1.0;
                continue 'run;
            }
            // t_i by linear interpolation between the half ticks: the next guess's history
            (h2, h1, h0) = (h1, h0, sa + pa / (pa - pb));
            // every edge here is the nearest tick, so they never go backwards: no clamp
            last = y.to_bits().wrapping_sub(MAGIC.to_bits());
            out = f(out, last);
            i += 1.0;
        }
        if i > self.next_f {
            // Newton's history, h0 its lower bracket: two ticks below the last step's
            // interpolated time (within a tick above its lower half tick), so below that
            // step's time whatever the conversion rounds
            self.hist = [(h0 - 2.0) * w, h1 * w, h2 * w];
            self.last_edge = last;
            self.next_f = i;
            self.next = i as u64;
        }
        out
    }

    /// Starts the accumulator at step `self.next` if the current piece runs it there.
    #[inline]
    fn start_run(&mut self) {
        let Some(plan) = self.cruise_exact else {
            return;
        };
        let i = self.next;
        if i < self.run_lo || i > self.run_hi {
            return;
        }
        if let Some(acc) = plan.at(i) {
            let n = self.run_hi - i + 1;
            self.acc = acc;
            self.run_left = n;
            self.last_edge = acc.edge_after(n - 1);
            self.next = self.run_hi + 1;
            self.next_f = self.next as f64;
        }
    }

    /// Local time of step i in the current piece, its nearest tick, and whether `f·t_i` is
    /// far enough from a half tick for f64 to decide that tick.
    #[inline(always)]
    fn locate(&mut self, i: f64) -> (f64, u64, bool) {
        let f = self.clock;
        let p = &self.cur;
        let n = i - p.p0;
        if self.cruise {
            // constant speed: τ = n/c1, by a reciprocal kept per piece (two roundings);
            // the bound covers them, n's own rounding (ε·i over the speed) and f·(t0 + τ).
            let tau = (n * self.inv_c1).min(p.dur);
            let x = (p.t0 + tau) * f;
            let (tick, dist) = nearest_tick(x);
            let bound = self.k_err() * (2.0 * tau + i * self.inv_c1) + 8.0 * EPS * x + 2e-9;
            return (tau, tick, dist > bound + self.cruise_dev);
        }
        if self.quad {
            return self
                .ramp
                .locate_once(Span::of(p), i, self.k_err(), self.clock);
        }
        let p = self.cur;
        let (tau, err) = self.newton(&p, n, EPS * i);
        let x = (p.t0 + tau) * f;
        let (tick, dist) = nearest_tick(x);
        (tau, tick, dist > 2.0 * (err * f + 4.0 * EPS * x) + 1e-9)
    }

    /// The margin of [`curve_run`](Self::curve_run) on the current (Newton) piece, and the
    /// steps it may run (`ramp_hi`: inside the piece, before N).
    ///
    /// A tested position `adv(s) − n` is off by the evaluation's rounding (a few ε times
    /// the terms' magnitude, as in Newton's own bound, taken 8 times over; the coefficients
    /// rescaled to ticks add a few ε more) plus the speed times the error of the half tick
    /// itself: `s = e − fl(fl(f·t0) + ½)` (and `s + 1`) is within `2ε·f·(t0 + dur + 1/f)`
    /// ticks of its exact local time (four roundings), taken 4 times over. The speed is
    /// bounded by the absolute coefficients (polynomials) or twice the larger end speed
    /// (the shapes' speeds are monotone on a piece).
    fn plan_prediction(&mut self) {
        let p = self.cur;
        let d = p.dur;
        let vmax = match (&self.shaped, p.law) {
            (Some(law), _) => {
                2.0 * law
                    .advance_velocity(0.0)
                    .1
                    .abs()
                    .max(law.advance_velocity(d).1.abs())
            }
            (None, Law::Poly { c1, c2, c3, c4 }) => {
                c1.abs() + d * (2.0 * c2.abs() + d * (3.0 * c3.abs() + d * 4.0 * c4.abs()))
            }
            _ => f64::INFINITY,
        };
        let t_end = p.t0 + d + self.inv_clock();
        let n_max = (self.cur_end.max(self.last_f) - p.p0).abs() + p.p0.abs();
        let scale = p.term_scale(d) + n_max;
        let m = 64.0 * EPS * scale + vmax * 8.0 * EPS * t_end;
        // the exponential's and the sine's steps test a local cubic, within `m + err`
        let (cubic, err) = match &self.shaped {
            Some(law) => LocalCubic::for_piece(law, d, self.clock, t_end, m, scale),
            None => (LocalCubic::NONE, 0.0),
        };
        self.cubic = cubic;
        self.pred_m = (m + err) * (1.0 + 1e-6);
        // runs where the piece is long enough for `curve_loop`'s range of guesses
        if self.pred_m.is_finite()
            && d > 6.0 * (self.inv_clock() + 16.0 * EPS * t_end)
            && t_end * self.clock < MAX_TICKS
        {
            self.ramp_hi = fm::floor(self.cur_end).min(self.last_f - 1.0);
        }
    }

    /// The error bounds' 2·f·ε (computed where used: the generator stays small).
    #[inline(always)]
    fn k_err(&self) -> f64 {
        2.0 * self.clock * EPS
    }

    #[inline]
    fn inv_clock(&self) -> f64 {
        1.0 / self.clock
    }

    /// `(p(τ) − p0, v(τ))` of the current piece `p`.
    #[inline(always)]
    fn advance_velocity(&self, p: &Piece, tau: f64) -> (f64, f64) {
        match &self.shaped {
            Some(law) => law.advance_velocity(tau),
            None => (p.advance(tau), p.velocity(tau)),
        }
    }

    /// Safeguarded Newton on `advance(τ) = n` inside a piece (Numerical Recipes' rtsafe),
    /// started from a cubic extrapolation of the previous steps' times. Returns τ and a
    /// bound on its error (s).
    #[inline(always)]
    fn newton(&mut self, p: &Piece, n: f64, n_err: f64) -> (f64, f64) {
        let h = self.hist;
        let mut lo = if self.nhist > 0 { h[0] } else { 0.0 };
        let mut hi = p.dur;
        let mut tau = match self.nhist {
            3 => 3.0 * (h[0] - h[1]) + h[2],
            1 | 2 if self.v_prev > 0.0 => h[0] + 1.0 / self.v_prev,
            _ => {
                let v0 = self.advance_velocity(p, 0.0).1;
                if v0 > 0.0 {
                    n / v0
                } else {
                    0.5 * (lo + hi)
                }
            }
        };
        if !(tau > lo && tau < hi) {
            tau = 0.5 * (lo + hi);
        }
        let mut err_newton = hi - lo;
        let mut v = 0.0;
        for _ in 0..200 {
            let (adv, vel) = self.advance_velocity(p, tau);
            let f = adv - n;
            v = vel;
            if f > 0.0 {
                hi = tau;
            } else {
                lo = tau;
            }
            let corr = f / v;
            let next = tau - corr;
            // inclusive: a guess exact to rounding gives corr = 0 and next = lo, which
            // is converged, not a reason to bisect (to the far half of the piece)
            if !(next >= lo && next <= hi) {
                tau = 0.5 * (lo + hi);
                err_newton = hi - lo;
                if hi - lo <= 4.0 * EPS * hi {
                    break;
                }
                continue;
            }
            tau = next;
            let amax = self.shaped_amax;
            if !amax.is_nan() {
                // Taylor with |a| ≤ amax on the piece: the step leaves |advance − n| ≤
                // amax·corr²/2 and v ≥ v − amax·|corr| between, so τ is within their ratio
                let slow = v - amax * corr.abs();
                let b = amax * corr * corr / (2.0 * slow);
                if slow > 0.0 && b * self.clock <= 1e-7 {
                    err_newton = 4.0 * b + 4.0 * EPS * tau;
                    break;
                }
            }
            if corr.abs() * self.clock <= 1e-3 {
                // Newton's error after this step is |a|/(2v)·corr² (quadratic convergence).
                // |a| at τ, or a bound on it over the piece (one transcendental less)
                let a = match &self.shaped {
                    Some(law) if amax.is_nan() => law.acceleration(tau).abs(),
                    Some(_) => amax,
                    None => p.acceleration(tau).abs(),
                };
                err_newton = 4.0 * a / (2.0 * v) * corr * corr + 4.0 * EPS * tau;
                break;
            }
            err_newton = corr.abs();
        }
        self.v_prev = v;
        self.hist = [tau, h[0], h[1]];
        self.nhist = (self.nhist + 1).min(3);
        let eval_err = 8.0 * EPS * (p.term_scale(tau) + n.abs()) + n_err;
        let err = if v > 0.0 {
            eval_err / v + err_newton
        } else {
            f64::INFINITY
        };
        (tau, err)
    }

    /// Settles a step on a constant-speed piece, where `t_i = t0 + (i − p0)/c1` is exact in
    /// double-double and p is linear, so the tick follows without evaluating p: rational
    /// speeds (32 000 steps/s at 50 MHz is 1562.5 ticks a step) put every other step exactly
    /// on a half tick, and this keeps them cheap. Exact ties go to the earlier tick, as in
    /// `int`. `None` when the half ticks around the edge leave the piece.
    fn settle_cruise(&self, i: f64) -> Option<u64> {
        let p = &self.cur;
        let f = Dd::new(self.clock);
        let c1 = p.quadratic().map_or(0.0, |q| q.0);
        let tau = (Dd::new(i) - Dd::new(p.p0)) / Dd::new(c1);
        let x = (Dd::new(p.t0) + tau) * f;
        let up = x.round_half_up();
        // how far x lies above the half tick below `up`; ~0 is an exact tie
        let d = x - Dd::new(up - 0.5);
        let above = d.hi + d.lo;
        let e = if above <= 1e-24 * (x.hi + 1.0) {
            up - 1.0
        } else {
            up
        };
        let inside = e - 1.0 >= p.t0 * self.clock && e + 1.0 <= (p.t0 + p.dur) * self.clock;
        (e >= 0.0 && inside).then_some(e as u64)
    }

    /// Finds the nearest tick for step i in double-double and checks it against the
    /// exactness condition, moving it by whole ticks until the condition holds.
    #[cold]
    fn settle(&mut self, k: usize, i: f64, tau: f64) -> u64 {
        self.settled += 1;
        let pr = self.profile();
        if let Some(x) = self.exact() {
            let guess = fm::floor((pr.piece(k).t0 + tau) * self.clock + 0.5).max(0.0);
            if let Some(e) = x.settle(pr, k, i as u64, guess as u64) {
                return e;
            }
        }
        if self.cruise {
            if let Some(e) = self.settle_cruise(i) {
                return e;
            }
        }
        let p = *self.profile().piece(k);
        let target = Dd::new(i) - Dd::new(p.p0);
        let mut t = Dd::new(tau);
        for _ in 0..8 {
            let v = p.velocity(t);
            if !(v.hi > 0.0) {
                break;
            }
            let step = (p.advance(t) - target) / v;
            t = t - step;
            if step.hi.abs() <= 1e-31 * t.hi.abs().max(1e-300) {
                break;
            }
        }
        let f = Dd::new(self.clock);
        let mut e = ((Dd::new(p.t0) + t) * f).round_half_up().max(0.0);
        let step = Dd::new(i);
        for _ in 0..1024 {
            let below = self.profile().position_dd(Dd::new(e - 0.5) / f);
            if below >= step && e > 0.0 {
                e -= 1.0;
                continue;
            }
            let above = self.profile().position_dd(Dd::new(e + 0.5) / f);
            if above < step {
                e += 1.0;
                continue;
            }
            break;
        }
        e as u64
    }
}

impl<P: Borrow<Profile>> Iterator for EdgeGenerator<P> {
    type Item = u64;

    #[inline]
    fn next(&mut self) -> Option<u64> {
        self.step()
    }

    #[inline]
    fn fold<B, F: FnMut(B, u64) -> B>(mut self, init: B, f: F) -> B {
        self.fold_edges(init, f)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let r = self.remaining() as usize;
        (r, Some(r))
    }
}

impl<P: Borrow<Profile>> EdgeGenerator<P> {
    /// The next edge. Always inlined, so that [`fill`](Self::fill) runs it in a tight loop
    /// (as `for e in generator` does) instead of calling it once per edge.
    #[inline(always)]
    fn step(&mut self) -> Option<u64> {
        if self.run_left > 0 {
            self.run_left -= 1;
            return Some(self.acc.next_edge());
        }
        if self.next_f <= self.ramp_hi && !self.quad && self.nhist == 3 {
            if let Some(e) = self.curve_run(1, None, &mut |_, e| Some(e)) {
                return Some(e);
            }
        }
        self.step_general()
    }

    /// The next edge by the general path (closed form or Newton, settled near half
    /// ticks); may start an accumulator run for the steps after it.
    #[inline(always)]
    fn step_general(&mut self) -> Option<u64> {
        let i = self.next_f;
        if i >= self.last_f {
            if i > self.last_f {
                return None;
            }
            self.next += 1;
            self.next_f += 1.0;
            let e = self.last_edge_tick().max(self.last_edge);
            self.last_edge = e;
            return Some(e);
        }
        self.next += 1;
        self.next_f += 1.0;
        if self.cur_end < i {
            let mut k = self.piece;
            while self.profile().end_of(k) < i && k + 1 < self.profile().len() {
                k += 1;
            }
            self.enter(k);
        }
        let (tau, tick, decided) = self.locate(i);
        let e = if decided {
            tick
        } else {
            self.settle(self.piece, i, tau)
        };
        // Edges never go backwards, even where two steps share a tick.
        let e = e.max(self.last_edge);
        self.last_edge = e;
        if self.cruise_exact.is_some() {
            self.start_run();
        }
        Some(e)
    }
}

impl<P: Borrow<Profile>> ExactSizeIterator for EdgeGenerator<P> {}

/// Periods between consecutive edges, starting from tick 0.
#[derive(Clone, Debug)]
pub struct Periods<P: Borrow<Profile> = Profile> {
    edges: EdgeGenerator<P>,
    last: u64,
}

impl<P: Borrow<Profile>> Iterator for Periods<P> {
    type Item = u64;
    #[inline]
    fn next(&mut self) -> Option<u64> {
        let e = self.edges.next()?;
        let p = e - self.last;
        self.last = e;
        Some(p)
    }
}

/// Builds a generator for any move in one call (planned on the clock:
/// [`Profile::plan_on_clock`]).
pub fn edges(m: &crate::profile::Move<'_>, clock_hz: f64) -> Result<EdgeGenerator, PlanError> {
    EdgeGenerator::new(Profile::plan_on_clock(m, clock_hz)?, clock_hz)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profile::{Family, PhaseMove};

    #[test]
    fn seed000_trapezoid_from_rest() {
        // 2400 microsteps in 20/10/20 ms at 50 MHz (seed 000's run)
        let p = Profile::phase(&PhaseMove {
            steps: 2400,
            accel_time: 0.02,
            cruise_time: 0.01,
            decel_time: 0.02,
            start_speed: 0.0,
            end_speed: 0.0,
            family: Family::Trapezoid,
        })
        .unwrap();
        let g = EdgeGenerator::new(p, 50e6).unwrap();
        let edges: std::vec::Vec<u64> = g.collect();
        assert_eq!(edges.len(), 2400);
        assert_eq!(*edges.last().unwrap(), 2_500_000);
        // vm = 2400/0.03 = 80000 steps/s, a = 4e6 steps/s²: t1 = √(2/a)
        let t1 = (2.0f64 / 4e6).sqrt();
        assert_eq!(edges[0], (t1 * 50e6 + 0.5).floor() as u64);
        // the middle of the cruise: 80000 steps/s is exactly 625 ticks per step
        let mid = &edges[1000..1300];
        assert!(mid.windows(2).all(|w| w[1] - w[0] == 625));
    }

    /// A borrowing generator holds no copy of the profile's pieces and gives the same edges.
    #[test]
    fn borrowed_generator_is_small_and_the_same() {
        let own = core::mem::size_of::<EdgeGenerator>();
        let borrowed = core::mem::size_of::<EdgeGenerator<&Profile>>();
        std::println!("EdgeGenerator: owned {own} B, borrowed {borrowed} B");
        assert!(
            own > core::mem::size_of::<Profile>() && borrowed < 576,
            "{own} {borrowed}"
        );
        let p = Profile::phase(&PhaseMove {
            steps: 5000,
            accel_time: 0.2,
            cruise_time: 0.3,
            decel_time: 0.2,
            start_speed: 0.0,
            end_speed: 0.0,
            family: Family::Sine,
        })
        .unwrap();
        let a: std::vec::Vec<u64> = EdgeGenerator::new(&p, 50e6).unwrap().collect();
        let b: std::vec::Vec<u64> = EdgeGenerator::new(p, 50e6).unwrap().collect();
        assert_eq!(a, b);
    }

    /// A 32 000 steps/s cruise between two ramps (1562.5 ticks a step, every other step on
    /// an exact half tick): the float generator's exact accumulator gives the integer
    /// datapath's edges on every step, through `next`, `fold_edges`, `fill` and `seek`.
    #[test]
    fn half_tick_cruise_equals_the_integer_datapath() {
        use crate::int::{IntClock, IntEdgeGenerator, IntProfile, IntSegment};
        use crate::profile::Segment;
        let (ramp, cruise) = (2_000u64, 996_000u64);
        let seg = |v0: f64, duration: f64, steps| Segment {
            v0,
            duration,
            steps,
        };
        let p = Profile::segments(&[
            seg(0.0, 0.125, ramp),
            seg(32e3, 31.125, cruise),
            seg(32e3, 0.125, ramp),
        ])
        .unwrap();
        let iseg = |v0, ticks, steps| IntSegment { v0, ticks, steps };
        let ip = IntProfile::segments(
            &[
                iseg(0, 6_250_000, ramp),
                iseg(32_000, 1_556_250_000, cruise),
                iseg(32_000, 6_250_000, ramp),
            ],
            IntClock::hz(50_000_000),
        )
        .unwrap();
        let want: std::vec::Vec<u64> = IntEdgeGenerator::new(ip).collect();
        let mut g = EdgeGenerator::new(p.clone(), 50e6).unwrap();
        let got: std::vec::Vec<u64> = (&mut g).collect();
        assert_eq!(got.len(), want.len());
        let bad = got.iter().zip(&want).position(|(a, b)| a != b);
        assert_eq!(
            bad,
            None,
            "first difference at step {:?}",
            bad.map(|k| k + 1)
        );
        assert!(g.settled_count() < 10, "{}", g.settled_count());
        // a cruise step on a half tick: 6.25 M + 1562.5·(odd) goes down
        assert_eq!(want[ramp as usize], 6_250_000 + 1562);
        let mut g = EdgeGenerator::new(p.clone(), 50e6).unwrap();
        let n = g.fold_edges(0usize, |k, e| {
            assert_eq!(e, want[k], "fold, step {}", k + 1);
            k + 1
        });
        assert_eq!(n, want.len());
        let mut g = EdgeGenerator::new(p, 50e6).unwrap();
        for start in [1u64, 2_001, 2_002, 500_001, 997_999, 998_001] {
            g.seek(start);
            let mut buf = [0u64; 37];
            let k = g.fill(&mut buf);
            let from = start as usize - 1;
            assert_eq!(&buf[..k], &want[from..from + k], "seek {start}");
            assert_eq!(g.remaining(), want.len() as u64 - start + 1 - k as u64);
        }
    }
}

#[cfg(test)]
mod near_ties {
    use super::*;
    use crate::moves::Segment;

    /// A constant-acceleration piece 2^20 s into a move, whose steps (2k+1)² lie on half
    /// ticks to within the f64 rounding of its coefficients, where f64 resolves the time
    /// only to about 2·10⁻⁷ ticks: every edge still meets the exactness condition in
    /// double-double, because the ramp loop's limit sent those steps to the settle.
    #[test]
    fn near_ties_far_into_a_move_are_settled() {
        let clock = 1000.0;
        // 10 000 steps in 0.05 s from rest: a = 8·10⁶ steps/s² = 8f², so step i is at
        // √i/2 ticks into the piece, a half tick when √i is odd
        let segs = [
            Segment {
                v0: 0.0,
                duration: 1_048_576.0,
                steps: 0,
            },
            Segment {
                v0: 0.0,
                duration: 0.05,
                steps: 10_000,
            },
        ];
        let p = Profile::segments(&segs).unwrap();
        let mut g = EdgeGenerator::new(&p, clock).unwrap();
        let edges: Vec<u64> = (&mut g).collect();
        assert_eq!(edges.len(), 10_000);
        let f = Dd::new(clock);
        for (k, &e) in edges.iter().enumerate().take(9_999) {
            let i = Dd::new((k + 1) as f64);
            let below = p.position_dd(Dd::new(e as f64 - 0.5) / f);
            let above = p.position_dd(Dd::new(e as f64 + 0.5) / f);
            assert!(below < i && !(above < i), "step {}: edge {e}", k + 1);
        }
        std::println!("settled {}", g.settled_count());
        assert!(g.settled_count() >= 25, "{}", g.settled_count());
    }
}
