//! A planned move as a piecewise position function `p(t)` (DESIGN.md §1), and its
//! evaluation. Planning lives in `plan` (dispatch), `phase` and `limits`; pieces are chained
//! by `builder`.

use crate::dd::Dd;
use crate::piece::Piece;

use crate::error::PlanError;
pub use crate::moves::{
    Family, LimitsMove, Move, Order, PhaseMove, Segment, DEFAULT_PHI, DEFAULT_PSI, DEFAULT_RHO,
    MAX_PHASE_PIECES, MAX_PIECES, MAX_STEPS,
};

/// A planned move: a chain of at most `N` pieces whose position goes from 0 to `steps`.
///
/// The default capacity is [`MAX_PIECES`], enough for any move, and what the edge
/// generator plays. A phase or limits move has at most [`MAX_PHASE_PIECES`] pieces, so it
/// may be planned into a smaller profile with the `*_in` planners
/// (`Profile::<MAX_PHASE_PIECES>::limits_in`): about 1 KB instead of 5, the same pieces bit
/// for bit, and [`Profile::resize`] makes the full-size one when it is to be played.
/// [`Profile::replan_limits`] plans into a profile's storage again.
#[derive(Clone, Debug)]
pub struct Profile<const N: usize = MAX_PIECES> {
    pub(crate) pieces: [Piece; N],
    /// `ends[k]` is the position where piece k ends (the next piece's `p0`).
    pub(crate) ends: [f64; N],
    pub(crate) len: usize,
    pub(crate) steps: u64,
    pub(crate) duration: f64,
    /// The integer move it plays on its clock, if any (`Profile::plan_on_clock`).
    pub(crate) exact: Option<crate::int::ExactMove>,
}

/// Equal moves: the same pieces, bit for bit (the unused slots of a reused profile hold
/// whatever was planned there before).
impl<const N: usize> PartialEq for Profile<N> {
    fn eq(&self, other: &Self) -> bool {
        self.pieces() == other.pieces()
            && self.ends[..self.len] == other.ends[..other.len]
            && (self.steps, self.duration, self.exact) == (other.steps, other.duration, other.exact)
    }
}

impl<const N: usize> Profile<N> {
    /// The same profile in a capacity of `M` pieces; an error if it has more than `M`.
    pub fn resize<const M: usize>(&self) -> Result<Profile<M>, PlanError> {
        if self.len > M {
            return Err(PlanError::TooManyPieces {
                max: M,
                what: "segments and phases together",
            });
        }
        let mut p = Profile {
            pieces: [Piece::EMPTY; M],
            ends: [0.0; M],
            len: self.len,
            steps: self.steps,
            duration: self.duration,
            exact: self.exact,
        };
        p.pieces[..self.len].copy_from_slice(self.pieces());
        p.ends[..self.len].copy_from_slice(&self.ends[..self.len]);
        Ok(p)
    }

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

    /// Largest |v| and |a| on the profile (ends included), each piece's from its closed
    /// form ([`Piece::peaks`]).
    pub fn peaks(&self) -> (f64, f64) {
        self.pieces().iter().fold((0.0f64, 0.0f64), |(v, a), p| {
            let (pv, pa) = p.peaks();
            (v.max(pv), a.max(pa))
        })
    }

    /// Largest |v| on the profile: [`Profile::peaks`]' speed alone.
    pub fn peak_speed(&self) -> f64 {
        self.pieces()
            .iter()
            .fold(0.0f64, |v, p| v.max(p.peak_speed()))
    }

    /// Largest |jerk| on the profile; `None` if a piece is parabolic (its acceleration is
    /// unbounded at the steep end).
    pub fn peak_jerk(&self) -> Option<f64> {
        self.pieces()
            .iter()
            .try_fold(0.0f64, |j, p| Some(j.max(p.peak_jerk()?)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::moves::{LimitsMove, PhaseMove};
    use proptest::prelude::*;

    /// Largest |v|, |a| and |jerk| from `n + 1` evenly spaced samples of every piece.
    fn sampled(p: &Profile, n: usize) -> (f64, f64, f64) {
        let (mut v, mut a, mut j) = (0.0f64, 0.0f64, 0.0f64);
        for pc in p.pieces() {
            for k in 0..=n {
                let tau = pc.dur * k as f64 / n as f64;
                v = v.max(pc.velocity(tau).abs());
                a = a.max(pc.acceleration(tau).abs());
                j = j.max(pc.jerk(tau).abs());
            }
        }
        (v, a, j)
    }

    /// The closed form is at least the 257-point sample (up to a few ulps of rounding in
    /// evaluating v at a different τ) and within 1e-9 of a 2^16-point one; infinite only
    /// where the sample is.
    fn check(p: &Profile) -> Result<(), TestCaseError> {
        let (v, a) = p.peaks();
        let (sv, sa, _) = sampled(p, 256);
        let (dv, da, dj) = sampled(p, 1 << 16);
        for (name, got, coarse, dense) in [("v", v, sv, dv), ("a", a, sa, da)] {
            if dense.is_infinite() {
                prop_assert!(got.is_infinite(), "{name}: {got} vs sampled {dense}");
                continue;
            }
            prop_assert!(
                got >= coarse * (1.0 - 8.0 * f64::EPSILON),
                "{name}: {got} < {coarse}"
            );
            prop_assert!(
                got >= dense * (1.0 - 8.0 * f64::EPSILON),
                "{name}: {got} < {dense}"
            );
            prop_assert!(got <= dense * (1.0 + 1e-9), "{name}: {got} > {dense}");
        }
        if let Some(j) = p.peak_jerk() {
            prop_assert!(j >= dj * (1.0 - 8.0 * f64::EPSILON) && j <= dj * (1.0 + 1e-9));
        } else {
            prop_assert!(p.pieces().iter().any(|pc| pc.peak_jerk().is_none()));
        }
        Ok(())
    }

    fn family() -> impl Strategy<Value = Family> {
        prop_oneof![
            Just(Family::Trapezoid),
            Just(Family::Parabolic),
            (0.03f64..4.0).prop_map(|rho| Family::Exponential { rho }),
            Just(Family::Sine),
            (0.05f64..=0.5).prop_map(|phi| Family::SCurve { phi }),
            (0.05f64..=0.5, 0.05f64..=0.5).prop_map(|(phi, psi)| Family::SCurve4 { phi, psi }),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

        #[test]
        fn phase_mode_peaks_are_the_dense_samples(
            family in family(),
            steps in 1u64..2_000_000,
            ta in 1e-3f64..2.0, tb in 0.0f64..2.0, tc in 1e-3f64..2.0,
            vs in 0.0f64..1.0, ve in 0.0f64..1.0,
        ) {
            let base = steps as f64 / (ta + tb + tc);
            let m = PhaseMove::new(steps, family, ta, tb, tc).with_speeds(vs * base, ve * base);
            if let Ok(p) = Profile::phase(&m) {
                check(&p)?;
            }
        }

        #[test]
        fn limits_mode_peaks_are_the_dense_samples(
            order in 0usize..3,
            steps in 1u64..2_000_000,
            vmax in 10.0f64..1e6, amax in 10.0f64..1e7, jmax in 10.0f64..1e9, smax in 10.0f64..1e11,
            vs in 0.0f64..1.0, ve in 0.0f64..1.0,
        ) {
            let m = crate::moves::limits_of_order(order, steps, [vmax, amax, jmax, smax], [vs, ve]);
            if let Ok(p) = Profile::limits(&m) {
                check(&p)?;
                let (v, a) = p.peaks();
                prop_assert!(v <= vmax * (1.0 + 1e-9) && a <= amax * (1.0 + 1e-9));
                if order > 0 {
                    prop_assert!(p.peak_jerk().unwrap() <= jmax * (1.0 + 1e-9));
                }
            }
        }

        #[test]
        fn segment_mode_peaks_are_the_dense_samples(
            segs in prop::collection::vec((0.0f64..1e4, 1e-3f64..1.0, 1u64..10_000), 1..8),
        ) {
            let segs: std::vec::Vec<Segment> = segs
                .into_iter()
                .map(|(v0, duration, steps)| Segment { v0, duration, steps })
                .collect();
            if let Ok(p) = Profile::segments(&segs) {
                check(&p)?;
            }
        }
    }

    #[test]
    fn a_parabolic_move_has_no_peak_jerk_and_an_infinite_peak_acceleration() {
        let p = Profile::phase(&PhaseMove::new(1000, Family::Parabolic, 0.1, 0.1, 0.1)).unwrap();
        assert!(p.peaks().1.is_infinite());
        assert_eq!(p.peak_jerk(), None);
        let s = Profile::limits(&LimitsMove::scurve(100_000, 1e4, 1e5, 1e6)).unwrap();
        assert!((s.peak_jerk().unwrap() - 1e6).abs() <= 1e-9 * 1e6);
    }
}
