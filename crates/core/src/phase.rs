//! Phase mode (the seeds' accel/cruise/decel times, every family) and segment mode (seed
//! 000's constant-acceleration segments).

use crate::builder::{planned, Builder};
use crate::error::{fraction, non_negative, positive, PlanError};
use crate::moves::{Family, PhaseMove, Segment, MAX_STEPS};
use crate::piece::Law;
use crate::profile::Profile;

pub(crate) fn check_steps(steps: u64) -> Result<u64, PlanError> {
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

/// Phase mode: `vm` follows from N = vs·Ta + (vm−vs)·Ta·G1 + vm·Tb + ve·Tc + (vm−ve)·Tc·G1.
pub(crate) fn plan<const N: usize>(m: &PhaseMove) -> Result<Profile<N>, PlanError> {
    planned(|prof| plan_into(m, prof))
}

/// [`plan`] into `prof`'s storage (its pieces unspecified on an error).
pub(crate) fn plan_into<const N: usize>(
    m: &PhaseMove,
    prof: &mut Profile<N>,
) -> Result<(), PlanError> {
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
    let mut b = Builder::new(prof);
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
pub(crate) fn plan_segments<const N: usize>(segs: &[Segment]) -> Result<Profile<N>, PlanError> {
    planned(|prof| plan_segments_into(segs, prof))
}

/// [`plan_segments`] into `prof`'s storage (its pieces unspecified on an error).
pub(crate) fn plan_segments_into<const N: usize>(
    segs: &[Segment],
    prof: &mut Profile<N>,
) -> Result<(), PlanError> {
    if segs.len() > N {
        return Err(PlanError::TooManyPieces {
            max: N,
            what: "segments",
        });
    }
    let mut b = Builder::new(prof);
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
