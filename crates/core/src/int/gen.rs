//! The integer edge stream: the pieces in order, each step one [`IntPiece::edge`].

use super::piece::IntPiece;
use super::plan::IntProfile;
use crate::accum::StepAccumulator;
use crate::MAX_PIECES;
use core::borrow::Borrow;

/// Streams the edge tick of every step of an [`IntProfile`], in order, with integer
/// arithmetic only.
///
/// It owns its profile (`IntEdgeGenerator<IntProfile>`, the default) or borrows it
/// (`IntEdgeGenerator<&IntProfile>`: the generator's own state only, no copy of the
/// pieces), as [`EdgeGenerator`](crate::EdgeGenerator) does.
#[derive(Clone, Debug)]
pub struct IntEdgeGenerator<P: Borrow<IntProfile<N>> = IntProfile, const N: usize = MAX_PIECES> {
    profile: P,
    /// The piece being played and its next step (0-based within the piece).
    piece: usize,
    j: u64,
    /// Steps still to come, besides the `run_left` the accumulator gives first.
    left: u64,
    run_left: u64,
    acc: StepAccumulator,
}

impl<P: Borrow<IntProfile<N>>, const N: usize> IntEdgeGenerator<P, N> {
    /// The edges of `profile` (an `IntProfile` or a reference to one).
    pub fn new(profile: P) -> Self {
        let left = profile.borrow().steps();
        IntEdgeGenerator {
            profile,
            piece: 0,
            j: 0,
            left,
            run_left: 0,
            acc: StepAccumulator::default(),
        }
    }

    /// The profile played.
    pub fn profile(&self) -> &IntProfile<N> {
        self.profile.borrow()
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
            match self.step_general() {
                Some(e) => out[k] = e,
                None => break,
            }
            k += 1;
            let n = self.ramp_len(out.len() - k);
            if n > 0 {
                let mut slots = out[k..k + n as usize].iter_mut();
                self.ramp_steps(n, (), |(), e| {
                    if let Some(slot) = slots.next() {
                        *slot = e;
                    }
                });
                k += n as usize;
            }
        }
        k
    }

    /// Folds every remaining edge into `init`, constant-speed runs through the
    /// accumulator held in local variables.
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
            match self.step_general() {
                Some(e) => out = f(out, e),
                None => return out,
            }
            let n = self.ramp_len(usize::MAX);
            if n > 0 {
                out = self.ramp_steps(n, out, &mut f);
            }
        }
    }

    /// Steps (at most `room`) a ramp run may give from here: the rest of the current
    /// piece if it is a ramp, before step N (which keeps its own rule).
    #[inline(always)]
    fn ramp_len(&self, room: usize) -> u64 {
        if self.left < 2 || self.piece >= self.profile().pieces().len() {
            return 0;
        }
        let p = self.current();
        if p.is_cruise() || self.j >= p.steps {
            return 0;
        }
        (p.steps - self.j).min(self.left - 1).min(room as u64)
    }

    /// `n` steps of the current ramp piece with its constants in local variables: the f64
    /// guess proved in integers, the exact kernel where the proof fails.
    #[inline(always)]
    fn ramp_steps<B>(&mut self, n: u64, mut out: B, mut f: impl FnMut(B, u64) -> B) -> B {
        let p = *self.current();
        let Some(mut ramp) = p.ramp(self.j) else {
            for _ in 0..n {
                let e = p.edge(self.j);
                self.j += 1;
                out = f(out, e);
            }
            self.left -= n;
            return out;
        };
        let mut j = self.j;
        for _ in 0..n {
            let local = match ramp.next_local() {
                Some(e) => e,
                None => p.kernel_local_edge(j),
            };
            out = f(out, p.t0 + local);
            j += 1;
        }
        self.j = j;
        self.left -= n;
        out
    }

    #[inline(always)]
    fn current(&self) -> &IntPiece {
        // `piece` stays below the profile's length (planning makes the steps add up)
        &self.profile.borrow().pieces()[self.piece]
    }

    /// The next edge by the piece's kernel; on a cruise piece, starts the accumulator
    /// for the piece's later steps (step N keeps its own rule).
    #[inline(always)]
    fn step_general(&mut self) -> Option<u64> {
        match self.left {
            0 => return None,
            // the move ends on step N (same contract as the float generator; the kernel
            // gives the same tick unless the move ends with a dwell)
            1 => {
                self.left = 0;
                return Some(self.profile.borrow().end_tick());
            }
            _ => {}
        }
        // planning guarantees the pieces' step counts add up to the move's
        while self.j >= self.current().steps {
            self.piece += 1;
            self.j = 0;
        }
        let p = self.current();
        let e = p.edge(self.j);
        let run = (p.steps - self.j - 1).min(self.left - 2);
        if run > 0 && p.is_cruise() {
            if let Some(acc) = p.cruise_accumulator(self.j + 1) {
                self.acc = acc;
                self.run_left = run;
                self.j += run;
                self.left -= run;
            }
        }
        self.j += 1;
        self.left -= 1;
        Some(e)
    }
}

impl<P: Borrow<IntProfile<N>>, const N: usize> Iterator for IntEdgeGenerator<P, N> {
    type Item = u64;

    #[inline]
    fn next(&mut self) -> Option<u64> {
        if self.run_left > 0 {
            self.run_left -= 1;
            return Some(self.acc.next_edge());
        }
        self.step_general()
    }

    #[inline]
    fn fold<B, F: FnMut(B, u64) -> B>(mut self, init: B, f: F) -> B {
        self.fold_edges(init, f)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = (self.left + self.run_left) as usize;
        (n, Some(n))
    }
}

impl<P: Borrow<IntProfile<N>>, const N: usize> ExactSizeIterator for IntEdgeGenerator<P, N> {}
