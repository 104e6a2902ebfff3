//! One piece of a piecewise position function. A profile is a chain of pieces; the f64
//! coefficients stored here *are* the profile: the edge generator inverts exactly this
//! function, and tests evaluate exactly this function in higher precision.

use crate::real::Real;
use crate::shape::Shape;

/// How position grows inside a piece, in local time τ ∈ [0, dur].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Law {
    /// `p(τ) = c1·τ + c2·τ² + c3·τ³ + c4·τ⁴` (constant snap 24·c4).
    Poly { c1: f64, c2: f64, c3: f64, c4: f64 },
    /// `p(τ) = base·τ + span·H(τ/dur)` with H the shape's integral (mirrored on decel).
    Shaped {
        shape: Shape,
        mirrored: bool,
        base: f64,
        span: f64,
    },
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Start time (s) and duration (s).
    pub t0: f64,
    pub dur: f64,
    /// Position at the start (steps).
    pub p0: f64,
    pub law: Law,
}

impl Piece {
    pub const EMPTY: Piece = Piece {
        t0: 0.0,
        dur: 0.0,
        p0: 0.0,
        law: Law::Poly {
            c1: 0.0,
            c2: 0.0,
            c3: 0.0,
            c4: 0.0,
        },
    };

    /// Position relative to `p0` at local time τ.
    #[inline(always)]
    pub fn advance<R: Real>(&self, tau: R) -> R {
        match self.law {
            Law::Poly { c1, c2, c3, c4 } => {
                let f = R::from_f64;
                tau * (f(c1) + tau * (f(c2) + tau * (f(c3) + tau * f(c4))))
            }
            Law::Shaped {
                shape,
                mirrored,
                base,
                span,
            } => {
                let u = tau / R::from_f64(self.dur);
                R::from_f64(base) * tau + R::from_f64(span) * shape.integral(u, mirrored)
            }
        }
    }

    /// Velocity (steps/s) at local time τ.
    #[inline(always)]
    pub fn velocity<R: Real>(&self, tau: R) -> R {
        match self.law {
            Law::Poly { c1, c2, c3, c4 } => {
                let f = R::from_f64;
                f(c1) + tau * (f(2.0 * c2) + tau * (f(3.0 * c3) + tau * f(4.0 * c4)))
            }
            Law::Shaped {
                shape,
                mirrored,
                base,
                span,
            } => {
                let d = R::from_f64(self.dur);
                R::from_f64(base) + R::from_f64(span) / d * shape.rate(tau / d, mirrored)
            }
        }
    }

    /// Acceleration (steps/s²) at local time τ.
    #[inline(always)]
    pub fn acceleration(&self, tau: f64) -> f64 {
        match self.law {
            Law::Poly { c2, c3, c4, .. } => 2.0 * c2 + tau * (6.0 * c3 + tau * 12.0 * c4),
            Law::Shaped {
                shape,
                mirrored,
                span,
                ..
            } => span / (self.dur * self.dur) * shape.slope(tau / self.dur, mirrored),
        }
    }

    /// Magnitude of the terms summed in `advance`, for rounding-error bounds.
    #[inline(always)]
    pub fn term_scale(&self, tau: f64) -> f64 {
        match self.law {
            Law::Poly { c1, c2, c3, c4 } => {
                tau * (c1.abs() + tau * (c2.abs() + tau * (c3.abs() + tau * c4.abs())))
            }
            Law::Shaped { base, span, .. } => base.abs() * tau + span.abs(),
        }
    }

    /// Constant acceleration with no higher terms: the closed form applies.
    #[inline(always)]
    pub fn quadratic(&self) -> Option<(f64, f64)> {
        match self.law {
            Law::Poly { c1, c2, c3, c4 } if c3 == 0.0 && c4 == 0.0 => Some((c1, c2)),
            _ => None,
        }
    }

    #[inline(always)]
    pub fn end(&self) -> f64 {
        self.p0 + self.advance(self.dur)
    }

    /// Jerk (steps/s³) at local time τ.
    pub fn jerk(&self, tau: f64) -> f64 {
        match self.law {
            Law::Poly { c3, c4, .. } => 6.0 * c3 + 24.0 * tau * c4,
            Law::Shaped {
                shape,
                mirrored,
                span,
                ..
            } => {
                let d = self.dur;
                span / (d * d * d) * shape.curvature(tau / d, mirrored)
            }
        }
    }

    /// Largest |v| and |a| on the piece, ends included, from its closed form: the ends and
    /// the interior zeros of the derivative. A shape's rate is monotone, its slope has one
    /// interior extremum (the sine's, at u = ½) and the parabola's is infinite at its
    /// steep end, as a dense sample there also finds.
    pub fn peaks(&self) -> (f64, f64) {
        let d = self.dur;
        let v = self.peak_speed();
        let mut a = self.acceleration(0.0).abs().max(self.acceleration(d).abs());
        match self.law {
            Law::Poly { c3, c4, .. } => {
                // j(τ) = 6c3 + 24c4·τ = 0 gives a's
                let t = -c3 / (4.0 * c4);
                if t > 0.0 && t < d {
                    a = a.max(self.acceleration(t).abs());
                }
            }
            Law::Shaped {
                shape: Shape::Sine, ..
            } => a = a.max(self.acceleration(0.5 * d).abs()),
            Law::Shaped { .. } => {}
        }
        (v, a)
    }

    /// Largest |v| on the piece, ends included: [`Piece::peaks`]'s speed without its
    /// acceleration.
    #[inline]
    pub fn peak_speed(&self) -> f64 {
        let d = self.dur;
        let mut v = self.velocity(0.0).abs().max(self.velocity(d).abs());
        if let Law::Poly { c2, c3, c4, .. } = self.law {
            // a(τ) = 2c2 + 6c3·τ + 12c4·τ² = 0 gives v's interior extrema (none when a is
            // constant)
            if c3 != 0.0 || c4 != 0.0 {
                let mut roots = [f64::NAN; 2];
                quadratic_roots(12.0 * c4, 6.0 * c3, 2.0 * c2, &mut roots);
                for t in roots {
                    if t > 0.0 && t < d {
                        v = v.max(self.velocity(t).abs());
                    }
                }
            }
        }
        v
    }

    /// Largest |jerk| on the piece: linear on a polynomial piece and monotone in a sine's
    /// or an exponential's slope derivative, so at an end; `None` on a parabolic piece,
    /// whose acceleration is unbounded.
    pub fn peak_jerk(&self) -> Option<f64> {
        if let Law::Shaped {
            shape: Shape::Parabolic,
            ..
        } = self.law
        {
            return None;
        }
        Some(self.jerk(0.0).abs().max(self.jerk(self.dur).abs()))
    }
}

/// Real roots of `a·x² + b·x + c` into `out` (NaN where none), without cancellation
/// (Numerical Recipes §5.6); a double root's vertex is kept even when rounding makes the
/// discriminant slightly negative, as an extra candidate costs nothing.
fn quadratic_roots(a: f64, b: f64, c: f64, out: &mut [f64; 2]) {
    if a == 0.0 {
        out[0] = -c / b;
        return;
    }
    let disc = b * b - 4.0 * a * c;
    if !(disc > 0.0) {
        out[0] = -b / (2.0 * a);
        return;
    }
    let q = -0.5 * (b + crate::real::fm::sqrt(disc).copysign(b));
    out[0] = q / a;
    out[1] = c / q;
}
