//! A shaped piece's law near a point as a cubic in ticks (its Taylor polynomial), with a
//! bound on how far that cubic may lie from the law: the curve run tests most half ticks
//! of the exponential and the sine with three multiplies instead of an `exp` or a `sin`
//! each, and only re-expands (one `exp`, or a `sin` and a `cos`) every `reach` ticks.

use crate::real::fm;
use crate::shape::ShapedLaw;

const EPS: f64 = f64::EPSILON;

/// Below this many ticks a window pays for none of its expansions: test the law itself.
const MIN_REACH: f64 = 16.0;

/// The Taylor remainder may reach this many steps (or the law's own evaluation bound,
/// if larger): a tested position closer to its step than the margin goes to Newton, about
/// one step in 10⁴ on a fast ramp, so a wider window costs less than it saves.
const REMAINDER_STEPS: f64 = 1e-7;

/// `p(s) − p0` near `at` (local ticks): `c0 + c1·d + c2·d² + c3·d³`, `d = s − at`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LocalCubic {
    at: f64,
    c: [f64; 4],
    /// Largest |d| the cubic is used at (ticks); 0 when the piece has no window.
    reach: f64,
    /// The piece's end in local ticks: an expansion point stays inside the piece, where
    /// the remainder's bound holds.
    end: f64,
}

impl LocalCubic {
    pub const NONE: LocalCubic = LocalCubic {
        at: f64::NAN,
        c: [0.0; 4],
        reach: 0.0,
        end: 0.0,
    };

    /// The window for `law` on a piece of `dur` s at `clock`, and the error its cubic adds
    /// to a tested position (steps), when `law_err` bounds the law's own evaluation and
    /// `scale` bounds |p − p0| and the step numbers.
    ///
    /// Taylor: `|p(τ_a + δ) − Σ_{k≤3} p⁽ᵏ⁾(τ_a)·δᵏ/k!| ≤ M4·δ⁴/24` with `M4` a bound on
    /// `|p⁗|` over the piece. The coefficients carry a few ε of their terms (v's scale,
    /// |a|, |j| times δ, δ²/2, δ³/6), Horner a few ε of every term; and the expansion
    /// point `fl(s_a·w)` and `d = fl(s − s_a)` are each within ε of their value, a shift
    /// of v's scale times `ε·(t_end + δ)`. Each is taken 4 times over.
    pub fn for_piece(
        law: &ShapedLaw,
        dur: f64,
        clock: f64,
        t_end: f64,
        law_err: f64,
        scale: f64,
    ) -> (LocalCubic, f64) {
        let Some([v, a, j, m4]) = law.derivative_bounds() else {
            return (LocalCubic::NONE, 0.0);
        };
        let budget = law_err.max(REMAINDER_STEPS);
        // δ⁴ = 24·budget/M4 (in seconds), at most the piece
        let delta = fm::sqrt(fm::sqrt(24.0 * budget / m4)).min(dur);
        let reach = delta * clock;
        if !(reach >= MIN_REACH) || !(reach.is_finite()) {
            return (LocalCubic::NONE, 0.0);
        }
        let terms = scale + v * delta + a * delta * delta / 2.0 + j * delta * delta * delta / 6.0;
        let rounding = 16.0 * EPS * terms + 8.0 * EPS * v * (t_end + delta);
        let remainder = m4 * delta * delta * delta * delta / 24.0;
        let err = (remainder + rounding) * (1.0 + 1e-6);
        let cubic = LocalCubic {
            at: f64::NAN,
            c: [0.0; 4],
            reach,
            end: dur * clock,
        };
        (cubic, err)
    }

    /// Whether the piece has a window (else its law is tested directly).
    #[inline(always)]
    pub fn active(&self) -> bool {
        self.reach > 0.0
    }

    /// `p(s) − p0` within the error of [`for_piece`](Self::for_piece), expanding again at
    /// a point ahead of `s` (`expand` gives `[p − p0, v, a/2, j/6]` in ticks there) when
    /// `s` is beyond the window.
    #[inline(always)]
    pub fn eval(&mut self, s: f64, expand: impl FnOnce(f64) -> [f64; 4]) -> f64 {
        let mut d = s - self.at;
        // also the first call, with `at` NaN
        if !(d.abs() <= self.reach) {
            self.at = (s + 0.8 * self.reach).min(self.end);
            self.c = expand(self.at);
            d = s - self.at;
        }
        let [c0, c1, c2, c3] = self.c;
        c0 + d * (c1 + d * (c2 + d * c3))
    }
}

/// `[p − p0, v, a/2, j/6]` of `law` at local tick `s` (`w` = 1/clock), in ticks: the
/// position as the curve run's direct test computes it, `advance_of::<K>`.
#[inline(never)]
#[cold]
pub(crate) fn expand<const K: u8>(law: &ShapedLaw, s: f64, w: f64) -> [f64; 4] {
    let tau = s * w;
    let p = law.advance_of::<K>(tau);
    let (v, a, j) = law.derivatives(tau).unwrap_or((0.0, 0.0, 0.0));
    [p, v * w, a * (w * w * 0.5), j * (w * w * w / 6.0)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dd::Dd;
    use crate::real::Real;
    use crate::shape::Shape;

    /// Every cubic value in a window lies within the bound of the law evaluated in
    /// double-double at the exact local time, on fast and slow pieces of both shapes, and
    /// the bound is not loose by more than a few hundred times (the window is used).
    #[test]
    fn the_cubic_stays_within_its_bound_of_the_law() {
        let clock = 50e6;
        let w = 1.0 / clock;
        let shapes = [
            Shape::Sine,
            Shape::Exponential { rho: 0.25 },
            Shape::Exponential { rho: 0.05 },
            Shape::Exponential { rho: 4.0 },
        ];
        let pieces = [(0.0, 2e5, 1.0), (3000.0, -1500.0, 0.4), (10.0, 40.0, 0.05)];
        let mut windows = 0;
        for shape in shapes {
            for mirrored in [false, true] {
                for (base, span, dur) in pieces {
                    let law = ShapedLaw::new(shape, mirrored, base, span, dur);
                    let scale = base.abs() * dur + span.abs();
                    let law_err = 64.0 * EPS * scale;
                    let (mut cubic, err) =
                        LocalCubic::for_piece(&law, dur, clock, dur + w, law_err, scale);
                    if !cubic.active() {
                        continue;
                    }
                    windows += 1;
                    let margin = law_err + err;
                    let kind = law.kind();
                    let (mut worst, mut s) = (0.0f64, 0.37);
                    let step = (cubic.reach / 7.3).max(1.0);
                    while s < dur * clock {
                        let q = cubic.eval(s, |a| match kind {
                            2 => expand::<2>(&law, a, w),
                            3 => expand::<3>(&law, a, w),
                            4 => expand::<4>(&law, a, w),
                            _ => expand::<5>(&law, a, w),
                        });
                        let tau = Dd::new(s) / Dd::new(clock);
                        let u = tau / Dd::new(dur);
                        let exact =
                            Dd::new(base) * tau + Dd::new(span) * shape.integral(u, mirrored);
                        let off = (Dd::new(q) - exact).to_f64().abs();
                        assert!(
                            off <= margin,
                            "{shape:?} m={mirrored} {base}/{span}/{dur} s={s}: off {off:e} > {margin:e}"
                        );
                        worst = worst.max(off);
                        s += step;
                    }
                    assert!(
                        worst * 300.0 > margin,
                        "{shape:?} m={mirrored} {base}/{span}/{dur}: worst {worst:e}, bound {margin:e}"
                    );
                }
            }
        }
        assert!(windows >= 16, "{windows}");
    }
}
