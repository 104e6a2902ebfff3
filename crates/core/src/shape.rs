//! Velocity shapes that are not polynomials: parabolic, exponential and sine
//! (DESIGN.md §2). On an accel phase `v(t) = vs + Δv·g(u)`, `u = t/T`, so the position is
//! `vs·t + Δv·T·G(u)` with `G(u) = ∫₀ᵘ g`. A decel phase is the time mirror: its rate is
//! `h(u) = g(1 − u)` and its integral `H(u) = G(1) − G(1 − u)`, written below in forms that
//! do not cancel for small u.

use crate::real::{fm, Real};

/// A non-polynomial velocity shape `g(u)` on `u ∈ [0, 1]`, `g(0) = 0`, `g(1) = 1`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// `g = √u` (seed 001 eq. (9)–(15)).
    Parabolic,
    /// `g = (1 − e^(−u/ρ)) / (1 − e^(−1/ρ))` (seed 001; seed 003 eq. (2)); ρ = τ/T.
    Exponential {
        /// Exponential ρ.
        rho: f64,
    },
    /// `g = (1 − cos πu) / 2`.
    Sine,
}

/// Whether R is wider than f64 (then series coefficients are divided out in R, so the
/// double-double path keeps its full precision).
#[inline(always)]
fn wide<R: Real>() -> bool {
    core::mem::size_of::<R>() > 8
}

/// `first · Σ_{k≥0} Π_{m=1..k} (x / d(m))`, summed forward with the term recurrence.
#[inline(always)]
fn series<R: Real>(x: R, first: R, d: impl Fn(usize) -> f64) -> R {
    let n = if wide::<R>() { 32 } else { 18 };
    let mut term = first;
    let mut sum = first;
    for m in 1..n {
        term = if wide::<R>() {
            term * x / R::from_f64(d(m))
        } else {
            term * x * R::from_f64(1.0 / d(m))
        };
        sum = sum + term;
    }
    sum
}

/// `e^(−x) − 1 + x = x²/2 − x³/6 + …` without cancellation.
#[inline]
fn exp_tail<R: Real>(x: R) -> R {
    if x.to_f64() < 0.5 {
        // x²/2 · Σ (−x)^k · 2/(k+2)!
        let half = R::from_f64(0.5);
        series(-x, x * x * half, |m| (m + 2) as f64)
    } else {
        (-x).exp_m1() + x
    }
}

/// `y − sin y = y³/6 − y⁵/120 + …` without cancellation.
#[inline]
fn sin_tail<R: Real>(y: R) -> R {
    if y.to_f64() < 1.0 {
        let first = y * y * y / R::from_f64(6.0);
        series(-(y * y), first, |m| ((2 * m + 2) * (2 * m + 3)) as f64)
    } else {
        y - y.sin()
    }
}

impl Shape {
    /// `G(1) = ∫₀¹ g`: the fraction of `Δv·T` that a phase covers.
    pub fn g1(self) -> f64 {
        match self {
            Shape::Parabolic => 2.0 / 3.0,
            Shape::Sine => 0.5,
            Shape::Exponential { rho } => {
                let d = -crate::real::fm::exp_m1(-1.0 / rho);
                exp_tail(1.0 / rho) * rho / d
            }
        }
    }

    /// `g(u)` (accel) or `h(u) = g(1−u)` (mirrored decel).
    #[inline]
    pub(crate) fn rate<R: Real>(self, u: R, mirrored: bool) -> R {
        let one = R::from_f64(1.0);
        let w = if mirrored { one - u } else { u };
        match self {
            Shape::Parabolic => w.sqrt(),
            Shape::Sine => (one - (R::pi() * w).cos()) * R::from_f64(0.5),
            Shape::Exponential { rho } => {
                let r = R::from_f64(rho);
                let d = -(-(one / r)).exp_m1();
                -((-(w / r)).exp_m1()) / d
            }
        }
    }

    /// `g'(u)` (accel) or `h'(u) = −g'(1−u)` (mirrored decel), in f64.
    pub(crate) fn slope(self, u: f64, mirrored: bool) -> f64 {
        let w = if mirrored { 1.0 - u } else { u };
        let d = match self {
            Shape::Parabolic => 0.5 / crate::real::fm::sqrt(w),
            Shape::Sine => {
                0.5 * core::f64::consts::PI * crate::real::fm::sin(core::f64::consts::PI * w)
            }
            Shape::Exponential { rho } => {
                let den = -crate::real::fm::exp_m1(-1.0 / rho);
                crate::real::fm::exp(-w / rho) / (rho * den)
            }
        };
        if mirrored {
            -d
        } else {
            d
        }
    }

    /// `g''(u)` (accel) or `h''(u) = g''(1−u)` (mirrored decel), in f64: infinite for the
    /// parabola at its steep end.
    pub(crate) fn curvature(self, u: f64, mirrored: bool) -> f64 {
        let w = if mirrored { 1.0 - u } else { u };
        match self {
            Shape::Parabolic => -0.25 / (w * crate::real::fm::sqrt(w)),
            Shape::Sine => {
                let pi = core::f64::consts::PI;
                0.5 * pi * pi * crate::real::fm::cos(pi * w)
            }
            Shape::Exponential { rho } => {
                let den = -crate::real::fm::exp_m1(-1.0 / rho);
                -crate::real::fm::exp(-w / rho) / (rho * rho * den)
            }
        }
    }

    /// `G(u)` (accel) or `H(u)` (mirrored decel).
    #[inline]
    pub(crate) fn integral<R: Real>(self, u: R, mirrored: bool) -> R {
        let one = R::from_f64(1.0);
        let two_thirds = R::from_f64(2.0) / R::from_f64(3.0);
        match (self, mirrored) {
            (Shape::Parabolic, false) => two_thirds * u * u.sqrt(),
            (Shape::Parabolic, true) => {
                // (2/3)(1 − (1−u)^{3/2}) = (2/3)·u(3 − 3u + u²) / (1 + (1−u)^{3/2})
                let w = one - u;
                let three = R::from_f64(3.0);
                two_thirds * u * (three - three * u + u * u) / (one + w * w.sqrt())
            }
            (Shape::Sine, false) => sin_tail(R::pi() * u) / (R::from_f64(2.0) * R::pi()),
            (Shape::Sine, true) => {
                let y = R::pi() * u;
                u * R::from_f64(0.5) + y.sin() / (R::from_f64(2.0) * R::pi())
            }
            (Shape::Exponential { rho }, false) => {
                let r = R::from_f64(rho);
                let d = -(-(one / r)).exp_m1();
                r * exp_tail(u / r) / d
            }
            (Shape::Exponential { rho }, true) => {
                // (u − ρ(e^{−(1−u)/ρ} − e^{−1/ρ})) / D
                let r = R::from_f64(rho);
                let d = -(-(one / r)).exp_m1();
                let x = u / r;
                let diff = if x.to_f64() < 1.0 {
                    (-(one / r)).exp() * x.exp_m1()
                } else {
                    (-((one - u) / r)).exp() - (-(one / r)).exp()
                };
                (u - r * diff) / d
            }
        }
    }
}

/// A shaped piece's law, `p(τ) − p0 = base·τ + span·G(τ/dur)`, with its per-piece
/// constants computed once: the same f64 operations as [`Piece`](crate::piece::Piece)'s
/// `advance`, `velocity` and `acceleration` on a `Law::Shaped`, so the same values bit
/// for bit (the edge generator's error bounds hold unchanged), without recomputing
/// `expm1(−1/ρ)` and `e^(−1/ρ)` on every call, and with the position and the velocity
/// sharing their `expm1` or square root where the argument is the same.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapedLaw {
    shape: Shape,
    mirrored: bool,
    base: f64,
    span: f64,
    dur: f64,
    /// `span/dur` and `span/dur²`: velocity and acceleration scales.
    span_rate: f64,
    span_slope: f64,
    /// Exponential: ρ, `D = −expm1(−1/ρ)`, `e^(−1/ρ)`, `ρ·D`.
    rho: f64,
    d: f64,
    e1: f64,
    rho_d: f64,
}

impl ShapedLaw {
    pub fn new(shape: Shape, mirrored: bool, base: f64, span: f64, dur: f64) -> Self {
        let rho = match shape {
            Shape::Exponential { rho } => rho,
            _ => 1.0,
        };
        let d = -fm::exp_m1(-(1.0 / rho));
        ShapedLaw {
            shape,
            mirrored,
            base,
            span,
            dur,
            span_rate: span / dur,
            span_slope: span / (dur * dur),
            rho,
            d,
            e1: fm::exp(-(1.0 / rho)),
            rho_d: rho * d,
        }
    }

    /// `(p(τ) − p0, v(τ))`.
    #[inline]
    pub fn advance_velocity(&self, tau: f64) -> (f64, f64) {
        let u = tau / self.dur;
        let (g, h) = match (self.shape, self.mirrored) {
            (Shape::Parabolic, false) => {
                let r = fm::sqrt(u);
                (2.0 / 3.0 * u * r, r)
            }
            (Shape::Parabolic, true) => {
                let w = 1.0 - u;
                let r = fm::sqrt(w);
                (2.0 / 3.0 * u * (3.0 - 3.0 * u + u * u) / (1.0 + w * r), r)
            }
            (Shape::Exponential { .. }, false) => {
                let x = u / self.rho;
                let em = fm::exp_m1(-x);
                let tail = if x < 0.5 { exp_tail(x) } else { em + x };
                (self.rho * tail / self.d, -em / self.d)
            }
            (Shape::Exponential { .. }, true) => {
                let x = u / self.rho;
                let z = -((1.0 - u) / self.rho);
                let diff = if x < 1.0 {
                    self.e1 * fm::exp_m1(x)
                } else {
                    fm::exp(z) - self.e1
                };
                ((u - self.rho * diff) / self.d, -fm::exp_m1(z) / self.d)
            }
            (Shape::Sine, m) => (self.shape.integral(u, m), self.shape.rate(u, m)),
        };
        (
            self.base * tau + self.span * g,
            self.base + self.span_rate * h,
        )
    }

    /// Which formula the position takes: the `K` of [`advance_of`](Self::advance_of), so
    /// that a loop can be specialised to it.
    pub fn kind(&self) -> u8 {
        match (self.shape, self.mirrored) {
            (Shape::Parabolic, false) => 0,
            (Shape::Parabolic, true) => 1,
            (Shape::Exponential { .. }, false) => 2,
            (Shape::Exponential { .. }, true) => 3,
            (Shape::Sine, false) => 4,
            (Shape::Sine, true) => 5,
        }
    }

    /// `p(τ) − p0` alone for a law of [`kind`](Self::kind) `K` (and only such a law): the
    /// same operations as [`advance_velocity`](Self::advance_velocity)'s position, without
    /// the velocity's own `expm1` or cosine.
    #[inline(always)]
    pub fn advance_of<const K: u8>(&self, tau: f64) -> f64 {
        use core::f64::consts::PI;
        let u = tau / self.dur;
        let g = match K {
            0 => 2.0 / 3.0 * u * fm::sqrt(u),
            1 => {
                let w = 1.0 - u;
                2.0 / 3.0 * u * (3.0 - 3.0 * u + u * u) / (1.0 + w * fm::sqrt(w))
            }
            2 => {
                let x = u / self.rho;
                let tail = if x < 0.5 {
                    exp_tail(x)
                } else {
                    fm::exp_m1(-x) + x
                };
                self.rho * tail / self.d
            }
            3 => {
                let x = u / self.rho;
                let diff = if x < 1.0 {
                    self.e1 * fm::exp_m1(x)
                } else {
                    fm::exp(-((1.0 - u) / self.rho)) - self.e1
                };
                (u - self.rho * diff) / self.d
            }
            4 => sin_tail(PI * u) / (2.0 * PI),
            _ => u * 0.5 + fm::sin(PI * u) / (2.0 * PI),
        };
        self.base * tau + self.span * g
    }

    /// `(v, a, j)` at τ from one `exp` (or one `sin` and one `cos`), for
    /// [`LocalCubic`](crate::jet::LocalCubic)'s coefficients: v within a few ε of the
    /// velocity scale of [`derivative_bounds`](Self::derivative_bounds), a and j within a
    /// few ε of themselves. `None` for the parabola, whose derivatives are unbounded at
    /// u = 0.
    #[inline]
    pub fn derivatives(&self, tau: f64) -> Option<(f64, f64, f64)> {
        use core::f64::consts::PI;
        let u = tau / self.dur;
        let w = if self.mirrored { 1.0 - u } else { u };
        let sign = if self.mirrored { -1.0 } else { 1.0 };
        // the rate h(u) = g(w), its slope ±g'(w), its curvature g''(w)
        let (h, h1, h2) = match self.shape {
            Shape::Parabolic => return None,
            Shape::Exponential { .. } => {
                let e = fm::exp(-w / self.rho);
                let g1 = e / self.rho_d;
                ((1.0 - e) / self.d, sign * g1, -g1 / self.rho)
            }
            Shape::Sine => {
                let (s, c) = (fm::sin(PI * w), fm::cos(PI * w));
                (0.5 * (1.0 - c), sign * (0.5 * PI) * s, (0.5 * PI * PI) * c)
            }
        };
        Some((
            self.base + self.span_rate * h,
            self.span_slope * h1,
            self.span_slope / self.dur * h2,
        ))
    }

    /// Bounds over the piece for [`LocalCubic`](crate::jet::LocalCubic): the scale of the
    /// velocity's terms as [`derivatives`](Self::derivatives) rounds them (`|base| +
    /// |span/dur|`, over D for the exponential, whose `1 − e` carries ε absolute), and
    /// `|a|`, `|j|` and `|p⁗|`: `span/dur^k` times the shape's largest |g'|, |g''|,
    /// |g'''| (`π^k/2` for the sine, `1/(ρ^(k−1)·ρD)` for the exponential), each with a
    /// margin for rounding. `None` for the parabola.
    pub fn derivative_bounds(&self) -> Option<[f64; 4]> {
        use core::f64::consts::PI;
        let (v_scale, g1, g2, g3) = match self.shape {
            Shape::Parabolic => return None,
            Shape::Exponential { .. } => {
                let (r, rd) = (self.rho, self.rho_d);
                (1.0 / self.d, 1.0 / rd, 1.0 / (r * rd), 1.0 / (r * r * rd))
            }
            Shape::Sine => (1.0, 0.5 * PI, 0.5 * PI * PI, 0.5 * PI * PI * PI),
        };
        let slope = self.span_slope.abs();
        let k = 1.01;
        Some([
            k * (self.base.abs() + self.span_rate.abs() * v_scale),
            k * slope * g1,
            k * slope / self.dur * g2,
            k * slope / (self.dur * self.dur) * g3,
        ])
    }

    /// A bound on |a(τ)| over the piece where the shape's slope is bounded: `π/2` (sine)
    /// and `1/(ρD)` (exponential, at its steep end) times `span/dur²`, with a margin for
    /// rounding; `None` for the parabola, whose slope is unbounded at u = 0.
    pub fn max_abs_acceleration(&self) -> Option<f64> {
        let g = match self.shape {
            Shape::Sine => 0.5 * core::f64::consts::PI,
            Shape::Exponential { .. } => 1.0 / self.rho_d,
            Shape::Parabolic => return None,
        };
        Some(1.001 * (self.span_slope * g).abs())
    }

    /// `a(τ)`, as [`Shape::slope`] scaled.
    #[inline]
    pub fn acceleration(&self, tau: f64) -> f64 {
        let u = tau / self.dur;
        let s = match self.shape {
            Shape::Exponential { .. } => {
                let w = if self.mirrored { 1.0 - u } else { u };
                let d = fm::exp(-w / self.rho) / self.rho_d;
                if self.mirrored {
                    -d
                } else {
                    d
                }
            }
            _ => self.shape.slope(u, self.mirrored),
        };
        self.span_slope * s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dd::Dd;

    fn shapes() -> [Shape; 5] {
        [
            Shape::Parabolic,
            Shape::Sine,
            Shape::Exponential { rho: 0.25 },
            Shape::Exponential { rho: 0.05 },
            Shape::Exponential { rho: 3.0 },
        ]
    }

    /// Simpson's rule on the rate must agree with the closed-form integral.
    #[test]
    fn integral_matches_quadrature() {
        for s in shapes() {
            for &mirrored in &[false, true] {
                for &u in &[1e-6, 0.01, 0.3, 0.5, 0.77, 1.0] {
                    let n = 20_000;
                    let h = u / n as f64;
                    let mut acc = 0.0;
                    for k in 0..=n {
                        let w = if k == 0 || k == n {
                            1.0
                        } else if k % 2 == 1 {
                            4.0
                        } else {
                            2.0
                        };
                        acc += w * s.rate(k as f64 * h, mirrored);
                    }
                    let quad = acc * h / 3.0;
                    let closed = s.integral(u, mirrored);
                    // √u is singular at an end, where Simpson's rule converges slowly
                    let tol = if matches!(s, Shape::Parabolic) {
                        1e-7
                    } else {
                        1e-11
                    };
                    assert!(
                        (quad - closed).abs() <= tol * closed.abs().max(1e-12),
                        "{s:?} m={mirrored} u={u}: {quad} vs {closed}"
                    );
                }
            }
            assert!((s.integral(1.0, false) - s.g1()).abs() < 1e-15);
            assert!((s.integral(1.0, true) - s.g1()).abs() < 1e-15);
            assert!((s.rate(1.0, false) - 1.0).abs() < 1e-15);
            assert!(s.rate(0.0, false).abs() < 1e-15);
        }
    }

    /// The hoisted law gives the piece's values bit for bit.
    #[test]
    fn shaped_law_is_the_piece_bit_for_bit() {
        use crate::piece::{Law, Piece};
        for s in shapes() {
            for &mirrored in &[false, true] {
                let (base, span, dur) = (123.25, 4567.5, 0.73);
                let piece = Piece {
                    t0: 0.0,
                    dur,
                    p0: 0.0,
                    law: Law::Shaped {
                        shape: s,
                        mirrored,
                        base,
                        span,
                    },
                };
                let law = ShapedLaw::new(s, mirrored, base, span, dur);
                for k in 0..=2000 {
                    let tau = dur * k as f64 / 2000.0;
                    let (a, v) = law.advance_velocity(tau);
                    let alone = match law.kind() {
                        0 => law.advance_of::<0>(tau),
                        1 => law.advance_of::<1>(tau),
                        2 => law.advance_of::<2>(tau),
                        3 => law.advance_of::<3>(tau),
                        4 => law.advance_of::<4>(tau),
                        _ => law.advance_of::<5>(tau),
                    };
                    assert_eq!(alone.to_bits(), a.to_bits(), "{s:?} {mirrored} {tau}");
                    assert_eq!(
                        a.to_bits(),
                        piece.advance(tau).to_bits(),
                        "{s:?} {mirrored} {tau}"
                    );
                    assert_eq!(
                        v.to_bits(),
                        piece.velocity(tau).to_bits(),
                        "{s:?} {mirrored} {tau}"
                    );
                    assert_eq!(
                        law.acceleration(tau).to_bits(),
                        piece.acceleration(tau).to_bits(),
                        "{s:?} {mirrored} {tau}"
                    );
                    if let Some(amax) = law.max_abs_acceleration() {
                        assert!(piece.acceleration(tau).abs() <= amax, "{s:?} {tau}");
                    }
                }
            }
        }
    }

    #[test]
    fn dd_and_f64_agree() {
        for s in shapes() {
            for &mirrored in &[false, true] {
                for &u in &[1e-9, 0.001, 0.49, 0.51, 0.999, 1.0] {
                    let a = s.integral(u, mirrored);
                    let b = s.integral(Dd::new(u), mirrored).to_f64();
                    assert!(
                        (a - b).abs() <= 2e-15 * b.abs().max(1e-300),
                        "{s:?} {mirrored} {u}: {a} {b}"
                    );
                }
            }
        }
    }
}
