//! The integer datapath against the float generator and against the exact test of
//! DESIGN.md §1, on well over 10^6 random moves.

use super::*;
use crate::profile::{Family, LimitsMove, Order, PhaseMove, Profile, Segment};
use crate::{EdgeGenerator, PlanError};
use proptest::prelude::*;
use std::vec::Vec;

/// 2^24 Hz: every whole tick count is an exact f64 number of seconds.
const F2: u64 = 1 << 24;

/// SplitMix64: a seeded stream, so a failure names its move.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.below(hi - lo + 1)
    }
}

/// The edges by `fold` (ramp and cruise runs in local variables), which every test below
/// checks; `paths_agree` checks `next` and `fill` against it.
fn int_edges(p: IntProfile) -> Vec<u64> {
    let e = IntEdgeGenerator::new(p.clone()).fold(Vec::new(), |mut v, e| {
        v.push(e);
        v
    });
    assert_eq!(e.len() as u64, p.steps());
    e
}

fn float_edges(p: Profile, hz: u64) -> Vec<u64> {
    EdgeGenerator::new(p, hz as f64)
        .unwrap()
        .fold(Vec::new(), |mut v, e| {
            v.push(e);
            v
        })
}

/// Drains a generator through `fill` in chunks of `chunk`.
fn filled(mut fill: impl FnMut(&mut [u64]) -> usize, chunk: usize) -> Vec<u64> {
    let (mut buf, mut out) = (vec![0; chunk], Vec::new());
    loop {
        let k = fill(&mut buf);
        if k == 0 {
            return out;
        }
        out.extend_from_slice(&buf[..k]);
    }
}

/// `next` one edge at a time and `fill` in chunks of `chunk` give `fold`'s edges, on
/// both generators; the integer edges are the nearest ticks.
fn paths_agree(m: &IntPhaseMove, hz: u64, chunk: usize) -> Result<(), TestCaseError> {
    let Ok(p) = IntProfile::phase(m, IntClock::hz(hz)) else {
        return Ok(());
    };
    let folded = int_edges(p.clone());
    assert_exact(&p, &folded, &|| format!("{m:?} at {hz} Hz"));
    let mut g = IntEdgeGenerator::new(p.clone());
    let stepped: Vec<u64> = core::iter::from_fn(|| g.next()).collect();
    prop_assert_eq!(&stepped, &folded, "int next");
    let mut g = IntEdgeGenerator::new(p);
    prop_assert_eq!(&filled(|b| g.fill(b), chunk), &folded, "int fill");
    let Ok(fp) = try_float_phase(m, hz) else {
        return Ok(());
    };
    let folded = float_edges(fp.clone(), hz);
    let mut g = EdgeGenerator::new(fp.clone(), hz as f64).unwrap();
    let stepped: Vec<u64> = core::iter::from_fn(|| g.next()).collect();
    prop_assert_eq!(&stepped, &folded, "float next");
    let mut g = EdgeGenerator::new(fp, hz as f64).unwrap();
    prop_assert_eq!(&filled(|b| g.fill(b), chunk), &folded, "float fill");
    Ok(())
}

fn assert_exact(p: &IntProfile, edges: &[u64], what: &dyn Fn() -> String) {
    for (k, &e) in edges.iter().enumerate() {
        let i = k as u64 + 1;
        // the last step is pinned to the end of the move by contract
        if i < p.steps() {
            assert!(
                p.is_nearest_tick(i, e),
                "step {i} edge {e} not nearest: {}",
                what()
            );
        }
    }
}

fn float_phase(m: &IntPhaseMove, hz: u64) -> Profile {
    try_float_phase(m, hz).unwrap()
}

fn try_float_phase(m: &IntPhaseMove, hz: u64) -> Result<Profile, PlanError> {
    let s = hz as f64;
    Profile::phase(&PhaseMove {
        steps: m.steps,
        accel_time: m.accel_ticks as f64 / s,
        cruise_time: m.cruise_ticks as f64 / s,
        decel_time: m.decel_ticks as f64 / s,
        start_speed: m.start_speed as f64,
        end_speed: m.end_speed as f64,
        family: Family::Trapezoid,
    })
}

/// Phase moves whose f64 profile is exactly the rational one: power-of-two accel and
/// decel times and `Ta + 2Tb + Tc` a power of two, at 2^24 Hz.
fn exact_phase_move(r: &mut Rng) -> IntPhaseMove {
    loop {
        let ta = if r.below(6) == 0 {
            0
        } else {
            1 << r.range(1, 22)
        };
        let tc = if r.below(6) == 0 {
            0
        } else {
            1 << r.range(1, 22)
        };
        let lo = 64 - (ta + tc).max(2u64).leading_zeros() as u64;
        let w: u64 = 1 << r.range(lo.max(1), 24);
        if w < ta + tc || (w - ta - tc) % 2 != 0 {
            continue;
        }
        let m = IntPhaseMove {
            steps: r.range(1, 48),
            accel_ticks: ta,
            cruise_ticks: (w - ta - tc) / 2,
            decel_ticks: tc,
            start_speed: if r.below(2) == 0 { 0 } else { r.range(1, 200) },
            end_speed: if r.below(2) == 0 { 0 } else { r.range(1, 200) },
        };
        if IntProfile::phase(&m, IntClock::hz(F2)).is_ok() {
            return m;
        }
    }
}

#[test]
fn phase_mode_equals_float_on_exact_moves() {
    let mut r = Rng(1);
    for n in 0..400_000 {
        let m = exact_phase_move(&mut r);
        let ip = IntProfile::phase(&m, IntClock::hz(F2)).unwrap();
        let ie = int_edges(ip.clone());
        let fe = float_edges(float_phase(&m, F2), F2);
        assert_eq!(ie, fe, "move {n}: {m:?}");
        if n % 8 == 0 {
            assert_exact(&ip, &ie, &|| format!("{m:?}"));
        }
    }
}

#[test]
fn segment_mode_equals_float_on_exact_moves() {
    let mut r = Rng(2);
    let mut done = 0;
    while done < 400_000 {
        let k = r.range(1, 4) as usize;
        let segs: Vec<IntSegment> = (0..k)
            .map(|_| IntSegment {
                v0: if r.below(3) == 0 { 0 } else { r.range(1, 3000) },
                ticks: 1 << r.range(8, 22),
                steps: r.range(0, 16),
            })
            .collect();
        let fsegs: Vec<Segment> = segs
            .iter()
            .map(|s| Segment {
                v0: s.v0 as f64,
                duration: s.ticks as f64 / F2 as f64,
                steps: s.steps,
            })
            .collect();
        let ip = IntProfile::segments(&segs, IntClock::hz(F2));
        let fp = Profile::segments(&fsegs);
        // both accept and reject the same moves (reversing segments, no steps)
        assert_eq!(ip.is_ok(), fp.is_ok(), "{segs:?}: {ip:?} {fp:?}");
        let Ok(ip) = ip else { continue };
        let ie = int_edges(ip.clone());
        assert_eq!(ie, float_edges(fp.unwrap(), F2), "{segs:?}");
        assert_exact(&ip, &ie, &|| format!("{segs:?}"));
        done += 1;
    }
}

/// Limits moves that reach vmax with whole-tick, f64-exact phase times: vmax = 2^b,
/// amax = 2^e, vs and ve multiples of 2^c so the cruise time is whole ticks.
#[test]
fn limits_mode_equals_float_when_times_are_whole_ticks() {
    let mut r = Rng(3);
    for n in 0..250_000 {
        let b = r.range(6, 13);
        let e = r.range(b.max(10), 22);
        let c = (b + e).saturating_sub(23).div_ceil(2);
        let vmax = 1u64 << b;
        let pick = |r: &mut Rng| {
            if r.below(2) == 0 {
                0
            } else {
                (r.below(vmax >> c) << c).min(vmax)
            }
        };
        let (vs, ve) = (pick(&mut r), pick(&mut r));
        // need = (2vmax² − vs² − ve²)/(2amax) steps to reach vmax
        let need = (2 * vmax * vmax - vs * vs - ve * ve).div_ceil(2 << e);
        let m = IntLimitsMove {
            steps: need.max(1) + r.below(40),
            vmax,
            amax: 1 << e,
            start_speed: vs,
            end_speed: ve,
        };
        let ip = IntProfile::limits(&m, IntClock::hz(F2)).unwrap();
        let fp = Profile::plan(&crate::Move::Limits(LimitsMove {
            steps: m.steps,
            order: Order::Trapezoid,
            vmax: vmax as f64,
            amax: m.amax as f64,
            jmax: None,
            smax: None,
            start_speed: vs as f64,
            end_speed: ve as f64,
        }))
        .unwrap();
        assert_eq!(
            ip.end_tick() as f64,
            fp.duration() * F2 as f64,
            "move {n}: {m:?}"
        );
        let ie = int_edges(ip);
        assert_eq!(ie, float_edges(fp, F2), "move {n}: {m:?}");
    }
}

/// Any whole-tick phase move at 50 MHz: the f64 profile rounds vm, so the two may differ
/// where the exact time is within f64 noise of a half tick (a tie); nowhere else.
#[test]
fn phase_mode_matches_float_up_to_ties_at_50mhz() {
    let hz = 50_000_000;
    let mut r = Rng(4);
    let (mut moves, mut edges, mut ties, mut exact_ties) = (0u64, 0u64, 0u64, 0u64);
    while moves < 150_000 {
        let m = random_phase(
            &mut r,
            64,
            [(0, 3_000_000), (0, 2_000_000), (0, 3_000_000)],
            500,
            true,
        );
        let Ok(ip) = IntProfile::phase(&m, IntClock::hz(hz)) else {
            continue;
        };
        let ie = int_edges(ip.clone());
        let fe = float_edges(float_phase(&m, hz), hz);
        for (k, (&a, &b)) in ie.iter().zip(&fe).enumerate() {
            if a != b {
                // a tie: one tick apart and the exact step time a hair from the half tick
                assert_eq!(a.abs_diff(b), 1, "{m:?} step {}", k + 1);
                let mid = 2 * a.min(b) as u128 + 1;
                assert!(
                    near_half_tick(&ip, k as u64 + 1, mid),
                    "{m:?} step {}: {a} vs {b}",
                    k + 1
                );
                ties += 1;
                exact_ties += exact_half_tick(&ip, k as u64 + 1, mid) as u64;
            }
        }
        assert_exact(&ip, &ie, &|| format!("{m:?}"));
        moves += 1;
        edges += ie.len() as u64;
    }
    std::println!("{edges} edges, {ties} differ from the float: {exact_ties} exact half ticks");
    // rational phase times put many steps exactly on a half tick, where the rounded f64
    // profile falls either side: those are the only differences
    assert_eq!(ties, exact_ties, "{edges} edges");
}

/// Whether step i happens exactly at the half tick `mid/2`.
fn exact_half_tick(p: &IntProfile, i: u64, mid: u128) -> bool {
    let k = p.pieces().partition_point(|q| 2 * q.t0 as u128 <= mid) - 1;
    let q = &p.pieces()[k];
    q.target(i)
        .is_some_and(|m| q.cmp_at_half_ticks(mid - 2 * q.t0 as u128, m).is_eq())
}

/// A phase move with up to `steps` steps, phase ticks in the given ranges, and start and
/// end speeds up to `speed` (each 0 half the time if `rests`).
fn random_phase(
    r: &mut Rng,
    steps: u64,
    ticks: [(u64, u64); 3],
    speed: u64,
    rests: bool,
) -> IntPhaseMove {
    let [a, b, c] = ticks.map(|(lo, hi)| r.range(lo, hi));
    let v = |r: &mut Rng| {
        if rests && r.below(2) == 0 {
            0
        } else {
            r.range(1, speed)
        }
    };
    IntPhaseMove {
        steps: r.range(1, steps),
        accel_ticks: a,
        cruise_ticks: b,
        decel_ticks: c,
        start_speed: v(r),
        end_speed: v(r),
    }
}

/// Whether step i's exact time is within 1e-6 tick of the half tick `mid/2`: p at
/// `mid/2 ± 1e-6` brackets i (checked at a 2^-20-tick grid, exactly).
fn near_half_tick(p: &IntProfile, i: u64, mid: u128) -> bool {
    let k = p.pieces().partition_point(|q| 2 * q.t0 as u128 <= mid) - 1;
    let q = &p.pieces()[k];
    let Some(m) = q.target(i) else { return false };
    // Den·(p − p0) at τ = (mid − 2t0)/2 ± 2^-20, scaled by 4·2^40
    let at = |num: i128| {
        let tau = num; // τ·2^21
        let lhs = q.a as i128 * tau * (1 << 19) + q.b * tau * tau / 4;
        lhs.cmp(&((m as i128) << 40))
    };
    let c = (mid as i128 - 2 * q.t0 as i128) << 20;
    at(c - 2).is_lt() && at(c + 2).is_ge()
}

#[test]
fn seed000_run_and_long_moves_are_exact() {
    // 2400 microsteps in 20/10/20 ms at 50 MHz (seed 000's run): identical to the float
    let hz = 50_000_000;
    let m = IntPhaseMove {
        steps: 2400,
        accel_ticks: 1_000_000,
        cruise_ticks: 500_000,
        decel_ticks: 1_000_000,
        ..Default::default()
    };
    let ip = IntProfile::phase(&m, IntClock::hz(hz)).unwrap();
    let ie = int_edges(ip.clone());
    assert_eq!(ie, float_edges(float_phase(&m, hz), hz));
    assert_eq!(*ie.last().unwrap(), 2_500_000);
    assert_exact(&ip, &ie, &|| "seed000".into());
    // a long limits move with fractional speeds (Q = 1000): every edge exact
    let lm = IntLimitsMove {
        steps: 300_000,
        vmax: 123_456_789,
        amax: 987_654_321,
        start_speed: 1_500,
        end_speed: 2_500_000,
    };
    let clock = IntClock {
        clock_hz: hz,
        speed_scale: 1000,
    };
    let ip = IntProfile::limits(&lm, clock).unwrap();
    let ie = int_edges(ip.clone());
    assert_exact(&ip, &ie, &|| "long limits".into());
    assert!(ie.windows(2).all(|w| w[0] <= w[1]));
}

#[test]
fn quantized_limits_never_exceed_the_limits() {
    let mut r = Rng(5);
    let hz = 50_000_000u128;
    for _ in 0..20_000 {
        let vmax = r.range(100, 400_000);
        let m = IntLimitsMove {
            steps: r.range(1, 100_000),
            vmax,
            amax: r.range(1_000, 50_000_000),
            start_speed: r.below(vmax / 4),
            end_speed: r.below(vmax / 4),
        };
        let Ok(p) = limits_to_phase(&m, IntClock::hz(hz as u64)) else {
            continue;
        };
        let (ta, tb, tc) = (
            p.accel_ticks as u128,
            p.cruise_ticks as u128,
            p.decel_ticks as u128,
        );
        let w = ta + 2 * tb + tc;
        let (vs, ve) = (m.start_speed as u128, m.end_speed as u128);
        // vm·W = 2N·f − vs·Ta − ve·Tc (steps/s × ticks)
        let vmw = 2 * m.steps as u128 * hz - vs * ta - ve * tc;
        assert!(vmw <= m.vmax as u128 * w, "{m:?} {p:?}");
        // |vm − vs|·f ≤ amax·Ta, |vm − ve|·f ≤ amax·Tc (times W)
        for (v, t) in [(vs, ta), (ve, tc)] {
            if t > 0 {
                assert!(
                    vmw.abs_diff(v * w) * hz <= m.amax as u128 * t * w,
                    "{m:?} {p:?}"
                );
            }
        }
    }
}

#[test]
fn bad_moves_get_typed_errors() {
    let c = IntClock::hz(50_000_000);
    let ph = |steps, ta, tb, tc, vs| IntPhaseMove {
        steps,
        accel_ticks: ta,
        cruise_ticks: tb,
        decel_ticks: tc,
        start_speed: vs,
        end_speed: 0,
    };
    assert_eq!(
        IntProfile::phase(&ph(0, 1, 1, 1, 0), c),
        Err(IntError::NoSteps)
    );
    assert_eq!(
        IntProfile::phase(&ph(5, 0, 0, 0, 0), c),
        Err(IntError::ZeroDuration)
    );
    // 1 step cannot shed 1000 steps/s over a 1 s accel phase
    assert_eq!(
        IntProfile::phase(&ph(1, 50_000_000, 0, 1, 1000), c),
        Err(IntError::CannotShed)
    );
    assert_eq!(
        IntProfile::phase(&ph(5, 1, 1, 1, 0), IntClock::hz(0)),
        Err(IntError::ZeroClock)
    );
    // phases of 2^60 ticks need more than 128 bits
    assert_eq!(
        IntProfile::phase(&ph(1 << 40, 1 << 60, 0, 1 << 60, 3), c),
        Err(IntError::TooWide)
    );
    let seg = [IntSegment {
        v0: 1000,
        ticks: 50_000_000,
        steps: 100,
    }];
    assert_eq!(
        IntProfile::segments(&seg, c),
        Err(IntError::SegmentReverses { index: 0 })
    );
    let lm = IntLimitsMove {
        steps: 10,
        vmax: 100,
        amax: 1,
        start_speed: 200,
        end_speed: 0,
    };
    assert_eq!(IntProfile::limits(&lm, c), Err(IntError::SpeedAboveLimit));
    let lm = IntLimitsMove {
        steps: 1,
        vmax: 1000,
        amax: 1,
        start_speed: 900,
        end_speed: 0,
    };
    assert_eq!(IntProfile::limits(&lm, c), Err(IntError::TooShortForLimits));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    /// Wild integers never panic: planning returns a move or a typed error, and a planned
    /// move streams non-decreasing edges ending at its last tick.
    #[test]
    fn wild_inputs_never_panic(
        x in proptest::collection::vec(any::<u64>(), 6),
        shift in proptest::collection::vec(0u32..64, 6),
        hz in any::<u64>(),
        q in any::<u64>(),
    ) {
        let v: Vec<u64> = x.iter().zip(&shift).map(|(a, s)| a >> s).collect();
        let clock = IntClock { clock_hz: hz >> (hz % 64), speed_scale: q >> (q % 64) };
        let ph = IntPhaseMove {
            steps: v[0], accel_ticks: v[1], cruise_ticks: v[2], decel_ticks: v[3],
            start_speed: v[4], end_speed: v[5],
        };
        let lm = IntLimitsMove { steps: v[0], vmax: v[1], amax: v[2], start_speed: v[3], end_speed: v[4] };
        let sg = [IntSegment { v0: v[0], ticks: v[1], steps: v[2] }, IntSegment { v0: v[3], ticks: v[4], steps: v[5] }];
        for p in [IntProfile::phase(&ph, clock), IntProfile::limits(&lm, clock), IntProfile::segments(&sg, clock)]
            .into_iter()
            .flatten()
        {
            let e: Vec<u64> = IntEdgeGenerator::new(p.clone()).take(200).collect();
            prop_assert!(e.windows(2).all(|w| w[0] <= w[1]));
            prop_assert!(e.iter().all(|&t| t <= p.end_tick()));
        }
    }

    /// Ramp and cruise runs (`fold`, `fill`) give the per-step path's edges on random
    /// trapezoids with and without rests, at 50 MHz and odd clocks, whatever the chunk.
    #[test]
    fn fold_fill_and_next_agree(
        seed in any::<u64>(), odd in any::<bool>(), chunk in 1usize..40,
    ) {
        let mut r = Rng(seed);
        let hz = if odd { r.range(1_000, 100_000_000) | 1 } else { 50_000_000 };
        let t = hz / 100;
        let m = random_phase(&mut r, 3_000, [(0, t), (0, t), (1, t)], 20_000, true);
        paths_agree(&m, hz, chunk)?;
    }

    /// Any segment chain the planner accepts is exact on every edge (odd clocks too).
    #[test]
    fn segments_are_exact(
        hz in 1_000u64..100_000_000,
        segs in proptest::collection::vec((0u64..5000, 1u64..5_000_000, 0u64..300), 1..5),
    ) {
        let segs: Vec<IntSegment> =
            segs.into_iter().map(|(v0, ticks, steps)| IntSegment { v0, ticks, steps }).collect();
        if let Ok(p) = IntProfile::segments(&segs, IntClock::hz(hz)) {
            let e = int_edges(p.clone());
            assert_exact(&p, &e, &|| format!("{hz} {segs:?}"));
        }
    }
}

/// Moves whose radicand Y needs more than 128 bits (the 256-bit software path) are
/// exact on every edge too.
#[test]
fn wide_radicand_moves_are_exact() {
    let mut r = Rng(6);
    let clock = IntClock {
        clock_hz: 50_000_000,
        speed_scale: 1000,
    };
    let (mut wide, mut moves, mut too_wide) = (0u64, 0u64, 0u64);
    while moves < 3000 {
        let m = random_phase(
            &mut r,
            200,
            [(1, 20_000_000), (0, 5_000_000), (1, 20_000_000)],
            100_000_000,
            false,
        );
        let p = match IntProfile::phase(&m, clock) {
            Ok(p) => p,
            Err(e) => {
                too_wide += (e == IntError::TooWide) as u64;
                continue;
            }
        };
        moves += 1;
        wide += p.pieces().iter().any(|q| q.kernel().is_none()) as u64;
        let e = int_edges(p.clone());
        assert_exact(&p, &e, &|| format!("{m:?}"));
    }
    std::println!("{moves} moves, {wide} on the wide path, {too_wide} rejected as too wide");
    assert!(
        wide > 1000,
        "only {wide} of {moves} moves took the wide path"
    );
}

/// One truth for limits mode: the float planner on a clock and the integer datapath round
/// a trapezoid's phases to the same whole ticks, so they emit the same edges (up to f64
/// noise at exact half ticks, as in phase mode), for any start and end speeds, reaching
/// vmax or not, at 50 MHz and at odd clocks.
#[test]
fn limits_mode_on_a_clock_equals_the_integer_datapath() {
    let mut r = Rng(11);
    let (mut moves, mut ties) = (0u64, 0u64);
    while moves < 4_000 {
        let hz = if r.below(2) == 0 {
            50_000_000
        } else {
            r.range(10_000, 200_000_000)
        };
        let vmax = r.range(50, 200_000);
        let m = IntLimitsMove {
            steps: r.range(1, 20_000),
            vmax,
            amax: r.range(100, 20_000_000),
            start_speed: if r.below(3) == 0 {
                0
            } else {
                r.below(vmax + 1)
            },
            end_speed: if r.below(3) == 0 {
                0
            } else {
                r.below(vmax + 1)
            },
        };
        let fm = LimitsMove {
            steps: m.steps,
            order: Order::Trapezoid,
            vmax: m.vmax as f64,
            amax: m.amax as f64,
            jmax: None,
            smax: None,
            start_speed: m.start_speed as f64,
            end_speed: m.end_speed as f64,
        };
        let clock = IntClock::hz(hz);
        let (ip, fp) = match (
            limits_to_phase(&m, clock),
            crate::limits::whole_ticks(&fm, hz as f64),
        ) {
            (Ok(ip), Ok(ft)) => {
                let it = (ip.accel_ticks, ip.cruise_ticks, ip.decel_ticks);
                let ft = (ft.0 as u64, ft.1 as u64, ft.2 as u64);
                assert_eq!(it, ft, "{m:?} at {hz} Hz");
                (ip, Profile::limits_on_clock(&fm, hz as f64))
            }
            (Err(IntError::TooShortForLimits), Err(PlanError::TooShortForLimits { .. })) => {
                continue
            }
            (a, b) => panic!("{m:?} at {hz} Hz: int {a:?}, float {b:?}"),
        };
        let Ok(ipr) = IntProfile::phase(&ip, clock) else {
            // beyond 124-bit intermediates: the float plans it, the integer path refuses
            continue;
        };
        let ie = int_edges(ipr.clone());
        let fe = float_edges(fp.unwrap(), hz);
        for (k, (&a, &b)) in ie.iter().zip(&fe).enumerate() {
            if a != b {
                assert_eq!(a.abs_diff(b), 1, "{m:?} step {}", k + 1);
                let mid = 2 * a.min(b) as u128 + 1;
                assert!(
                    near_half_tick(&ipr, k as u64 + 1, mid),
                    "{m:?} step {}",
                    k + 1
                );
                ties += 1;
            }
        }
        assert_exact(&ipr, &ie, &|| format!("{m:?}"));
        moves += 1;
    }
    std::println!("{moves} limits moves; {ties} edges differ at f64-noise half ticks");
}

/// A small profile (`IntProfile::<N>`) and a borrowing generator give the default
/// profile's edges; a move with more pieces than the capacity is refused, not cut.
#[test]
fn small_and_borrowed_forms_give_the_same_edges() {
    let mut r = Rng(0x5a11);
    for _ in 0..200 {
        let m = IntLimitsMove {
            steps: r.range(1, 5000),
            vmax: r.range(100, 20_000),
            amax: r.range(1000, 1_000_000),
            start_speed: 0,
            end_speed: 0,
        };
        let clock = IntClock::hz(1_000_000);
        let (Ok(big), Ok(small)) = (
            IntProfile::limits(&m, clock),
            IntProfile::<3>::limits_in(&m, clock),
        ) else {
            panic!("{m:?} plans in both sizes or neither");
        };
        assert_eq!(big.pieces(), small.pieces());
        let want: Vec<u64> = IntEdgeGenerator::new(big.clone()).collect();
        assert_eq!(IntEdgeGenerator::new(&small).collect::<Vec<_>>(), want);
        assert_eq!(IntEdgeGenerator::new(&big).collect::<Vec<_>>(), want);
    }
    let seg = IntSegment {
        v0: 1000,
        ticks: 1000,
        steps: 1,
    };
    let clock = IntClock::hz(1_000_000);
    assert!(IntProfile::<2>::segments_in(&[seg; 2], clock).is_ok());
    assert_eq!(
        IntProfile::<2>::segments_in(&[seg; 3], clock),
        Err(IntError::TooManyPieces)
    );
}

/// Memory per axis, printed by `cargo test -p multistep-core sizes -- --nocapture`
/// (the figures in the crate README); the small forms must stay small.
#[test]
fn sizes() {
    use core::mem::size_of;
    let rows = [
        ("Profile", size_of::<Profile>()),
        (
            "EdgeGenerator (owns its Profile)",
            size_of::<EdgeGenerator>(),
        ),
        (
            "EdgeGenerator<&Profile>",
            size_of::<EdgeGenerator<&Profile>>(),
        ),
        ("IntProfile (64 pieces)", size_of::<IntProfile>()),
        ("IntProfile<3>", size_of::<IntProfile<3>>()),
        (
            "IntEdgeGenerator (owns its IntProfile)",
            size_of::<IntEdgeGenerator>(),
        ),
        (
            "IntEdgeGenerator<&IntProfile<3>, 3>",
            size_of::<IntEdgeGenerator<&IntProfile<3>, 3>>(),
        ),
        ("Tracker", size_of::<crate::Tracker>()),
        ("IntTracker", size_of::<super::IntTracker>()),
    ];
    for (name, bytes) in rows {
        std::println!("{name:40} {bytes:6} B");
    }
    assert!(size_of::<EdgeGenerator<&Profile>>() < 576);
    assert!(size_of::<IntEdgeGenerator<&IntProfile<3>, 3>>() < 256);
    assert!(size_of::<IntProfile<3>>() * 16 < size_of::<IntProfile>());
}

/// `limits_to_phase`'s defining inequalities, re-checked in 1024-bit arithmetic: the ramp
/// ticks are the least `t` with `2(t·amax + hz·v)² ≥ hz²·2vp²` and the cruise the least
/// `tb` with `(2tb + ta + tc)²·2vp² ≥ 2K²`.
fn limits_rounding_is_least(m: &IntLimitsMove, clock: IntClock) -> Result<(), TestCaseError> {
    use crypto_bigint::U1024;
    let Ok(ph) = limits_to_phase(m, clock) else {
        return Ok(());
    };
    let w = |x: u128| U1024::from_u128(x);
    let (q, hz, n) = (
        clock.speed_scale as u128,
        clock.clock_hz as u128,
        m.steps as u128,
    );
    let (amax, vmax) = (w(m.amax as u128), m.vmax as u128);
    let (vs, ve) = (m.start_speed as u128, m.end_speed as u128);
    let two_aqn = w(2 * m.amax as u128)
        .wrapping_mul(&w(q))
        .wrapping_mul(&w(n));
    let ends = w(vs * vs).wrapping_add(&w(ve * ve));
    let top = w(vmax * vmax).wrapping_mul(&w(2));
    let vp2x2 = if top.wrapping_sub(&ends) <= two_aqn {
        top
    } else {
        two_aqn.wrapping_add(&ends)
    };
    let target = w(hz * hz).wrapping_mul(&vp2x2);
    let reaches = |t: u128, v: u128| {
        let x = w(t)
            .wrapping_mul(&amax)
            .wrapping_add(&w(hz).wrapping_mul(&w(v)));
        x.wrapping_mul(&x).wrapping_mul(&w(2)) >= target
    };
    let (ta, tc) = (ph.accel_ticks as u128, ph.decel_ticks as u128);
    for (t, v) in [(ta, vs), (tc, ve)] {
        prop_assert!(reaches(t, v), "{m:?} {clock:?}: {t} ticks do not reach vp");
        prop_assert!(
            t == 0 || !reaches(t - 1, v),
            "{m:?} {clock:?}: {t} is not the least"
        );
    }
    let f = hz * q;
    let k = w(2 * n).wrapping_mul(&w(f));
    let shed = w(vs)
        .wrapping_mul(&w(ta))
        .wrapping_add(&w(ve).wrapping_mul(&w(tc)));
    if k > shed {
        let k = k.wrapping_sub(&shed);
        let k2x2 = k.wrapping_mul(&k).wrapping_mul(&w(2));
        let covers = |tb: u128| {
            let x = w(2 * tb + ta + tc);
            x.wrapping_mul(&x).wrapping_mul(&vp2x2) >= k2x2
        };
        let tb = ph.cruise_ticks as u128;
        prop_assert!(
            covers(tb) && (tb == 0 || !covers(tb - 1)),
            "{m:?} {clock:?}: cruise {tb}"
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Limits moves of any size (values up to 2^64, clocks up to 2^53) round to the least
    /// whole-tick phases, as a 1024-bit check of the same inequalities says.
    #[test]
    fn huge_limits_moves_round_to_the_least_ticks(
        x in proptest::collection::vec(any::<u64>(), 5),
        shift in proptest::collection::vec(0u32..64, 5),
        hz in 1u64..(1 << 53),
        q in 1u64..1_000_000,
    ) {
        let v: Vec<u64> = x.iter().zip(&shift).map(|(a, s)| a >> s).collect();
        let (vmax, vs, ve) = (v[1].max(1), v[3], v[4]);
        let m = IntLimitsMove {
            steps: v[0].max(1), vmax, amax: v[2].max(1),
            start_speed: vs.min(vmax), end_speed: ve.min(vmax),
        };
        limits_rounding_is_least(&m, IntClock { clock_hz: hz, speed_scale: q })?;
    }
}
