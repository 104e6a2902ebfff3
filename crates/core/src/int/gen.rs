//! The integer edge stream: one [`IntPiece::edge`] per step, the step target advanced by
//! one addition (`M += Den`).

use super::piece::IntPiece;
use super::plan::IntProfile;

/// Streams the edge tick of every step of an [`IntProfile`], in order, with integer
/// arithmetic only.
#[derive(Clone, Debug)]
pub struct IntEdgeGenerator {
    profile: IntProfile,
    /// Next step (1-based), its piece and its target `Den·i − C` in that piece.
    next: u64,
    piece: usize,
    m: u128,
}

impl IntEdgeGenerator {
    pub fn new(profile: IntProfile) -> Self {
        let m = profile.pieces()[0].target(1).unwrap_or(0);
        IntEdgeGenerator {
            profile,
            next: 1,
            piece: 0,
            m,
        }
    }

    pub fn profile(&self) -> &IntProfile {
        &self.profile
    }

    /// Writes up to `out.len()` edges; returns how many were written.
    pub fn fill(&mut self, out: &mut [u64]) -> usize {
        let mut k = 0;
        for slot in out.iter_mut() {
            match self.next() {
                Some(e) => *slot = e,
                None => break,
            }
            k += 1;
        }
        k
    }

    #[inline(always)]
    fn current(&self) -> &IntPiece {
        &self.profile.pieces()[self.piece]
    }
}

impl Iterator for IntEdgeGenerator {
    type Item = u64;

    #[inline]
    fn next(&mut self) -> Option<u64> {
        let i = self.next;
        let steps = self.profile.steps();
        if i > steps {
            return None;
        }
        self.next += 1;
        if i == steps {
            // the move ends on step N (same contract as the float generator)
            return Some(self.profile.end_tick());
        }
        // step i lies in the first piece whose end position is ≥ i
        while self.m > self.current().m_end && self.piece + 1 < self.profile.pieces().len() {
            self.piece += 1;
            self.m = self.current().target(i).unwrap_or(u128::MAX);
        }
        let p = *self.current();
        let e = p.edge(self.m);
        self.m += p.den;
        Some(e)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let r = (self.profile.steps() + 1 - self.next) as usize;
        (r, Some(r))
    }
}

impl ExactSizeIterator for IntEdgeGenerator {}
