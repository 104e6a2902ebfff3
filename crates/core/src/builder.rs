//! Chains pieces into a profile, carrying time and position forward.

use crate::error::PlanError;
use crate::piece::{Law, Piece};
use crate::profile::Profile;

/// How far the pieces may end from step N, in units of ε·(N + the terms summed).
const END_TOLERANCE: f64 = 64.0;

/// Appends pieces, carrying time and position forward, into a profile of at most `N`
/// pieces (written in place: no copy of the pieces).
pub(crate) struct Builder<'a, const N: usize> {
    prof: &'a mut Profile<N>,
    t: f64,
    p: f64,
    /// Sum of the magnitudes of the terms the pieces' ends were added from (steps).
    scale: f64,
}

impl<const N: usize> Profile<N> {
    /// No pieces yet.
    #[inline(always)]
    pub(crate) fn empty() -> Self {
        Profile {
            pieces: [Piece::EMPTY; N],
            ends: [0.0; N],
            len: 0,
            steps: 0,
            duration: 0.0,
            exact: None,
        }
    }

    /// No pieces, as [`Profile::empty`], keeping the storage.
    #[inline(always)]
    pub(crate) fn clear(&mut self) {
        self.len = 0;
        self.steps = 0;
        self.duration = 0.0;
        self.exact = None;
    }
}

/// The profile `plan` builds, built where it is returned (a profile is a kilobyte or more:
/// planning into a local and returning it would copy it).
#[inline(always)]
pub(crate) fn planned<const N: usize>(
    plan: impl FnOnce(&mut Profile<N>) -> Result<(), PlanError>,
) -> Result<Profile<N>, PlanError> {
    let mut out = Ok(Profile::empty());
    if let Ok(prof) = &mut out {
        if let Err(e) = plan(prof) {
            out = Err(e);
        }
    }
    out
}

/// A profile with no pieces, storage for [`Profile::replan_limits`].
impl<const N: usize> Default for Profile<N> {
    fn default() -> Self {
        Profile::empty()
    }
}

impl<'a, const N: usize> Builder<'a, N> {
    /// Builds into `prof`, which is emptied.
    #[inline(always)]
    pub(crate) fn new(prof: &'a mut Profile<N>) -> Self {
        prof.clear();
        Builder {
            prof,
            t: 0.0,
            p: 0.0,
            scale: 0.0,
        }
    }

    /// Adds a piece; the next one starts where this one ends (or at `exact_end` if given).
    #[inline(always)]
    pub(crate) fn push(
        &mut self,
        dur: f64,
        law: Law,
        exact_end: Option<f64>,
    ) -> Result<(), PlanError> {
        if dur <= 0.0 {
            return Ok(());
        }
        let len = self.prof.len;
        if len == N {
            return Err(PlanError::TooManyPieces {
                max: N,
                what: "segments and phases together",
            });
        }
        let piece = Piece {
            t0: self.t,
            dur,
            p0: self.p,
            law,
        };
        let end = exact_end.unwrap_or_else(|| piece.end()).max(self.p);
        self.scale += piece.term_scale(dur);
        self.prof.pieces[len] = piece;
        self.prof.ends[len] = end;
        self.prof.len = len + 1;
        self.t += dur;
        self.p = end;
        Ok(())
    }

    /// Appends a run of polynomial pieces from speed `v` with zero acceleration and jerk
    /// ([`schedule`]).
    #[inline(always)]
    pub(crate) fn push_schedule(
        &mut self,
        order: u8,
        v: f64,
        entries: &[(f64, f64)],
    ) -> Result<(), PlanError> {
        let mut sch = Schedule::new(order, v);
        for &(d, x) in entries {
            let law = sch.next(d, x);
            self.push(d, law, None)?;
        }
        Ok(())
    }

    /// Where the pieces so far end (steps).
    pub(crate) fn position(&self) -> f64 {
        self.p
    }

    #[inline(always)]
    pub(crate) fn cruise(&mut self, v: f64, dur: f64) -> Result<(), PlanError> {
        self.push(
            dur,
            Law::Poly {
                c1: v,
                c2: 0.0,
                c3: 0.0,
                c4: 0.0,
            },
            None,
        )
    }

    /// Checks the pieces end on step N and completes the profile.
    #[inline(always)]
    pub(crate) fn finish(self, steps: u64) -> Result<(), PlanError> {
        let len = self.prof.len;
        if len == 0 || !(self.t > 0.0) {
            return Err(PlanError::ZeroDuration);
        }
        // The move ends on step N by definition. The pieces reach N up to the rounding of
        // the terms their ends are summed from; anything more is a planning error, never
        // silently absorbed.
        let n = steps as f64;
        if !((self.p - n).abs() <= END_TOLERANCE * f64::EPSILON * (n + self.scale)) {
            return Err(PlanError::MissesLastStep {
                reached: self.p,
                steps,
            });
        }
        self.prof.ends[len - 1] = n;
        self.prof.steps = steps;
        self.prof.duration = self.t;
        Ok(())
    }
}

/// The laws of a run of polynomial pieces from speed `v` with zero acceleration and jerk,
/// where each entry `(duration, x)` sets the acceleration (order 2), jerk (order 3) or
/// snap (order 4) on its piece and lower derivatives carry over.
struct Schedule {
    order: u8,
    v: f64,
    a: f64,
    j: f64,
}

impl Schedule {
    #[inline(always)]
    fn new(order: u8, v: f64) -> Self {
        Schedule {
            order,
            v,
            a: 0.0,
            j: 0.0,
        }
    }

    /// The law of the piece of entry `(d, x)`; the state moves to its end.
    #[inline(always)]
    fn next(&mut self, d: f64, x: f64) -> Law {
        let s = match self.order {
            2 => {
                self.a = x;
                self.j = 0.0;
                0.0
            }
            3 => {
                self.j = x;
                0.0
            }
            _ => x,
        };
        let (v, a, j) = (self.v, self.a, self.j);
        let law = Law::Poly {
            c1: v,
            c2: a / 2.0,
            c3: j / 6.0,
            c4: s / 24.0,
        };
        self.v = v + d * (a + d * (j / 2.0 + d * s / 6.0));
        self.a = a + d * (j + d * s / 2.0);
        self.j = j + d * s;
        law
    }
}

/// Where [`Builder::push_schedule`] on an empty builder ends, bit for bit, without a
/// builder (whose piece arrays cost more to set up than the sums).
#[inline(always)]
pub(crate) fn schedule_end(order: u8, v: f64, entries: &[(f64, f64)]) -> f64 {
    let mut p = 0.0;
    let mut sch = Schedule::new(order, v);
    for &(dur, x) in entries {
        let law = sch.next(dur, x);
        if dur > 0.0 {
            let piece = Piece {
                t0: 0.0,
                dur,
                p0: p,
                law,
            };
            p = piece.end().max(p);
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finish_refuses_pieces_that_miss_step_n() {
        let cruise = |b: &mut Builder<4>, v: f64| b.cruise(v, 1.0).unwrap();
        let mut p = Profile::<4>::empty();
        let mut b = Builder::new(&mut p);
        cruise(&mut b, 10.0);
        assert!(b.finish(10).is_ok());
        let mut b = Builder::new(&mut p);
        cruise(&mut b, 10.0 + 1e-12);
        assert!(matches!(
            b.finish(10),
            Err(PlanError::MissesLastStep { steps: 10, .. })
        ));
    }

    /// (order, start speed, schedule)
    type Run<'a> = (u8, f64, &'a [(f64, f64)]);

    #[test]
    fn schedule_end_is_where_a_builder_ends() {
        let runs: [Run; 4] = [
            (2, 3.0, &[(0.7, -2.5)]),
            (3, 0.0, &[(0.1, 1e6), (0.0, 0.0), (0.1, -1e6)]),
            (3, 1e4, &[(0.013, -7e5), (0.2, 0.0), (0.013, 7e5)]),
            (
                4,
                5.0,
                &[
                    (0.01, 3e9),
                    (0.02, 0.0),
                    (0.01, -3e9),
                    (0.3, 0.0),
                    (0.01, -3e9),
                    (0.02, 0.0),
                    (0.01, 3e9),
                ],
            ),
        ];
        for (order, v, entries) in runs {
            let mut p = Profile::<7>::empty();
            let mut b = Builder::new(&mut p);
            b.push_schedule(order, v, entries).unwrap();
            assert!(b.position() > 0.0);
            assert_eq!(
                schedule_end(order, v, entries).to_bits(),
                b.position().to_bits()
            );
        }
    }
}
