//! The edge generator: step i happens at `t_i = min{t : p(t) = i}` and its edge is the
//! nearest tick, `floor(f·t_i + ½)` (DESIGN.md §1).
//!
//! Each step is solved in f64 (closed form on constant-acceleration pieces, safeguarded
//! Newton elsewhere) together with a bound on its rounding error in ticks. When `f·t_i` lies
//! within that bound of a half tick, the edge is settled in double-double arithmetic and
//! checked against `p((e − ½)/f) < i ≤ p((e + ½)/f)`, so every edge is the nearest tick,
//! not only most of them. Memory is O(1); nothing allocates.

use crate::dd::Dd;
use crate::error::{positive, PlanError};
use crate::piece::Piece;
use crate::profile::Profile;
use crate::real::fm;

const EPS: f64 = f64::EPSILON;
/// Most ticks a move may span: half-tick decisions stay meaningful in f64 and u64.
pub const MAX_TICKS: f64 = (1u64 << 52) as f64;

/// Streams the edge tick of every step of a profile, in order.
#[derive(Clone, Debug)]
pub struct EdgeGenerator {
    profile: Profile,
    clock: f64,
    /// Next step to produce (1-based).
    next: u64,
    /// Current piece and the local time of the previous step in it.
    piece: usize,
    tau_prev: f64,
    v_prev: f64,
    last_edge: u64,
    settled: u64,
}

impl EdgeGenerator {
    /// A generator for `profile` at `clock_hz` ticks per second.
    pub fn new(profile: Profile, clock_hz: f64) -> Result<Self, PlanError> {
        let clock = positive("clock", clock_hz)?;
        let ticks = clock * profile.duration();
        if !(ticks <= MAX_TICKS) {
            return Err(PlanError::TooManyTicks {
                ticks,
                max: MAX_TICKS,
            });
        }
        Ok(EdgeGenerator {
            profile,
            clock,
            next: 1,
            piece: 0,
            tau_prev: 0.0,
            v_prev: 0.0,
            last_edge: 0,
            settled: 0,
        })
    }

    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    pub fn clock(&self) -> f64 {
        self.clock
    }

    /// Steps not produced yet.
    pub fn remaining(&self) -> u64 {
        self.profile.steps() + 1 - self.next
    }

    /// How many edges needed the double-double settle so far (a diagnostic).
    pub fn settled_count(&self) -> u64 {
        self.settled
    }

    /// The tick of the last step: `round(f·T)`.
    pub fn last_edge_tick(&self) -> u64 {
        Dd::mul_f64(self.clock, self.profile.duration()).round_half_up() as u64
    }

    /// Turns this edge stream into a stream of periods `edge_i − edge_{i−1}`.
    pub fn periods(self) -> Periods {
        Periods {
            edges: self,
            last: 0,
        }
    }

    /// Writes up to `out.len()` edges; returns how many were written.
    pub fn fill(&mut self, out: &mut [u64]) -> usize {
        let mut k = 0;
        while k < out.len() {
            match self.next() {
                Some(e) => {
                    out[k] = e;
                    k += 1;
                }
                None => break,
            }
        }
        k
    }

    /// Local time of step i inside piece k with an error bound (s) on the f64 result.
    #[inline(always)]
    fn solve(&mut self, k: usize, i: f64) -> (f64, f64) {
        let p = *self.profile.piece(k);
        let n = i - p.p0;
        // rounding of n itself, as a position error
        let n_err = EPS * i.abs();
        if let Some((c1, c2)) = p.quadratic() {
            // seed 000's merged formula t = 2n / (v0 + √(v0² + 2a·n)): no cancellation
            let r = c1 * c1 + 4.0 * c2 * n;
            let s = fm::sqrt(r.max(0.0));
            let den = c1 + s;
            let tau = (2.0 * n / den).min(p.dur);
            // relative error of τ from the radicand and the root, then n's own error
            let rel = EPS * (4.0 + (0.75 * (c1 * c1 + 4.0 * c2.abs() * n) / s + s) / den);
            let err = if s > 0.0 {
                tau * rel + n_err / s
            } else {
                f64::INFINITY
            };
            self.v_prev = s;
            return (tau, err);
        }
        self.newton(&p, n, n_err)
    }

    /// Safeguarded Newton on `advance(τ) = n` inside a piece (Numerical Recipes' rtsafe).
    #[inline(always)]
    fn newton(&mut self, p: &Piece, n: f64, n_err: f64) -> (f64, f64) {
        let same_piece = self.tau_prev > 0.0;
        let mut lo = if same_piece { self.tau_prev } else { 0.0 };
        let mut hi = p.dur;
        let mut tau = if same_piece && self.v_prev > 0.0 {
            lo + 1.0 / self.v_prev
        } else {
            let v0 = p.velocity(0.0);
            if v0 > 0.0 {
                n / v0
            } else {
                0.5 * (lo + hi)
            }
        };
        if !(tau > lo && tau < hi) {
            tau = 0.5 * (lo + hi);
        }
        let mut last_step = hi - lo;
        let mut v = 0.0;
        for _ in 0..200 {
            let f = p.advance(tau) - n;
            v = p.velocity(tau);
            if f > 0.0 {
                hi = tau;
            } else {
                lo = tau;
            }
            let mut next = tau - f / v;
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            last_step = (next - tau).abs();
            tau = next;
            if last_step * self.clock <= 1e-7
                || last_step <= 4.0 * EPS * tau
                || hi - lo <= 4.0 * EPS * hi
            {
                break;
            }
        }
        self.v_prev = v;
        let eval_err = 8.0 * EPS * (p.term_scale(tau) + n.abs()) + n_err;
        let err = if v > 0.0 {
            eval_err / v + last_step
        } else {
            f64::INFINITY
        };
        (tau, err)
    }

    /// Finds the nearest tick for step i in double-double and checks it against the
    /// exactness condition, moving it by whole ticks until the condition holds.
    #[cold]
    fn settle(&mut self, k: usize, i: f64, tau: f64) -> u64 {
        self.settled += 1;
        let p = *self.profile.piece(k);
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
            let below = self.profile.position_dd(Dd::new(e - 0.5) / f);
            if below >= step && e > 0.0 {
                e -= 1.0;
                continue;
            }
            let above = self.profile.position_dd(Dd::new(e + 0.5) / f);
            if above < step {
                e += 1.0;
                continue;
            }
            break;
        }
        e as u64
    }
}

impl Iterator for EdgeGenerator {
    type Item = u64;

    #[inline]
    fn next(&mut self) -> Option<u64> {
        let steps = self.profile.steps();
        let i_u = self.next;
        if i_u > steps {
            return None;
        }
        self.next += 1;
        if i_u == steps {
            let e = self.last_edge_tick().max(self.last_edge);
            self.last_edge = e;
            return Some(e);
        }
        let i = i_u as f64;
        let mut k = self.piece;
        while self.profile.end_of(k) < i && k + 1 < self.profile.len() {
            k += 1;
        }
        if k != self.piece {
            self.piece = k;
            self.tau_prev = 0.0;
        }
        let (tau, err) = self.solve(k, i);
        let t0 = self.profile.piece(k).t0;
        let x = (t0 + tau) * self.clock;
        let fl = fm::floor(x);
        let dist = (x - fl - 0.5).abs();
        let guard = 2.0 * (err * self.clock + 4.0 * EPS * x) + 1e-9;
        let e = if dist > guard {
            if x - fl >= 0.5 {
                fl as u64 + 1
            } else {
                fl as u64
            }
        } else {
            self.settle(k, i, tau)
        };
        self.tau_prev = tau;
        // Edges never go backwards, even where two steps share a tick.
        let e = e.max(self.last_edge);
        self.last_edge = e;
        Some(e)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let r = self.remaining() as usize;
        (r, Some(r))
    }
}

impl ExactSizeIterator for EdgeGenerator {}

/// Periods between consecutive edges, starting from tick 0.
#[derive(Clone, Debug)]
pub struct Periods {
    edges: EdgeGenerator,
    last: u64,
}

impl Iterator for Periods {
    type Item = u64;
    #[inline]
    fn next(&mut self) -> Option<u64> {
        let e = self.edges.next()?;
        let p = e - self.last;
        self.last = e;
        Some(p)
    }
}

/// Builds a generator for any move in one call.
pub fn edges(m: &crate::profile::Move<'_>, clock_hz: f64) -> Result<EdgeGenerator, PlanError> {
    EdgeGenerator::new(Profile::plan(m)?, clock_hz)
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
}
