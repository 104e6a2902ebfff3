//! The integer edge stream: the pieces in order, each step one [`IntPiece::edge`].

use super::piece::IntPiece;
use super::plan::IntProfile;

/// Streams the edge tick of every step of an [`IntProfile`], in order, with integer
/// arithmetic only.
#[derive(Clone, Debug)]
pub struct IntEdgeGenerator {
    profile: IntProfile,
    /// The piece being played and its next step (0-based within the piece).
    piece: usize,
    j: u64,
    /// Steps still to come.
    left: u64,
}

impl IntEdgeGenerator {
    pub fn new(profile: IntProfile) -> Self {
        let left = profile.steps();
        IntEdgeGenerator {
            profile,
            piece: 0,
            j: 0,
            left,
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
        match self.left {
            0 => return None,
            // the move ends on step N (same contract as the float generator; the kernel
            // gives the same tick unless the move ends with a dwell)
            1 => {
                self.left = 0;
                return Some(self.profile.end_tick());
            }
            _ => {}
        }
        // planning guarantees the pieces' step counts add up to the move's
        while self.j >= self.current().steps {
            self.piece += 1;
            self.j = 0;
        }
        let e = self.current().edge(self.j);
        self.j += 1;
        self.left -= 1;
        Some(e)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left as usize, Some(self.left as usize))
    }
}

impl ExactSizeIterator for IntEdgeGenerator {}
