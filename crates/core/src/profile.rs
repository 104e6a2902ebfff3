//! A move as a piecewise position function `p(t)` (DESIGN.md §1), and the three ways of
//! specifying one (§2): phase mode, segment mode and limits mode.

use crate::dd::Dd;
use crate::error::{fraction, non_negative, positive, PlanError, UnknownName};
use crate::limits;
use crate::piece::{Law, Piece};
use crate::shape::Shape;

/// Most pieces one profile holds (a fixed array: planning and generation never allocate).
pub const MAX_PIECES: usize = 64;
/// Most steps one move may have: positions stay exact integers in f64 with room to spare.
pub const MAX_STEPS: u64 = 1 << 48;

/// A velocity-curve family (DESIGN.md §2 table).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Family {
    Trapezoid,
    Parabolic,
    Exponential { rho: f64 },
    Sine,
    SCurve { phi: f64 },
    SCurve4 { phi: f64, psi: f64 },
}

pub const DEFAULT_RHO: f64 = 0.25;
pub const DEFAULT_PHI: f64 = 0.5;
pub const DEFAULT_PSI: f64 = 0.5;

impl Family {
    pub const NAMES: [&'static str; 6] = [
        "trapezoid",
        "parabolic",
        "exponential",
        "sine",
        "scurve",
        "scurve4",
    ];

    pub fn name(&self) -> &'static str {
        match self {
            Family::Trapezoid => "trapezoid",
            Family::Parabolic => "parabolic",
            Family::Exponential { .. } => "exponential",
            Family::Sine => "sine",
            Family::SCurve { .. } => "scurve",
            Family::SCurve4 { .. } => "scurve4",
        }
    }

    /// Parses a family name with its optional shape parameters (defaults: ρ = 0.25, φ = ψ = ½).
    pub fn parse(
        name: &str,
        rho: Option<f64>,
        phi: Option<f64>,
        psi: Option<f64>,
    ) -> Result<Family, PlanError> {
        let phi_v = || fraction("phi", phi.unwrap_or(DEFAULT_PHI));
        Ok(match name {
            "trapezoid" => Family::Trapezoid,
            "parabolic" => Family::Parabolic,
            "sine" => Family::Sine,
            "exponential" => Family::Exponential {
                rho: positive("rho", rho.unwrap_or(DEFAULT_RHO))?,
            },
            "scurve" => Family::SCurve { phi: phi_v()? },
            "scurve4" => Family::SCurve4 {
                phi: phi_v()?,
                psi: fraction("psi", psi.unwrap_or(DEFAULT_PSI))?,
            },
            other => return Err(PlanError::UnknownFamily(UnknownName::new(other))),
        })
    }

    fn shape(&self) -> Option<Shape> {
        match *self {
            Family::Parabolic => Some(Shape::Parabolic),
            Family::Sine => Some(Shape::Sine),
            Family::Exponential { rho } => Some(Shape::Exponential { rho }),
            _ => None,
        }
    }

    /// `G(1) = ∫₀¹ g(u) du`.
    pub fn g1(&self) -> f64 {
        match self.shape() {
            Some(s) => s.g1(),
            // trapezoid and both S-curves have g(u) + g(1−u) = 1
            None => 0.5,
        }
    }
}

/// Phase mode: N steps in accel, cruise and decel times (the seeds' way).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhaseMove {
    pub steps: u64,
    pub accel_time: f64,
    pub cruise_time: f64,
    pub decel_time: f64,
    pub start_speed: f64,
    pub end_speed: f64,
    pub family: Family,
}

/// One constant-acceleration segment of seed 000's register model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    /// Start speed (steps/s).
    pub v0: f64,
    /// Duration (s).
    pub duration: f64,
    /// Steps covered.
    pub steps: u64,
}

/// The order of a limits-mode profile: which derivative is bounded last.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// vmax, amax.
    Trapezoid,
    /// vmax, amax, jmax.
    SCurve,
    /// vmax, amax, jmax, smax.
    SCurve4,
}

/// Limits mode: the time-optimal move of N steps under kinematic limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimitsMove {
    pub steps: u64,
    pub order: Order,
    pub vmax: f64,
    pub amax: f64,
    pub jmax: Option<f64>,
    pub smax: Option<f64>,
    pub start_speed: f64,
    pub end_speed: f64,
}

impl LimitsMove {
    /// A trapezoid from rest to rest: `n` steps under `vmax` (steps/s) and `amax` (steps/s²).
    pub const fn trapezoid(steps: u64, vmax: f64, amax: f64) -> Self {
        LimitsMove {
            steps,
            order: Order::Trapezoid,
            vmax,
            amax,
            jmax: None,
            smax: None,
            start_speed: 0.0,
            end_speed: 0.0,
        }
    }

    /// A jerk-limited S-curve from rest to rest (`jmax` in steps/s³).
    pub const fn scurve(steps: u64, vmax: f64, amax: f64, jmax: f64) -> Self {
        LimitsMove {
            order: Order::SCurve,
            jmax: Some(jmax),
            ..LimitsMove::trapezoid(steps, vmax, amax)
        }
    }

    /// A snap-limited 4th-order S-curve from rest to rest (`smax` in steps/s⁴).
    pub const fn scurve4(steps: u64, vmax: f64, amax: f64, jmax: f64, smax: f64) -> Self {
        LimitsMove {
            order: Order::SCurve4,
            jmax: Some(jmax),
            smax: Some(smax),
            ..LimitsMove::trapezoid(steps, vmax, amax)
        }
    }

    /// The same move starting at `start` and ending at `end` steps/s.
    pub const fn with_speeds(self, start: f64, end: f64) -> Self {
        LimitsMove {
            start_speed: start,
            end_speed: end,
            ..self
        }
    }
}

/// A move in any of the three modes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Move<'a> {
    Phase(PhaseMove),
    Segments(&'a [Segment]),
    Limits(LimitsMove),
}

/// A planned move: a chain of pieces whose position goes from 0 to `steps`.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    pieces: [Piece; MAX_PIECES],
    /// `ends[k]` is the position where piece k ends (the next piece's `p0`).
    ends: [f64; MAX_PIECES],
    len: usize,
    steps: u64,
    duration: f64,
}

/// How far the pieces may end from step N, in units of ε·(N + the terms summed).
const END_TOLERANCE: f64 = 8.0;

/// Appends pieces, carrying time and position forward.
pub(crate) struct Builder {
    pieces: [Piece; MAX_PIECES],
    ends: [f64; MAX_PIECES],
    len: usize,
    t: f64,
    p: f64,
    /// Sum of the magnitudes of the terms the pieces' ends were added from (steps).
    scale: f64,
}

impl Builder {
    pub(crate) fn new() -> Self {
        Builder {
            pieces: [Piece::EMPTY; MAX_PIECES],
            ends: [0.0; MAX_PIECES],
            len: 0,
            t: 0.0,
            p: 0.0,
            scale: 0.0,
        }
    }

    /// Adds a piece; the next one starts where this one ends (or at `exact_end` if given).
    pub(crate) fn push(
        &mut self,
        dur: f64,
        law: Law,
        exact_end: Option<f64>,
    ) -> Result<(), PlanError> {
        if dur <= 0.0 {
            return Ok(());
        }
        if self.len == MAX_PIECES {
            return Err(PlanError::TooManyPieces {
                max: MAX_PIECES,
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
        self.pieces[self.len] = piece;
        self.ends[self.len] = end;
        self.len += 1;
        self.t += dur;
        self.p = end;
        Ok(())
    }

    /// Appends a run of polynomial pieces from speed `v` with zero acceleration and jerk,
    /// where each entry `(duration, x)` sets the acceleration (order 2), jerk (order 3) or
    /// snap (order 4) on its piece and lower derivatives carry over.
    pub(crate) fn push_schedule(
        &mut self,
        order: u8,
        v: f64,
        entries: &[(f64, f64)],
    ) -> Result<(), PlanError> {
        let (mut v, mut a, mut j) = (v, 0.0, 0.0);
        for &(d, x) in entries {
            let s = match order {
                2 => {
                    a = x;
                    j = 0.0;
                    0.0
                }
                3 => {
                    j = x;
                    0.0
                }
                _ => x,
            };
            let law = Law::Poly {
                c1: v,
                c2: a / 2.0,
                c3: j / 6.0,
                c4: s / 24.0,
            };
            self.push(d, law, None)?;
            v += d * (a + d * (j / 2.0 + d * s / 6.0));
            a += d * (j + d * s / 2.0);
            j += d * s;
        }
        Ok(())
    }

    /// Where the pieces so far end (steps).
    pub(crate) fn position(&self) -> f64 {
        self.p
    }

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

    pub(crate) fn finish(mut self, steps: u64) -> Result<Profile, PlanError> {
        if self.len == 0 || !(self.t > 0.0) {
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
        self.ends[self.len - 1] = steps as f64;
        Ok(Profile {
            pieces: self.pieces,
            ends: self.ends,
            len: self.len,
            steps,
            duration: self.t,
        })
    }
}

fn check_steps(steps: u64) -> Result<u64, PlanError> {
    if steps == 0 {
        return Err(PlanError::NoSteps);
    }
    if steps > MAX_STEPS {
        return Err(PlanError::TooManySteps {
            steps,
            max: MAX_STEPS,
        });
    }
    Ok(steps)
}

/// Entries of one S-curve velocity change of `dv` over `t` seconds in phase mode.
fn scurve_phase(family: Family, dv: f64, t: f64) -> ([(f64, f64); 7], usize, u8) {
    let mut e = [(0.0, 0.0); 7];
    match family {
        Family::SCurve { phi } => {
            // jerk ±J on [0,φ] and [1−φ,1]; a_max = Jφ, ∫a = Jφ(1−φ) = 1 (units of u)
            let j = dv / (t * t * phi * (1.0 - phi));
            e[0] = (phi * t, j);
            e[1] = ((1.0 - 2.0 * phi) * t, 0.0);
            e[2] = (phi * t, -j);
            (e, 3, 3)
        }
        Family::SCurve4 { phi, psi } => {
            // a_max = 1/(1−φ) reached after a jerk ramp with snap S: a_max = Sψφ²(1−ψ)
            let s = dv / ((1.0 - phi) * psi * phi * phi * (1.0 - psi) * t * t * t);
            let (r, c, m) = (
                psi * phi * t,
                (1.0 - 2.0 * psi) * phi * t,
                (1.0 - 2.0 * phi) * t,
            );
            e = [
                (r, s),
                (c, 0.0),
                (r, -s),
                (m, 0.0),
                (r, -s),
                (c, 0.0),
                (r, s),
            ];
            (e, 7, 4)
        }
        _ => {
            e[0] = (t, dv / t);
            (e, 1, 2)
        }
    }
}

impl Profile {
    /// Plans a move in any mode.
    pub fn plan(m: &Move<'_>) -> Result<Profile, PlanError> {
        match m {
            Move::Phase(p) => Profile::phase(p),
            Move::Segments(s) => Profile::segments(s),
            Move::Limits(l) => Profile::limits(l),
        }
    }

    /// Limits mode: the time-optimal move of its order that never exceeds a limit.
    pub fn limits(m: &LimitsMove) -> Result<Profile, PlanError> {
        limits::plan(m)
    }

    /// Limits mode on a clock of `clock_hz`: a trapezoid's accel, cruise and decel times are
    /// rounded up to whole ticks (so no limit is exceeded) and the cruise speed follows from
    /// N, exactly as the integer datapath ([`crate::int::IntProfile::limits`]) and the FPGA
    /// plan it, so all of them emit the same edges. S-curves are planned as [`Profile::limits`].
    pub fn limits_on_clock(m: &LimitsMove, clock_hz: f64) -> Result<Profile, PlanError> {
        limits::plan_on_clock(m, clock_hz)
    }

    /// Any mode, with limits-mode trapezoids on whole ticks ([`Profile::limits_on_clock`]):
    /// what a move plays as on a clock of `clock_hz`.
    pub fn plan_on_clock(m: &Move<'_>, clock_hz: f64) -> Result<Profile, PlanError> {
        match m {
            Move::Limits(l) => Profile::limits_on_clock(l, clock_hz),
            other => Profile::plan(other),
        }
    }

    /// Phase mode: `vm` follows from N = vs·Ta + (vm−vs)·Ta·G1 + vm·Tb + ve·Tc + (vm−ve)·Tc·G1.
    pub fn phase(m: &PhaseMove) -> Result<Profile, PlanError> {
        let steps = check_steps(m.steps)?;
        let ta = non_negative("accel time", m.accel_time)?;
        let tb = non_negative("cruise time", m.cruise_time)?;
        let tc = non_negative("decel time", m.decel_time)?;
        let vs = non_negative("start speed", m.start_speed)?;
        let ve = non_negative("end speed", m.end_speed)?;
        // re-validate shape parameters given directly rather than through `Family::parse`
        match m.family {
            Family::Exponential { rho } => {
                positive("rho", rho)?;
            }
            Family::SCurve { phi } => {
                fraction("phi", phi)?;
            }
            Family::SCurve4 { phi, psi } => {
                fraction("phi", phi)?;
                fraction("psi", psi)?;
            }
            _ => {}
        }
        if ta + tb + tc <= 0.0 {
            return Err(PlanError::ZeroDuration);
        }
        let g1 = m.family.g1();
        let n = steps as f64;
        let vm = (n - (1.0 - g1) * (vs * ta + ve * tc)) / (g1 * (ta + tc) + tb);
        if !(vm >= 0.0) || !vm.is_finite() {
            return Err(PlanError::CannotShed {
                steps,
                start_speed: vs,
                end_speed: ve,
                cruise_speed: vm,
            });
        }
        let mut b = Builder::new();
        match m.family.shape() {
            Some(shape) => {
                let accel = Law::Shaped {
                    shape,
                    mirrored: false,
                    base: vs,
                    span: (vm - vs) * ta,
                };
                b.push(ta, accel, None)?;
                b.cruise(vm, tb)?;
                let decel = Law::Shaped {
                    shape,
                    mirrored: true,
                    base: ve,
                    span: (vm - ve) * tc,
                };
                b.push(tc, decel, None)?;
            }
            None => {
                if ta > 0.0 {
                    let (e, k, order) = scurve_phase(m.family, vm - vs, ta);
                    b.push_schedule(order, vs, &e[..k])?;
                }
                b.cruise(vm, tb)?;
                if tc > 0.0 {
                    let (e, k, order) = scurve_phase(m.family, ve - vm, tc);
                    b.push_schedule(order, vm, &e[..k])?;
                }
            }
        }
        b.finish(steps)
    }

    /// Segment mode (seed 000): each segment `(v0, T, n)` has `a = 2(n − v0·T)/T²`.
    pub fn segments(segs: &[Segment]) -> Result<Profile, PlanError> {
        if segs.len() > MAX_PIECES {
            return Err(PlanError::TooManyPieces {
                max: MAX_PIECES,
                what: "segments",
            });
        }
        let mut b = Builder::new();
        let mut total: u64 = 0;
        for (index, s) in segs.iter().enumerate() {
            let v0 = non_negative("segment start speed", s.v0)?;
            let t = positive("segment time", s.duration)?;
            let n = s.steps as f64;
            let mut end_speed = (2.0 * n - v0 * t) / t;
            if end_speed < 0.0 && end_speed > -1e-12 * (v0 + n / t) {
                end_speed = 0.0;
            }
            if end_speed < 0.0 {
                return Err(PlanError::SegmentReverses { index, end_speed });
            }
            let a = 2.0 * (n - v0 * t) / (t * t);
            total = total.saturating_add(s.steps);
            let law = Law::Poly {
                c1: v0,
                c2: a / 2.0,
                c3: 0.0,
                c4: 0.0,
            };
            b.push(t, law, Some(total as f64))?;
        }
        let steps = check_steps(total)?;
        b.finish(steps)
    }

    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Duration T (s): the last step happens at T.
    pub fn duration(&self) -> f64 {
        self.duration
    }

    pub fn pieces(&self) -> &[Piece] {
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
        p.velocity((t - p.t0).min(p.dur))
    }

    /// Acceleration (steps/s²) at t.
    pub fn acceleration(&self, t: f64) -> f64 {
        if t < 0.0 || t > self.duration {
            return 0.0;
        }
        let p = &self.pieces[self.piece_at(t)];
        p.acceleration((t - p.t0).min(p.dur))
    }

    /// p(t) in double-double, for settling edges near a half tick.
    pub fn position_dd(&self, t: Dd) -> Dd {
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

    /// Largest |v| and |a| on the profile, sampled densely on every piece (ends included).
    pub fn peaks(&self) -> (f64, f64) {
        let (mut vmax, mut amax) = (0.0f64, 0.0f64);
        for p in self.pieces() {
            const N: usize = 256;
            for k in 0..=N {
                let tau = p.dur * k as f64 / N as f64;
                vmax = vmax.max(p.velocity(tau).abs());
                amax = amax.max(p.acceleration(tau).abs());
            }
        }
        (vmax, amax)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finish_refuses_pieces_that_miss_step_n() {
        let cruise = |b: &mut Builder, v: f64| b.cruise(v, 1.0).unwrap();
        let mut b = Builder::new();
        cruise(&mut b, 10.0);
        assert!(b.finish(10).is_ok());
        let mut b = Builder::new();
        cruise(&mut b, 10.0 + 1e-12);
        assert!(matches!(
            b.finish(10),
            Err(PlanError::MissesLastStep { steps: 10, .. })
        ));
    }
}
