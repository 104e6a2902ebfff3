//! Every edge is the nearest tick to the exact step time of the *move*: checked against the
//! move's position function built from its definition in 256-bit arithmetic
//! (tests/common/move_ref.rs: the family's g(u), the phase times or limits, vs, ve, N),
//! never from the planner's pieces. Also: velocity continuity, the requested start, end
//! and peak speeds, exact ties on every kind of piece, and typed errors.
// `!(x <= y)` fails on NaN too, on purpose
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod common;

use common::limits_ref::assert_feasible;
use common::move_ref::{bf, div, lt, mul, sub, to_f64, Ctx, MoveRef};
use common::strategies::{clock, family};
use multistep_core::int::{IntClock, IntEdgeGenerator, IntProfile, IntRamp, IntSegment};
use multistep_core::{
    EdgeGenerator, Family, LimitsMove, Move, Order, PhaseMove, PlanError, Profile, Segment,
};
use proptest::prelude::*;

/// How far (ticks) from a half tick a step of the move may lie and still have its edge
/// decided either way: the planner's profile is the move in f64 (its cruise speed, peak
/// speed and coefficients are rounded), so it moves step times by about ε·f·T; a step
/// closer than that to a half tick has no f64-plannable "right" edge.
fn slack(clock: f64, duration: f64) -> f64 {
    1e-7 + 64.0 * f64::EPSILON * clock * duration
}

/// ... and how far (steps) its positions may lie from the move's: the pieces are chained in
/// f64 from terms of up to v·T steps, and planning refuses any that miss N by more than
/// 8·ε·(N + their sum).
fn steps_slack(r: &MoveRef) -> f64 {
    let terms: f64 = r
        .phases
        .iter()
        .map(|p| to_f64(&p.v0).max(to_f64(&p.v1)) * to_f64(&p.dur))
        .sum();
    16.0 * f64::EPSILON * ((r.steps as f64).max(1.0) + terms)
}

struct Checked {
    edges: u64,
    /// Edges within the slack of a half tick that went the other way.
    near: u64,
}

/// Checks the planner's edges of steps `from..from+count` against the move.
fn check_edges(
    ctx: &mut Ctx,
    prof: &Profile,
    r: &MoveRef,
    clock: f64,
    from: u64,
    count: u64,
) -> Result<Checked, String> {
    let mut gen = EdgeGenerator::new(prof.clone(), clock).map_err(|e| e.to_string())?;
    gen.seek(from);
    let n = r.steps;
    let f = bf(clock);
    let d = slack(clock, prof.duration());
    let ds = steps_slack(r);
    let mut out = Checked { edges: 0, near: 0 };
    for i in from..(from + count).min(n + 1) {
        let e = gen.next().ok_or("generator ended early")? as f64;
        if i == n {
            // the move ends on step N at T: the last edge is the tick nearest f·T
            let x = mul(&f, &r.duration);
            let off = sub(&x, &bf(e)).abs();
            if lt(&bf(0.5 + d), &off) {
                return Err(format!("last edge {e}, f·T = {}", to_f64(&x)));
            }
        } else {
            // "below step i", allowing for the reference's own 256-bit rounding (2^-160·i), so
            // that an exact tie reads as p = i
            let target = sub(&bf(i as f64), &bf(1e-48 * i as f64));
            let at = |ctx: &mut Ctx, x: f64| r.position(ctx, &div(&bf(x), &f));
            // exact: p((e − ½)/f) < i ≤ p((e + ½)/f); an exact half tick goes to the earlier tick
            let strict =
                (e == 0.0 || lt(&at(ctx, e - 0.5), &target)) && !lt(&at(ctx, e + 0.5), &target);
            if !strict {
                let (above, below) = (bf(i as f64 + ds), bf(i as f64 - ds));
                let loose = (e == 0.0 || lt(&at(ctx, e - 0.5 - d), &above))
                    && !lt(&at(ctx, e + 0.5 + d), &below);
                if !loose {
                    return Err(format!(
                        "step {i}: edge {e} is not the nearest tick: p((e-½)/f) = {}, p((e+½)/f) = {}",
                        to_f64(&at(ctx, e - 0.5)),
                        to_f64(&at(ctx, e + 0.5))
                    ));
                }
                out.near += 1;
            }
        }
        out.edges += 1;
    }
    Ok(out)
}

/// Velocity agreement, relative to the move's top speed: √u (parabolic) turns an ulp of
/// local time into √ε ≈ 1.5e-8 of speed at the ends of its phases.
const V_TOL: f64 = 5e-8;

/// The planner's velocity equals the move's everywhere (so it is continuous, starts at vs,
/// ends at ve and peaks at the move's peak speed), sampled densely and on both sides of
/// every phase boundary.
fn check_speeds(ctx: &mut Ctx, prof: &Profile, r: &MoveRef, peak: f64) -> Result<(), String> {
    let t_end = prof.duration();
    let first = r.phases.first().unwrap();
    let last = r.phases.last().unwrap();
    let (vs, ve) = (to_f64(&first.v0), to_f64(&last.v1));
    let scale = vs.max(ve).max(peak).max(1.0);
    // an ulp of absolute time is ε·t/T of a phase of length T, which a √-shaped end turns
    // into √(ε·t/T) of speed: short phases late in a move need more than V_TOL
    let shortest = r
        .phases
        .iter()
        .map(|ph| to_f64(&ph.dur))
        .filter(|&d| d > 0.0)
        .fold(f64::INFINITY, f64::min);
    let tol = V_TOL.max(2.0 * (f64::EPSILON * t_end / shortest).sqrt()) * scale;
    let mut times: Vec<f64> = (0..=128).map(|k| t_end * k as f64 / 128.0).collect();
    for ph in &r.phases {
        let t0 = to_f64(&ph.t0);
        times.extend([t0 * (1.0 - 1e-12), t0 * (1.0 + 1e-12) + 1e-300]);
    }
    let mut top = 0.0f64;
    for &t in &times {
        let t = t.clamp(0.0, t_end);
        let v = prof.velocity(t);
        top = top.max(v);
        let want = to_f64(&r.velocity(ctx, &bf(t)));
        if !((v - want).abs() <= tol) {
            return Err(format!("v({t}) = {v}, the move has {want}"));
        }
    }
    for (name, got, want) in [
        ("start", prof.velocity(0.0), vs),
        ("end", prof.velocity(t_end), ve),
        ("peak", top, peak),
    ] {
        if !((got - want).abs() <= V_TOL * scale) {
            return Err(format!("{name} speed {got}, the move has {want}"));
        }
    }
    Ok(())
}

/// Every check on one planned move: all edges, periods, speeds, duration and end.
fn check_all(
    ctx: &mut Ctx,
    prof: &Profile,
    r: &MoveRef,
    clock: f64,
    peak: f64,
) -> Result<(), TestCaseError> {
    let c = check_edges(ctx, prof, r, clock, 1, prof.steps()).map_err(TestCaseError::fail)?;
    prop_assert_eq!(c.edges, prof.steps());
    prop_assert!(
        c.near <= 2,
        "{} edges near a half tick went the other way",
        c.near
    );
    // fold and fill (constant-speed and ramp runs in local variables) give the edges
    // checked above one step at a time
    let mut g = EdgeGenerator::new(prof.clone(), clock).unwrap();
    let stepped: Vec<u64> = std::iter::from_fn(|| g.next()).collect();
    let folded = EdgeGenerator::new(prof.clone(), clock)
        .unwrap()
        .fold(Vec::new(), |mut v, e| {
            v.push(e);
            v
        });
    prop_assert_eq!(&folded, &stepped);
    let (mut g, mut buf, mut filled) = (
        EdgeGenerator::new(prof.clone(), clock).unwrap(),
        [0u64; 13],
        Vec::new(),
    );
    while let k @ 1.. = g.fill(&mut buf) {
        filled.extend_from_slice(&buf[..k]);
    }
    prop_assert_eq!(&filled, &stepped);
    // the summary's period range (constant-speed runs in O(1)) is the edges'
    let want = stepped.iter().scan(0, |last, &e| {
        let p = e - *last;
        *last = e;
        Some(p)
    });
    let want = want.fold(None, |m: Option<(u64, u64)>, p| {
        Some(m.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))))
    });
    let got = EdgeGenerator::new(prof.clone(), clock)
        .unwrap()
        .period_extremes(0);
    prop_assert_eq!(got, want.map(|(lo, hi)| (lo, hi, *stepped.last().unwrap())));
    let gen = EdgeGenerator::new(prof.clone(), clock).unwrap();
    let last = gen.last_edge_tick();
    prop_assert_eq!(gen.periods().sum::<u64>(), last);
    check_speeds(ctx, prof, r, peak).map_err(TestCaseError::fail)?;
    let t = to_f64(&r.duration);
    prop_assert!(
        (prof.duration() - t).abs() <= 1e-12 * t,
        "T {} vs {t}",
        prof.duration()
    );
    let end = sub(&r.end(ctx), &bf(r.steps as f64)).abs();
    prop_assert!(
        !lt(&bf(1e-9), &end),
        "the move itself ends {} off N",
        to_f64(&end)
    );
    Ok(())
}

/// The peak (phase mode: cruise) speed of a move from its reference.
fn phase_peak(r: &MoveRef) -> f64 {
    r.phases
        .iter()
        .map(|p| to_f64(&p.v0).max(to_f64(&p.v1)))
        .fold(0.0, f64::max)
}

fn phase_time() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), 1e-4f64..0.05]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, ..ProptestConfig::default() })]

    #[test]
    fn phase_mode_edges_are_exact(
        fam in family(), steps in 1u64..3000, ta in phase_time(), tb in phase_time(),
        tc in phase_time(), vs in prop_oneof![Just(0.0), 0.0f64..2e4],
        ve in prop_oneof![Just(0.0), 0.0f64..2e4], f in clock(),
    ) {
        let m = PhaseMove { steps, accel_time: ta, cruise_time: tb, decel_time: tc,
                            start_speed: vs, end_speed: ve, family: fam };
        match Profile::phase(&m) {
            Ok(p) => {
                let mut ctx = Ctx::new();
                let r = MoveRef::phase(&mut ctx, &m);
                check_all(&mut ctx, &p, &r, f, phase_peak(&r))?
            }
            Err(PlanError::ZeroDuration) => prop_assert!(ta + tb + tc == 0.0),
            Err(PlanError::CannotShed { cruise_speed, .. }) => prop_assert!(cruise_speed < 0.0),
            Err(e) => return Err(TestCaseError::fail(format!("unexpected {e}"))),
        }
    }

    #[test]
    fn segment_mode_edges_are_exact(
        segs in prop::collection::vec((0.0f64..5e4, 1e-4f64..0.05, 0u64..1500), 1..5), f in clock(),
    ) {
        // keep every end speed ≥ 0: n ≥ v0·T/2
        let segs: Vec<Segment> = segs.into_iter().map(|(v0, t, extra)| Segment {
            v0, duration: t, steps: (v0 * t / 2.0).ceil() as u64 + extra }).collect();
        match Profile::segments(&segs) {
            Ok(p) => {
                let mut ctx = Ctx::new();
                let r = MoveRef::segments(&mut ctx, &segs);
                check_all(&mut ctx, &p, &r, f, phase_peak(&r))?
            }
            Err(PlanError::NoSteps) => prop_assert!(segs.iter().all(|s| s.steps == 0)),
            Err(e) => return Err(TestCaseError::fail(format!("unexpected {e}"))),
        }
    }

    #[test]
    fn limits_mode_edges_are_exact_and_within_limits(
        order in prop_oneof![Just(Order::Trapezoid), Just(Order::SCurve), Just(Order::SCurve4)],
        steps in 1u64..4000, vmax in 100.0f64..1e5, amax in 1e3f64..1e7,
        jmax in 1e5f64..1e10, smax in 1e7f64..1e14, fs in 0.0f64..1.0, fe in 0.0f64..1.0,
        f in clock(),
    ) {
        let m = LimitsMove { steps, order, vmax, amax, jmax: Some(jmax), smax: Some(smax),
                             start_speed: fs * fs * vmax, end_speed: fe * fe * vmax };
        let p = match Profile::plan(&Move::Limits(m)) {
            Ok(p) => p,
            Err(PlanError::TooShortForLimits { needed, .. }) => {
                prop_assert!(needed > steps as f64);
                return Ok(());
            }
            Err(e) => return Err(TestCaseError::fail(format!("unexpected {e}"))),
        };
        let mut ctx = Ctx::new();
        let (r, vp) = MoveRef::limits(&mut ctx, &m).ok_or_else(|| TestCaseError::fail("the reference finds no move"))?;
        check_all(&mut ctx, &p, &r, f, vp.max(m.start_speed).max(m.end_speed))?;
        assert_feasible(&p, &m)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Limits-mode trapezoids and S-curves on a whole-Hz clock: the integer datapath's
    /// edges ([`IntRamp`], cubic pieces searched by the exactness test in integers) are the
    /// float generator's, which are checked against the move's own definition.
    #[test]
    fn limits_mode_integer_edges_equal_float_and_are_exact(
        scurve in any::<bool>(), steps in 1u64..3000, vmax in 100.0f64..1e5,
        amax in 1e3f64..1e7, jmax in 1e5f64..1e10, fs in 0.0f64..1.0, fe in 0.0f64..1.0,
        f in prop_oneof![Just(50_000_000u64), 100_000u64..1_000_000_000],
    ) {
        let order = if scurve { Order::SCurve } else { Order::Trapezoid };
        let m = LimitsMove { steps, order, vmax, amax, jmax: Some(jmax), smax: None,
                             start_speed: fs * fs * vmax, end_speed: fe * fe * vmax };
        let Ok(p) = Profile::plan(&Move::Limits(m)) else { return Ok(()) };
        let want = edges_at(&p, f as f64);
        let got: Vec<u64> = IntRamp::new(p.clone(), f).unwrap().collect();
        prop_assert_eq!(&got, &want);
        let mut ctx = Ctx::new();
        let (r, _) = MoveRef::limits(&mut ctx, &m)
            .ok_or_else(|| TestCaseError::fail("the reference finds no move"))?;
        let c = check_edges(&mut ctx, &p, &r, f as f64, 1, p.steps()).map_err(TestCaseError::fail)?;
        prop_assert_eq!(c.edges, p.steps());
        prop_assert!(c.near <= 2, "{} edges near a half tick went the other way", c.near);
    }
}

/// Time-optimal trapezoid: closed form for any vs, ve.
fn trapezoid_time(n: f64, vmax: f64, a: f64, vs: f64, ve: f64) -> f64 {
    let vp = (a * n + (vs * vs + ve * ve) / 2.0).sqrt();
    if vp <= vmax {
        (2.0 * vp - vs - ve) / a
    } else {
        let d = (2.0 * vmax * vmax - vs * vs - ve * ve) / (2.0 * a);
        (2.0 * vmax - vs - ve) / a + (n - d) / vmax
    }
}

/// Time-optimal rest-to-rest double-S (Biagiotti & Melchiorri 2008, eq. 3.25–3.26 with vs = ve = 0).
fn scurve_rest_time(n: f64, vmax: f64, amax: f64, jmax: f64) -> f64 {
    let (tj, ta) = if vmax * jmax >= amax * amax {
        (amax / jmax, amax / jmax + vmax / amax)
    } else {
        ((vmax / jmax).sqrt(), 2.0 * (vmax / jmax).sqrt())
    };
    let _ = tj;
    let tv = n / vmax - ta;
    if tv > 0.0 {
        return 2.0 * ta + tv;
    }
    let tj = amax / jmax;
    let mut ta = tj / 2.0 + ((tj / 2.0).powi(2) + n / amax).sqrt();
    if ta < 2.0 * tj {
        ta = 2.0 * (n / (2.0 * jmax)).cbrt();
    }
    2.0 * ta
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, ..ProptestConfig::default() })]

    #[test]
    fn trapezoid_limits_are_time_optimal(
        steps in 1u64..1_000_000, vmax in 10.0f64..1e6, amax in 10.0f64..1e8,
        fs in 0.0f64..1.0, fe in 0.0f64..1.0,
    ) {
        let (vs, ve) = (fs * vmax, fe * vmax);
        let m = LimitsMove { steps, order: Order::Trapezoid, vmax, amax, jmax: None, smax: None,
                             start_speed: vs, end_speed: ve };
        match Profile::plan(&Move::Limits(m)) {
            Ok(p) => {
                let want = trapezoid_time(steps as f64, vmax, amax, vs, ve);
                prop_assert!((p.duration() - want).abs() <= 1e-9 * want, "{} vs {}", p.duration(), want);
            }
            Err(PlanError::TooShortForLimits { .. }) => {
                prop_assert!((vs * vs - ve * ve).abs() / (2.0 * amax) > steps as f64 * (1.0 - 1e-12));
            }
            Err(e) => return Err(TestCaseError::fail(format!("unexpected {e}"))),
        }
    }

    #[test]
    fn scurve_rest_to_rest_is_time_optimal(
        steps in 1u64..1_000_000, vmax in 10.0f64..1e6, amax in 10.0f64..1e8, jmax in 10.0f64..1e11,
    ) {
        let m = LimitsMove { steps, order: Order::SCurve, vmax, amax, jmax: Some(jmax), smax: None,
                             start_speed: 0.0, end_speed: 0.0 };
        let p = Profile::plan(&Move::Limits(m)).unwrap();
        let want = scurve_rest_time(steps as f64, vmax, amax, jmax);
        prop_assert!((p.duration() - want).abs() <= 1e-8 * want, "{} vs {}", p.duration(), want);
    }

    /// The phase-mode cruise speed follows from N (DESIGN.md §2) and the profile ends on N.
    #[test]
    fn phase_mode_covers_n_steps(fam in family(), steps in 1u64..1u64 << 32,
        ta in 0.0f64..100.0, tb in 0.0f64..100.0, tc in 0.0f64..100.0) {
        prop_assume!(ta + tb + tc > 0.0);
        let m = PhaseMove { steps, accel_time: ta, cruise_time: tb, decel_time: tc,
                            start_speed: 0.0, end_speed: 0.0, family: fam };
        // planning refuses pieces that miss step N by more than a few ulps
        let p = Profile::phase(&m).unwrap();
        let end = p.position(p.duration() * (1.0 - 1e-15));
        prop_assert!((end - steps as f64).abs() <= 1e-6 * steps as f64);
        prop_assert!((p.duration() - (ta + tb + tc)).abs() <= 1e-12 * (ta + tb + tc));
    }
}

/// Windows of 2^32-step, 10^4-second moves: first steps, piece boundaries and the end.
#[test]
fn huge_moves_are_exact_in_every_window() {
    let mut ctx = Ctx::new();
    let steps = 1u64 << 32;
    for fam in [
        Family::Trapezoid,
        Family::Parabolic,
        Family::Exponential { rho: 0.25 },
        Family::Sine,
        Family::SCurve { phi: 0.3 },
        Family::SCurve4 {
            phi: 0.4,
            psi: 0.25,
        },
    ] {
        let m = PhaseMove {
            steps,
            accel_time: 2000.0,
            cruise_time: 6000.0,
            decel_time: 2000.0,
            start_speed: 0.0,
            end_speed: 0.0,
            family: fam,
        };
        let p = Profile::phase(&m).unwrap();
        let r = MoveRef::phase(&mut ctx, &m);
        let mut starts = vec![1u64, steps - 300];
        for ph in &r.phases {
            starts.push((to_f64(&ph.p0) as u64).saturating_sub(100).max(1));
        }
        starts.push(steps / 3);
        for s in starts {
            let c = check_edges(&mut ctx, &p, &r, 50e6, s, 200)
                .unwrap_or_else(|e| panic!("{fam:?}: {e}"));
            assert!(c.edges > 0);
        }
    }
}

/// The ambiguous edges are real: a move whose exact step time is near a half tick must be
/// settled in double-double, and still be right.
#[test]
fn half_tick_edges_are_settled() {
    // constant speed 1 step per 2.5 ticks: every other step lies exactly on a half tick
    // (exact ties are decided by rounding noise); nearby speeds put steps within 1e-12 ticks.
    let mut ctx = Ctx::new();
    for v in [20e6, 20e6 * (1.0 + 1e-13), 20e6 * (1.0 - 1e-13)] {
        let segs = [Segment {
            v0: v,
            duration: 1000.0 / v,
            steps: 1000,
        }];
        let p = Profile::segments(&segs).unwrap();
        let r = MoveRef::segments(&mut ctx, &segs);
        assert_eq!(
            check_edges(&mut ctx, &p, &r, 50e6, 1, 1000).unwrap().edges,
            1000
        );
        let mut g = EdgeGenerator::new(p, 50e6).unwrap();
        let e: Vec<u64> = (&mut g).collect();
        // 2.5 ticks per step: periods alternate between 2 and 3 ticks
        assert!(e.windows(2).all(|w| w[1] - w[0] == 2 || w[1] - w[0] == 3));
        assert_eq!(*e.last().unwrap(), 2500);
        assert!(g.settled_count() > 0);
    }
}

#[test]
fn errors_are_typed_and_never_panic() {
    let base = PhaseMove {
        steps: 100,
        accel_time: 0.1,
        cruise_time: 0.1,
        decel_time: 0.1,
        start_speed: 0.0,
        end_speed: 0.0,
        family: Family::Trapezoid,
    };
    let bad = |m: PhaseMove| Profile::phase(&m).unwrap_err();
    assert!(matches!(
        bad(PhaseMove {
            accel_time: f64::NAN,
            ..base
        }),
        PlanError::NotFinite { .. }
    ));
    assert!(matches!(
        bad(PhaseMove {
            accel_time: -1.0,
            ..base
        }),
        PlanError::Negative { .. }
    ));
    assert!(matches!(
        bad(PhaseMove {
            cruise_time: f64::INFINITY,
            ..base
        }),
        PlanError::NotFinite { .. }
    ));
    assert!(matches!(
        bad(PhaseMove {
            accel_time: 0.0,
            cruise_time: 0.0,
            decel_time: 0.0,
            ..base
        }),
        PlanError::ZeroDuration
    ));
    assert!(matches!(
        bad(PhaseMove { steps: 0, ..base }),
        PlanError::NoSteps
    ));
    assert!(matches!(
        bad(PhaseMove {
            start_speed: 1e6,
            ..base
        }),
        PlanError::CannotShed { .. }
    ));
    assert!(matches!(
        bad(PhaseMove {
            family: Family::SCurve { phi: 0.7 },
            ..base
        }),
        PlanError::FractionOutOfRange { name: "phi", .. }
    ));
    assert!(matches!(
        bad(PhaseMove {
            family: Family::SCurve4 { phi: 0.5, psi: 0.0 },
            ..base
        }),
        PlanError::FractionOutOfRange { name: "psi", .. }
    ));
    assert!(matches!(
        bad(PhaseMove {
            family: Family::Exponential { rho: -1.0 },
            ..base
        }),
        PlanError::NotPositive { .. }
    ));
    assert!(matches!(
        Family::parse("cubic", None, None, None),
        Err(PlanError::UnknownFamily(_))
    ));
    assert!(matches!(
        Profile::segments(&[Segment {
            v0: 1000.0,
            duration: 0.1,
            steps: 10
        }]),
        Err(PlanError::SegmentReverses { index: 0, .. })
    ));
    let p = Profile::phase(&base).unwrap();
    assert!(matches!(
        EdgeGenerator::new(p.clone(), 0.0),
        Err(PlanError::NotPositive { .. })
    ));
    assert!(matches!(
        EdgeGenerator::new(p.clone(), -5.0),
        Err(PlanError::NotPositive { .. })
    ));
    assert!(matches!(
        EdgeGenerator::new(p, 1e18),
        Err(PlanError::TooManyTicks { .. })
    ));
    let lim = LimitsMove {
        steps: 100,
        order: Order::SCurve,
        vmax: 1e3,
        amax: 1e4,
        jmax: None,
        smax: None,
        start_speed: 0.0,
        end_speed: 0.0,
    };
    assert!(matches!(
        Profile::plan(&Move::Limits(lim)),
        Err(PlanError::MissingLimit { .. })
    ));
    let lim4 = LimitsMove {
        order: Order::SCurve4,
        jmax: Some(1e5),
        ..lim
    };
    assert!(matches!(
        Profile::plan(&Move::Limits(lim4)),
        Err(PlanError::MissingLimit { .. })
    ));
    let shed = LimitsMove {
        order: Order::Trapezoid,
        start_speed: 1e3,
        steps: 2,
        ..lim
    };
    assert!(matches!(
        Profile::plan(&Move::Limits(shed)),
        Err(PlanError::TooShortForLimits { .. })
    ));
    let over = LimitsMove {
        order: Order::Trapezoid,
        start_speed: 2e3,
        ..lim
    };
    assert!(matches!(
        Profile::plan(&Move::Limits(over)),
        Err(PlanError::SpeedAboveLimit { .. })
    ));
}

/// Rational speeds put steps exactly on half ticks; on constant-speed pieces those ties are
/// decided exactly and go to the earlier tick (as the integer datapath does).
#[test]
fn exact_ties_at_constant_speed_go_to_the_earlier_tick() {
    // 32 000 steps/s at 50 MHz: step i at 1562.5·i ticks
    let p = Profile::segments(&[Segment {
        v0: 32_000.0,
        duration: 0.5,
        steps: 16_000,
    }])
    .unwrap();
    let mut g = EdgeGenerator::new(p, 50e6).unwrap();
    for (k, e) in (&mut g).enumerate() {
        let i = k as u64 + 1;
        // 1562.5·i rounded half down: (3125·i − 1) / 2 for odd i, exact for even i
        let want = if i % 2 == 1 {
            (3125 * i - 1) / 2
        } else {
            3125 * i / 2
        };
        assert_eq!(e, want, "step {i}");
    }
    // the exact constant-speed accumulator takes the ties at no extra cost: only the
    // first steps of the piece go through the general path
    assert!(g.settled_count() <= 2, "{}", g.settled_count());
}

/// The float and the integer generators' edges of a move, and a few of them as expected.
fn edges_at(p: &Profile, clock: f64) -> Vec<u64> {
    EdgeGenerator::new(p.clone(), clock).unwrap().collect()
}

/// Exact ties on an accelerating and a decelerating constant-acceleration piece (closed
/// form, then the double-double settle): all numbers are dyadic, so the planned profile is
/// the move exactly and step i lies exactly on a half tick. The earlier tick wins.
#[test]
fn exact_ties_on_accelerating_and_decelerating_pieces_go_to_the_earlier_tick() {
    // 1024 Hz; from rest, a = 2^23 steps/s² for 8 ticks: p(t) = 2^22·t², so step (2k+1)²
    // is at (k + ½) ticks
    let clock = 1024.0;
    let accel = [Segment {
        v0: 0.0,
        duration: 1.0 / 128.0,
        steps: 256,
    }];
    let e = edges_at(&Profile::segments(&accel).unwrap(), clock);
    for (i, want) in [(1, 0), (9, 1), (25, 2), (49, 3), (81, 4), (225, 7)] {
        assert_eq!(e[i - 1], want, "accelerating, step {i}");
    }
    // the time mirror: from 2^16 steps/s to rest, step 256 − (2k+1)² at 8 − (k + ½) ticks
    let decel = [Segment {
        v0: 65536.0,
        duration: 1.0 / 128.0,
        steps: 256,
    }];
    let e = edges_at(&Profile::segments(&decel).unwrap(), clock);
    for (i, want) in [(255, 7), (247, 6), (231, 5), (207, 4), (175, 3)] {
        assert_eq!(e[i - 1], want, "decelerating, step {i}");
    }
    // the integer datapath agrees on both
    for (v0, segs) in [(0, &accel), (65536, &decel)] {
        let int = IntProfile::segments(
            &[IntSegment {
                v0,
                ticks: 8,
                steps: 256,
            }],
            IntClock::hz(1024),
        )
        .unwrap();
        let ie: Vec<u64> = IntEdgeGenerator::new(int).collect();
        assert_eq!(ie, edges_at(&Profile::segments(segs).unwrap(), clock));
    }
}

/// Exact ties on cubic pieces (Newton, then the settle): a φ = ½ S-curve whose numbers are
/// all dyadic. 768 steps in 4 + 4 ticks at 1024 Hz: vm = 3·2^16 steps/s, jerk 3·2^34, so
/// p = 2^33·t³ on the first piece (step 27 at 1.5 ticks, step 1 at 0.5) and the mirror on
/// the last (step 741 at 6.5 ticks, step 767 at 7.5).
#[test]
fn exact_ties_on_newton_solved_pieces_go_to_the_earlier_tick() {
    let m = PhaseMove {
        steps: 768,
        accel_time: 1.0 / 256.0,
        cruise_time: 0.0,
        decel_time: 1.0 / 256.0,
        start_speed: 0.0,
        end_speed: 0.0,
        family: Family::SCurve { phi: 0.5 },
    };
    let p = Profile::phase(&m).unwrap();
    let mut g = EdgeGenerator::new(p.clone(), 1024.0).unwrap();
    let e: Vec<u64> = (&mut g).collect();
    for (i, want) in [(1, 0), (27, 1), (741, 6), (767, 7), (768, 8)] {
        assert_eq!(e[i - 1], want, "step {i}");
    }
    assert!(g.settled_count() >= 4);
    // and the reference built from the move agrees with every edge, strictly
    let mut ctx = Ctx::new();
    let r = MoveRef::phase(&mut ctx, &m);
    let c = check_edges(&mut ctx, &p, &r, 1024.0, 1, 768).unwrap();
    assert_eq!((c.edges, c.near), (768, 0));
}

/// The same ties on the integer datapath's cubic pieces ([`IntRamp`]: the exactness test
/// evaluated in integers): a limits-mode S-curve from rest whose numbers are all dyadic
/// (jmax 3·2^34, amax 3·2^25, vmax 3·2^16 at 1024 Hz: the φ = ½ move above), every edge
/// the float generator's, the ties included.
#[test]
fn exact_ties_on_integer_cubic_pieces_go_to_the_earlier_tick() {
    let m = LimitsMove {
        steps: 768,
        order: Order::SCurve,
        vmax: 3.0 * 65536.0,
        amax: 3.0 * (1u64 << 25) as f64,
        jmax: Some(3.0 * (1u64 << 34) as f64),
        smax: None,
        start_speed: 0.0,
        end_speed: 0.0,
    };
    let p = Profile::plan(&Move::Limits(m)).unwrap();
    let want = edges_at(&p, 1024.0);
    let got: Vec<u64> = IntRamp::new(p.clone(), 1024).unwrap().collect();
    assert_eq!(got, want);
    for (i, tick) in [(1, 0), (27, 1), (741, 6), (767, 7), (768, 8)] {
        assert_eq!(got[i - 1], tick, "step {i}");
    }
    let mut ctx = Ctx::new();
    let (r, _) = MoveRef::limits(&mut ctx, &m).unwrap();
    let c = check_edges(&mut ctx, &p, &r, 1024.0, 1, 768).unwrap();
    assert_eq!((c.edges, c.near), (768, 0));
}

/// A short √-shaped deceleration late in a move: its end speed is the move's exactly
/// (the last piece's end, not `t0 + dur` rounded apart from the duration), and its speeds
/// agree within what an ulp of absolute time allows.
#[test]
fn short_parabolic_deceleration_ends_at_the_end_speed() {
    let m = PhaseMove {
        steps: 1,
        accel_time: 0.0,
        cruise_time: 0.04593893745305046,
        decel_time: 0.0003419668556530847,
        start_speed: 0.0,
        end_speed: 0.0,
        family: Family::Parabolic,
    };
    let p = Profile::phase(&m).unwrap();
    assert_eq!(p.velocity(p.duration()), 0.0);
    let mut ctx = Ctx::new();
    let r = MoveRef::phase(&mut ctx, &m);
    check_all(&mut ctx, &p, &r, 50e6, phase_peak(&r)).unwrap();
}
