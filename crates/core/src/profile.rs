//! A planned move as a piecewise position function `p(t)` (DESIGN.md §1), and its
//! evaluation. Planning lives in `plan` (dispatch), `phase` and `limits`; pieces are chained
//! by `builder`.

use crate::dd::Dd;
use crate::piece::Piece;

pub use crate::moves::{
    Family, LimitsMove, Move, Order, PhaseMove, Segment, DEFAULT_PHI, DEFAULT_PSI, DEFAULT_RHO,
    MAX_PIECES, MAX_STEPS,
};

/// A planned move: a chain of pieces whose position goes from 0 to `steps`.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    pub(crate) pieces: [Piece; MAX_PIECES],
    /// `ends[k]` is the position where piece k ends (the next piece's `p0`).
    pub(crate) ends: [f64; MAX_PIECES],
    pub(crate) len: usize,
    pub(crate) steps: u64,
    pub(crate) duration: f64,
}

impl Profile {
    /// Steps of the move.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Duration T (s): the last step happens at T.
    pub fn duration(&self) -> f64 {
        self.duration
    }

    pub(crate) fn pieces(&self) -> &[Piece] {
        &self.pieces[..self.len]
    }

    /// Position where piece k ends.
    #[inline(always)]
    pub(crate) fn end_of(&self, k: usize) -> f64 {
        self.ends[k]
    }

    #[inline(always)]
    pub(crate) fn piece(&self, k: usize) -> &Piece {
        &self.pieces[k]
    }

    pub(crate) fn len(&self) -> usize {
        self.len
    }

    fn piece_at(&self, t: f64) -> usize {
        let ps = self.pieces();
        let k = ps.partition_point(|p| p.t0 <= t);
        k.saturating_sub(1)
    }

    /// Position p(t) in steps (0 before the move, N after it).
    pub fn position(&self, t: f64) -> f64 {
        if !(t > 0.0) {
            return 0.0;
        }
        if t >= self.duration {
            return self.steps as f64;
        }
        let p = &self.pieces[self.piece_at(t)];
        p.p0 + p.advance((t - p.t0).min(p.dur))
    }

    /// Velocity (steps/s) at t.
    pub fn velocity(&self, t: f64) -> f64 {
        if t < 0.0 || t > self.duration {
            return 0.0;
        }
        let p = &self.pieces[self.piece_at(t)];
        p.velocity(self.local_time(p, t))
    }

    /// Acceleration (steps/s²) at t.
    pub fn acceleration(&self, t: f64) -> f64 {
        if t < 0.0 || t > self.duration {
            return 0.0;
        }
        let p = &self.pieces[self.piece_at(t)];
        p.acceleration(self.local_time(p, t))
    }

    /// Time into piece `p` at t; the move's end is the last piece's end exactly (`t0 + dur`
    /// may round apart from the duration, and a √-shaped end would turn that ulp of t into
    /// √(ε·t/dur) of speed).
    fn local_time(&self, p: &Piece, t: f64) -> f64 {
        if t >= self.duration {
            p.dur
        } else {
            (t - p.t0).min(p.dur)
        }
    }

    /// p(t) in double-double, for settling edges near a half tick.
    pub(crate) fn position_dd(&self, t: Dd) -> Dd {
        if !(t.hi > 0.0) {
            return Dd::ZERO;
        }
        if t.hi >= self.duration {
            return Dd::new(self.steps as f64);
        }
        let p = &self.pieces[self.piece_at(t.hi)];
        let tau = t - Dd::new(p.t0);
        let tau = if tau.hi > p.dur { Dd::new(p.dur) } else { tau };
        Dd::new(p.p0) + p.advance(tau)
    }

    /// Largest |v| and |a| on the profile, sampled densely on every piece (ends included).
    pub fn peaks(&self) -> (f64, f64) {
        let (mut vmax, mut amax) = (0.0f64, 0.0f64);
        for p in self.pieces() {
            const N: usize = 256;
            for k in 0..=N {
                let tau = p.dur * k as f64 / N as f64;
                vmax = vmax.max(p.velocity(tau).abs());
                amax = amax.max(p.acceleration(tau).abs());
            }
        }
        (vmax, amax)
    }
}
