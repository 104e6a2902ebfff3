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

    pub fn end(&self) -> f64 {
        self.p0 + self.advance(self.dur)
    }
}
