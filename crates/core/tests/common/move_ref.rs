//! A move's position function built from the move itself in 256-bit arithmetic
//! (astro-float), independent of the planner's pieces: the family's g(u) (DESIGN.md §2),
//! the phase times or limits, vs, ve and N.
//!
//! Every phase is a velocity change `v = v0 + (v1 − v0)·g(u)`, `u = τ/T` (the decel phase
//! of phase mode is the time mirror `v = v1 + (v0 − v1)·g(1 − u)`), so its position is
//! `v0·τ + (v1 − v0)·T·G(u)` with `G = ∫g`. G is the closed form for the parabolic,
//! exponential and sine shapes, and for trapezoid and both S-curves the exact integral of a
//! piecewise-constant derivative of g (g' for the trapezoid, jerk g'' for scurve, snap g'''
//! for scurve4), normalised so that g(1) = 1. A limits-mode change is the S-curve of the
//! same order whose fractions φ, ψ follow from the limits.

use super::limits_ref::{lim_of, reference};
use astro_float::{BigFloat, Consts, RoundingMode};
use multistep_core::{Family, LimitsMove, Order, PhaseMove, Segment};

pub const P: usize = 256;
const RM: RoundingMode = RoundingMode::ToEven;

pub fn bf(x: f64) -> BigFloat {
    BigFloat::from_f64(x, P)
}

pub fn add(a: &BigFloat, b: &BigFloat) -> BigFloat {
    a.add(b, P, RM)
}
pub fn sub(a: &BigFloat, b: &BigFloat) -> BigFloat {
    a.sub(b, P, RM)
}
pub fn mul(a: &BigFloat, b: &BigFloat) -> BigFloat {
    a.mul(b, P, RM)
}
pub fn div(a: &BigFloat, b: &BigFloat) -> BigFloat {
    a.div(b, P, RM)
}
pub fn lt(a: &BigFloat, b: &BigFloat) -> bool {
    a.cmp(b).unwrap() < 0
}
/// For messages: astro-float has no direct conversion, so through its decimal form.
pub fn to_f64(a: &BigFloat) -> f64 {
    let s = format!("{a}");
    s.parse::<f64>()
        .or_else(|_| s.replace("e+", "e").parse())
        .unwrap_or(f64::NAN)
}

/// A piecewise polynomial g: on `[knots[k], knots[k+1]]` its `order`-th derivative is
/// `values[k]`; `state[k]` holds `[G, g, g', …, g^(order−1)]` at `knots[k]`.
#[derive(Clone, Debug)]
pub struct PolyG {
    order: usize,
    knots: Vec<BigFloat>,
    values: Vec<BigFloat>,
    state: Vec<Vec<BigFloat>>,
}

fn factorial(m: usize) -> f64 {
    (1..=m).product::<usize>() as f64
}

impl PolyG {
    /// From `(length in u, derivative value)` pairs covering [0, 1] (lengths in BigFloat).
    fn new(order: usize, parts: &[(BigFloat, f64)]) -> PolyG {
        let mut knots = vec![bf(0.0)];
        let mut values = Vec::new();
        for (len, v) in parts {
            let last = knots.last().unwrap().clone();
            knots.push(add(&last, len));
            values.push(bf(*v));
        }
        let mut g = PolyG {
            order,
            knots,
            values,
            state: vec![vec![bf(0.0); order + 1]],
        };
        for k in 0..parts.len() {
            let h = sub(&g.knots[k + 1], &g.knots[k]);
            let next = (0..=order).map(|d| g.derivative_in(k, d, &h)).collect();
            g.state.push(next);
        }
        // normalise: g(1) = 1 (g is linear in the values)
        let scale = g.state.last().unwrap()[1].clone();
        g.values = g.values.iter().map(|v| div(v, &scale)).collect();
        g.state = g
            .state
            .iter()
            .map(|s| s.iter().map(|x| div(x, &scale)).collect())
            .collect();
        g
    }

    /// The d-th entry of `[G, g, g', …]` at `knots[k] + h`: Taylor's sum, exact for the
    /// polynomial piece.
    fn derivative_in(&self, k: usize, d: usize, h: &BigFloat) -> BigFloat {
        let s = &self.state[k];
        let mut acc = bf(0.0);
        let mut hp = bf(1.0);
        for m in d..=self.order {
            acc = add(&acc, &div(&mul(&s[m], &hp), &bf(factorial(m - d))));
            hp = mul(&hp, h);
        }
        // the constant top derivative, the (order+1)-th entry of the chain
        add(
            &acc,
            &div(
                &mul(&self.values[k], &hp),
                &bf(factorial(self.order + 1 - d)),
            ),
        )
    }

    fn eval(&self, u: &BigFloat, d: usize) -> BigFloat {
        let k = self.knots[1..]
            .iter()
            .position(|x| !lt(x, u))
            .unwrap_or(self.values.len() - 1);
        let h = sub(u, &self.knots[k]);
        self.derivative_in(k, d, &h)
    }
}

/// The family's g, as the definitions give it.
#[derive(Clone, Debug)]
pub enum G {
    Poly(PolyG),
    Parabolic,
    Exponential(f64),
    Sine,
}

/// Evaluation context (π and astro-float's constant cache).
pub struct Ctx {
    cc: Consts,
    pi: BigFloat,
}

impl Ctx {
    pub fn new() -> Ctx {
        let mut cc = Consts::new().unwrap();
        let pi = cc.pi(P, RM);
        Ctx { cc, pi }
    }

    /// `G(u) = ∫₀ᵘ g`.
    pub fn big_g(&mut self, g: &G, u: &BigFloat) -> BigFloat {
        match g {
            G::Poly(p) => p.eval(u, 0),
            // (2/3) u^{3/2}
            G::Parabolic => div(&mul(&bf(2.0), &mul(u, &u.sqrt(P, RM))), &bf(3.0)),
            // u/2 − sin(πu)/(2π)
            G::Sine => {
                let s = mul(&self.pi, u).sin(P, RM, &mut self.cc);
                sub(&div(u, &bf(2.0)), &div(&s, &mul(&bf(2.0), &self.pi)))
            }
            // (u − ρ(1 − e^{−u/ρ})) / (1 − e^{−1/ρ})
            G::Exponential(rho) => {
                let r = bf(*rho);
                let e_u = div(u, &r).neg().exp(P, RM, &mut self.cc);
                let e_1 = div(&bf(1.0), &r).neg().exp(P, RM, &mut self.cc);
                let num = sub(u, &mul(&r, &sub(&bf(1.0), &e_u)));
                div(&num, &sub(&bf(1.0), &e_1))
            }
        }
    }

    /// `g(u)`.
    pub fn small_g(&mut self, g: &G, u: &BigFloat) -> BigFloat {
        match g {
            G::Poly(p) => p.eval(u, 1),
            G::Parabolic => u.sqrt(P, RM),
            G::Sine => {
                let c = mul(&self.pi, u).cos(P, RM, &mut self.cc);
                div(&sub(&bf(1.0), &c), &bf(2.0))
            }
            G::Exponential(rho) => {
                let r = bf(*rho);
                let e_u = div(u, &r).neg().exp(P, RM, &mut self.cc);
                let e_1 = div(&bf(1.0), &r).neg().exp(P, RM, &mut self.cc);
                div(&sub(&bf(1.0), &e_u), &sub(&bf(1.0), &e_1))
            }
        }
    }
}

/// scurve's jerk schedule in u: +J on [0, φ], 0, −J on [1 − φ, 1].
fn scurve_g(phi: &BigFloat) -> G {
    let mid = sub(&bf(1.0), &mul(&bf(2.0), phi));
    G::Poly(PolyG::new(
        2,
        &[(phi.clone(), 1.0), (mid, 0.0), (phi.clone(), -1.0)],
    ))
}

/// scurve4's snap schedule in u (DESIGN.md §2 table).
fn scurve4_g(phi: &BigFloat, psi: &BigFloat) -> G {
    let r = mul(psi, phi);
    let c = sub(phi, &mul(&bf(2.0), &r));
    let m = sub(&bf(1.0), &mul(&bf(2.0), phi));
    G::Poly(PolyG::new(
        3,
        &[
            (r.clone(), 1.0),
            (c.clone(), 0.0),
            (r.clone(), -1.0),
            (m, 0.0),
            (r.clone(), -1.0),
            (c, 0.0),
            (r, 1.0),
        ],
    ))
}

fn trapezoid_g() -> G {
    G::Poly(PolyG::new(1, &[(bf(1.0), 1.0)]))
}

pub fn family_g(f: Family) -> G {
    match f {
        Family::Trapezoid => trapezoid_g(),
        Family::Parabolic => G::Parabolic,
        Family::Exponential { rho } => G::Exponential(rho),
        Family::Sine => G::Sine,
        Family::SCurve { phi } => scurve_g(&bf(phi)),
        Family::SCurve4 { phi, psi } => scurve4_g(&bf(phi), &bf(psi)),
    }
}

/// One velocity change from v0 to v1 over `dur`.
#[derive(Clone, Debug)]
pub struct Phase {
    pub t0: BigFloat,
    pub dur: BigFloat,
    pub p0: BigFloat,
    pub v0: BigFloat,
    pub v1: BigFloat,
    pub g: G,
    /// `v = v1 + (v0 − v1)·g(1 − u)` instead of `v0 + (v1 − v0)·g(u)`.
    pub mirrored: bool,
}

/// A move as a chain of phases, from its definition.
pub struct MoveRef {
    pub phases: Vec<Phase>,
    pub steps: u64,
    pub duration: BigFloat,
}

impl MoveRef {
    fn build(
        ctx: &mut Ctx,
        steps: u64,
        parts: Vec<(BigFloat, BigFloat, BigFloat, G, bool)>,
    ) -> MoveRef {
        let mut phases = Vec::new();
        let (mut t, mut p) = (bf(0.0), bf(0.0));
        for (dur, v0, v1, g, mirrored) in parts {
            if !lt(&bf(0.0), &dur) {
                continue;
            }
            let ph = Phase {
                t0: t.clone(),
                dur: dur.clone(),
                p0: p.clone(),
                v0,
                v1,
                g,
                mirrored,
            };
            p = add(&p, &ph.advance(ctx, &dur));
            t = add(&t, &dur);
            phases.push(ph);
        }
        MoveRef {
            phases,
            steps,
            duration: t,
        }
    }

    /// Phase mode: `vm` from N = vs·Ta + (vm−vs)·Ta·G1 + vm·Tb + ve·Tc + (vm−ve)·Tc·G1.
    pub fn phase(ctx: &mut Ctx, m: &PhaseMove) -> MoveRef {
        let g = family_g(m.family);
        let g1 = ctx.big_g(&g, &bf(1.0));
        let (ta, tb, tc) = (bf(m.accel_time), bf(m.cruise_time), bf(m.decel_time));
        let (vs, ve) = (bf(m.start_speed), bf(m.end_speed));
        let n = bf(m.steps as f64);
        let shed = mul(&sub(&bf(1.0), &g1), &add(&mul(&vs, &ta), &mul(&ve, &tc)));
        let vm = div(&sub(&n, &shed), &add(&mul(&g1, &add(&ta, &tc)), &tb));
        let parts = vec![
            (ta, vs, vm.clone(), g.clone(), false),
            (tb, vm.clone(), vm.clone(), trapezoid_g(), false),
            (tc, vm, ve, g, true),
        ];
        MoveRef::build(ctx, m.steps, parts)
    }

    /// Segment mode: `a = 2(n − v0·T)/T²` (a trapezoid change from v0 to 2n/T − v0).
    pub fn segments(ctx: &mut Ctx, segs: &[Segment]) -> MoveRef {
        let parts = segs
            .iter()
            .map(|s| {
                let (v0, t) = (bf(s.v0), bf(s.duration));
                let v1 = sub(&div(&bf(2.0 * s.steps as f64), &t), &v0);
                (t, v0, v1, trapezoid_g(), false)
            })
            .collect();
        let steps = segs.iter().map(|s| s.steps).sum();
        MoveRef::build(ctx, steps, parts)
    }

    /// Limits mode: the peak (or valley) speed of the time-optimal member of the family,
    /// from the brute-force reference, and each change the S-curve of the same order whose
    /// fractions follow from the limits. Returns the peak speed too.
    pub fn limits(ctx: &mut Ctx, m: &LimitsMove) -> Option<(MoveRef, f64)> {
        let l = lim_of(m);
        let (vs, ve) = (m.start_speed, m.end_speed);
        let (_, vp) = reference(&l, m.steps as f64, vs, ve, m.vmax)?;
        let change = |v0: f64, v1: f64| -> (BigFloat, G) {
            let dv = (v1 - v0).abs();
            let t = l.change_time(dv);
            let g = match m.order {
                Order::Trapezoid => trapezoid_g(),
                // the acceleration rises to its peak in rise(a): φ = rise/T
                Order::SCurve => scurve_g(&div(&bf(l.rise(l.peak_accel(dv))), &bf(t))),
                Order::SCurve4 => {
                    let a = l.peak_accel(dv);
                    let rise = l.rise(a);
                    let ts = if a * l.smax >= l.jmax * l.jmax {
                        l.jmax / l.smax
                    } else {
                        (a / l.smax).sqrt()
                    };
                    scurve4_g(&div(&bf(rise), &bf(t)), &div(&bf(ts), &bf(rise)))
                }
            };
            (bf(t), g)
        };
        let (t1, g1) = change(vs, vp);
        let (t2, g2) = change(vp, ve);
        let (bvs, bvp, bve) = (bf(vs), bf(vp), bf(ve));
        // steps of the two changes: (v0 + v1)/2 · T each; the cruise covers the rest
        let half = |a: &BigFloat, b: &BigFloat, t: &BigFloat| div(&mul(&add(a, b), t), &bf(2.0));
        let d = add(&half(&bvs, &bvp, &t1), &half(&bvp, &bve, &t2));
        let mut tb = div(&sub(&bf(m.steps as f64), &d), &bvp);
        if lt(&tb, &bf(0.0)) {
            tb = bf(0.0);
        }
        let parts = vec![
            (t1, bvs, bvp.clone(), g1, false),
            (tb, bvp.clone(), bvp.clone(), trapezoid_g(), false),
            (t2, bvp, bve, g2, false),
        ];
        Some((MoveRef::build(ctx, m.steps, parts), vp))
    }

    fn phase_at(&self, t: &BigFloat) -> &Phase {
        let k = self.phases.iter().rposition(|p| !lt(t, &p.t0)).unwrap_or(0);
        &self.phases[k]
    }

    /// p(t) in steps.
    pub fn position(&self, ctx: &mut Ctx, t: &BigFloat) -> BigFloat {
        if !lt(&bf(0.0), t) {
            return bf(0.0);
        }
        if !lt(t, &self.duration) {
            return self.end(ctx);
        }
        let ph = self.phase_at(t);
        add(&ph.p0, &ph.advance(ctx, &sub(t, &ph.t0)))
    }

    /// Where the last phase ends (N, up to the move's own exactness).
    pub fn end(&self, ctx: &mut Ctx) -> BigFloat {
        let ph = self.phases.last().unwrap();
        add(&ph.p0, &ph.advance(ctx, &ph.dur))
    }

    /// v(t) in steps/s.
    pub fn velocity(&self, ctx: &mut Ctx, t: &BigFloat) -> BigFloat {
        let ph = self.phase_at(t);
        let mut tau = sub(t, &ph.t0);
        if lt(&ph.dur, &tau) {
            tau = ph.dur.clone();
        }
        ph.velocity(ctx, &tau)
    }
}

impl Phase {
    /// Position above p0 at local time τ.
    pub fn advance(&self, ctx: &mut Ctx, tau: &BigFloat) -> BigFloat {
        let u = div(tau, &self.dur);
        if self.mirrored {
            // v1·τ + (v0 − v1)·T·(G(1) − G(1 − u))
            let g1 = ctx.big_g(&self.g, &bf(1.0));
            let gw = ctx.big_g(&self.g, &sub(&bf(1.0), &u));
            let span = mul(&sub(&self.v0, &self.v1), &self.dur);
            add(&mul(&self.v1, tau), &mul(&span, &sub(&g1, &gw)))
        } else {
            let span = mul(&sub(&self.v1, &self.v0), &self.dur);
            add(&mul(&self.v0, tau), &mul(&span, &ctx.big_g(&self.g, &u)))
        }
    }

    pub fn velocity(&self, ctx: &mut Ctx, tau: &BigFloat) -> BigFloat {
        let u = div(tau, &self.dur);
        if self.mirrored {
            let g = ctx.small_g(&self.g, &sub(&bf(1.0), &u));
            add(&self.v1, &mul(&sub(&self.v0, &self.v1), &g))
        } else {
            let g = ctx.small_g(&self.g, &u);
            add(&self.v0, &mul(&sub(&self.v1, &self.v0), &g))
        }
    }
}
