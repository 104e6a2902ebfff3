//! The integer tracker against the float tracker and against exact references: every
//! edge of both trackers is the same, ramp edges pass DESIGN.md §1's exactness test
//! `p((e − ½)/f) < i ≤ p((e + ½)/f)` evaluated on the ramp's f64 pieces as the binary
//! rationals they are (astro-float at a precision that rounds nothing), and cruise edges
//! equal `⌈X₀ + k·f·den/num − ½⌉` by one exact division.

extern crate std;

use super::IntTracker;
use crate::piece::Law;
use crate::profile::Profile;
use crate::track::{Rate, TrackLimits, TrackSegment, Tracker};
use astro_float::{BigFloat, RoundingMode};
use proptest::prelude::*;

const F: u64 = 50_000_000;
/// Enough bits that sums and products of f64s and tick counts round nothing.
const P: usize = 3072;
const RM: RoundingMode = RoundingMode::None;

fn bf(x: f64) -> BigFloat {
    BigFloat::from_f64(x, P)
}

fn bu(x: u128) -> BigFloat {
    BigFloat::from_u128(x, P)
}

/// Whether `p(x2/2 ticks) ≥ i` on `profile` (the piece holding that time, as DESIGN.md §1
/// evaluates p), exactly: `f³·p0 + f²·c1·u + f·c2·u² + c3·u³ ≥ f³·i` with u the local time
/// in ticks.
fn reached(profile: &Profile, x2: u128, i: u64) -> bool {
    let f = bu(F as u128);
    let x = bu(x2).div(&bu(2), P, RM);
    if x.cmp(&f.mul(&bf(profile.duration()), P, RM)).unwrap() >= 0 {
        return profile.steps() >= i;
    }
    if x2 == 0 {
        return i == 0;
    }
    // the last piece starting at or before x
    let k = profile
        .pieces()
        .iter()
        .rposition(|p| x.cmp(&f.mul(&bf(p.t0), P, RM)).unwrap() >= 0)
        .unwrap_or(0);
    let p = profile.piece(k);
    let Law::Poly { c1, c2, c3, c4 } = p.law else {
        panic!("a shaped piece")
    };
    assert_eq!(c4, 0.0);
    let mut u = x.sub(&f.mul(&bf(p.t0), P, RM), P, RM);
    let ud = f.mul(&bf(p.dur), P, RM);
    if u.cmp(&ud).unwrap() > 0 {
        u = ud;
    }
    // times f³: f³·p0 + f²·c1·u + f·c2·u² + c3·u³ ≥ f³·i
    let f2 = f.mul(&f, P, RM);
    let f3 = f2.mul(&f, P, RM);
    let lhs = f3
        .mul(&bf(p.p0), P, RM)
        .add(&f2.mul(&bf(c1), P, RM).mul(&u, P, RM), P, RM)
        .add(&f.mul(&bf(c2), P, RM).mul(&u, P, RM).mul(&u, P, RM), P, RM)
        .add(&bf(c3).mul(&u, P, RM).mul(&u, P, RM).mul(&u, P, RM), P, RM);
    lhs.cmp(&f3.mul(&bu(i as u128), P, RM)).unwrap() >= 0
}

/// DESIGN.md §1's test for ramp step `i` at local tick `e`; the last step is at
/// `round(f·T)` (a half tick up).
fn ramp_edge_exact(profile: &Profile, i: u64, e: u64) -> bool {
    if i == profile.steps() {
        let x = bu(F as u128)
            .mul(&bf(profile.duration()), P, RM)
            .add(&bf(0.5), P, RM);
        return x.cmp(&bu(e as u128)).unwrap() >= 0 && x.cmp(&bu(e as u128 + 1)).unwrap() < 0;
    }
    let below = e == 0 || !reached(profile, 2 * e as u128 - 1, i);
    below && reached(profile, 2 * e as u128 + 1, i)
}

/// `⌈X₀ + k·f·den/num − ½⌉` with X₀ = o + c/2^b: numerator and denominator times
/// 2^(b+1)·num, one 512-bit division (every value below 2^400).
fn cruise_edge(rate: Rate, o: u64, c: u128, b: u32, k: u64) -> u64 {
    use crypto_bigint::{NonZero, U512};
    let w = U512::from_u128;
    let (num, den) = (w(rate.num()), w(rate.den()));
    let s = U512::ONE.shl_vartime(b);
    let d = s.shl_vartime(1).wrapping_mul(&num);
    let x = d
        .wrapping_mul(&w(o as u128))
        .wrapping_add(&w(c).wrapping_mul(&num).shl_vartime(1))
        .wrapping_add(
            &w(k as u128 * F as u128)
                .wrapping_mul(&den)
                .wrapping_mul(&s)
                .shl_vartime(1),
        )
        .wrapping_sub(&s.wrapping_mul(&num));
    let (q, r) = x.div_rem_vartime(&NonZero::new(d).unwrap());
    let q = q.to_le_bytes();
    u64::from_le_bytes(q[..8].try_into().unwrap()) + (r != U512::ZERO) as u64
}

/// Two trackers in lock-step, every edge checked.
struct Pair {
    int: IntTracker,
    float: Tracker,
    steps: u64,
    ramp_edges: u64,
    cruise_edges: u64,
    exact_ramp_checks: u64,
    /// The ramp running: its start tick and step, and how many of its edges to check
    /// exactly (the first and last of each ramp and a stride between).
    ramp: Option<(u64, u64)>,
}

impl Pair {
    fn new(limits: TrackLimits, start: f64, rate: Rate) -> Pair {
        Pair {
            int: IntTracker::new(F as f64, limits, start, rate).unwrap(),
            float: Tracker::new(F as f64, limits, start, rate).unwrap(),
            steps: 0,
            ramp_edges: 0,
            cruise_edges: 0,
            exact_ramp_checks: 0,
            ramp: None,
        }
    }

    fn set_rate(&mut self, r: Rate) -> Result<(), TestCaseError> {
        let a = self.int.set_rate(r);
        let b = self.float.set_rate(r);
        prop_assert_eq!(&a, &b);
        prop_assert!(a.is_ok());
        Ok(())
    }

    /// `first` steps, then each (rate, steps) change in turn, a stop run to the stream's
    /// end, and a restart if given; some ramp edges must have been checked.
    fn script(
        &mut self,
        first: u64,
        changes: &[(Rate, u64)],
        restart: Option<(Rate, u64)>,
    ) -> Result<(), TestCaseError> {
        self.run(first)?;
        for &(r, n) in changes {
            self.set_rate(r)?;
            self.run(n)?;
        }
        self.set_rate(Rate::ZERO)?;
        prop_assert!(!self.run(u64::MAX)?, "a stop ends the stream");
        if let Some((r, n)) = restart {
            self.set_rate(r)?;
            self.run(n)?;
        }
        prop_assert!(self.ramp_edges > 0);
        Ok(())
    }

    /// Up to `n` steps; false when the stream ended.
    fn run(&mut self, n: u64) -> Result<bool, TestCaseError> {
        for _ in 0..n {
            let (a, b) = (self.int.next(), self.float.next());
            prop_assert_eq!(a, b, "step {}", self.steps + 1);
            let Some(e) = a else { return Ok(false) };
            self.steps += 1;
            prop_assert_eq!(self.int.segment(), self.float.segment());
            match self.int.segment() {
                TrackSegment::Ramp {
                    start_tick,
                    start_step,
                } => {
                    if self.ramp != Some((start_tick, start_step)) {
                        self.ramp = Some((start_tick, start_step));
                    }
                    let p = self.int.ramp_profile().unwrap();
                    let i = self.steps - start_step;
                    let n = p.steps();
                    if i <= 64 || i + 64 >= n || i % 97 == 0 {
                        prop_assert!(
                            ramp_edge_exact(p, i, e - start_tick),
                            "ramp step {} of {}: edge {}",
                            i,
                            n,
                            e - start_tick
                        );
                        self.exact_ramp_checks += 1;
                    }
                    self.ramp_edges += 1;
                }
                TrackSegment::Cruise {
                    rate,
                    start_step,
                    origin_tick,
                    frac_num,
                    frac_bits,
                } => {
                    let k = self.steps - start_step;
                    prop_assert_eq!(
                        e,
                        cruise_edge(rate, origin_tick, frac_num, frac_bits, k),
                        "cruise step {}",
                        k
                    );
                    self.cruise_edges += 1;
                }
                TrackSegment::Stopped => prop_assert!(false, "an edge while stopped"),
            }
        }
        Ok(true)
    }
}

/// 24 simulated hours at the sidereal rate, from rest: every edge of the integer tracker
/// equals the float tracker's and the exact cruise formula's.
#[test]
fn sidereal_24_hours_int_equals_float_and_exact() {
    let limits = TrackLimits {
        amax: 200.0,
        jmax: None,
    };
    let rate = Rate::new(15041, 324).unwrap();
    let mut pair = Pair::new(limits, 0.0, rate);
    // 24 h at 15041/324 steps/s: 4 010 933 steps (and the few of the ramp)
    let steps = 24 * 3600 * 15041 / 324;
    assert!(pair.run(steps).unwrap());
    let last = pair.int.last_edge();
    assert!(
        last > 24 * 3600 * F - F && last < 24 * 3600 * F + F,
        "{last}"
    );
    assert!(pair.ramp_edges > 0 && pair.cruise_edges > 4_000_000);
    assert!(pair.exact_ramp_checks == pair.ramp_edges);
}

/// The sidereal rate from rest with S-curve ramps (jmax): every ramp and cruise edge of the
/// integer tracker equals the float tracker's and the exact references; then a change to
/// twice the rate while cruising, one while that ramp runs (applied at its end), and a stop.
#[test]
fn scurve_sidereal_int_equals_float_and_exact() {
    let limits = TrackLimits {
        amax: 200.0,
        jmax: Some(1000.0),
    };
    let rate = Rate::new(15041, 324).unwrap();
    let mut pair = Pair::new(limits, 0.0, rate);
    assert!(pair.run(20_000).unwrap());
    pair.set_rate(Rate::new(30082, 324).unwrap()).unwrap();
    assert!(pair.run(3).unwrap());
    pair.set_rate(Rate::new(123_457, 1000).unwrap()).unwrap();
    assert!(pair.run(30_000).unwrap());
    pair.set_rate(Rate::ZERO).unwrap();
    assert!(!pair.run(u64::MAX).unwrap());
    assert!(pair.ramp_edges > 100 && pair.cruise_edges > 10_000);
    assert!(
        pair.exact_ramp_checks == pair.ramp_edges,
        "{}",
        pair.ramp_edges
    );
}

/// A random exact rate between 0.5 and 2·10⁵ steps/s with a denominator up to 2^24.
fn any_rate() -> impl Strategy<Value = Rate> {
    (0.5f64..2e5, 1u128..(1 << 24))
        .prop_map(|(r, den)| Rate::new(((r * den as f64) as u128).max(1), den).unwrap())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

    /// Random rates, start speeds and limits; a change after a random number of steps
    /// (often inside the first ramp) and a stop after another: every edge of the integer
    /// tracker equals the float tracker's and the exact references.
    #[test]
    fn int_tracker_equals_float_and_exact(
        r1 in any_rate(), r2 in any_rate(), start in 0.0f64..2.0, amax_exp in 0.7f64..4.0,
        n1 in 1u64..6000, n2 in 1u64..6000, restart in any::<bool>(),
    ) {
        // amax from 5 to 10⁴ times the fastest speed: a ramp of at most a tenth of its
        // rate in steps
        let amax = r1.to_f64().max(r2.to_f64()).max(start * r1.to_f64()) * 10f64.powf(amax_exp);
        let limits = TrackLimits { amax, jmax: None };
        let mut pair = Pair::new(limits, start * r1.to_f64(), r1);
        pair.script(n1, &[(r2, n2)], restart.then_some((r1, n1)))?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, ..ProptestConfig::default() })]

    /// S-curve ramps (jmax): random rates, start speeds, amax and jmax; a change after a
    /// random number of steps (often inside the first ramp, where it waits for the ramp's
    /// end), another one, a stop and a restart: every edge of the integer tracker equals
    /// the float tracker's and the exact references.
    #[test]
    fn scurve_int_tracker_equals_float_and_exact(
        r1 in any_rate(), r2 in any_rate(), r3 in any_rate(), start in 0.0f64..2.0,
        amax_exp in 0.7f64..4.0, jmax_exp in 0.3f64..3.0,
        n1 in 1u64..4000, n2 in 1u64..4000, n3 in 1u64..4000, restart in any::<bool>(),
    ) {
        // amax from 5 to 10⁴ times the fastest speed, jmax from 2 to 10³ times amax
        let top = r1.to_f64().max(r2.to_f64()).max(r3.to_f64()).max(start * r1.to_f64());
        let amax = top * 10f64.powf(amax_exp);
        let limits = TrackLimits { amax, jmax: Some(amax * 10f64.powf(jmax_exp)) };
        let mut pair = Pair::new(limits, start * r1.to_f64(), r1);
        pair.script(n1, &[(r2, n2), (r3, n3)], restart.then_some((r1, n1)))?;
    }
}

/// A ramp from 166 388 down to 1323 steps/s that dips to 131 steps/s and comes back (the
/// S-curve planner's shortest change): the cubic of the piece after the dip, extended
/// backwards, rises again before the piece starts, and the one before it turns back after
/// its end. The search stays inside each piece, so every edge is still the float
/// tracker's and exact.
#[test]
fn scurve_cubics_are_searched_inside_their_pieces() {
    let amax = 166_388.0 * 10f64.powf(3.5142302352473354);
    let limits = TrackLimits {
        amax,
        jmax: Some(amax * 10f64.powf(0.3)),
    };
    let mut pair = Pair::new(limits, 0.0, Rate::new(1, 1).unwrap());
    pair.script(
        1,
        &[
            (Rate::new(166_388, 1).unwrap(), 552),
            (Rate::new(1323, 1).unwrap(), 2100),
        ],
        None,
    )
    .unwrap();
    assert!(pair.ramp_edges > 4000, "{}", pair.ramp_edges);
}

/// Clocks from 1 MHz to 2^53 Hz with S-curve ramps: the integer tracker gives the float
/// tracker's edges, or refuses the ramp with a typed error when its values need more than
/// 512 bits (never a wrong edge, never a panic).
#[test]
fn scurve_clocks_up_to_2_pow_53_equal_or_refuse() {
    let limits = TrackLimits {
        amax: 3000.0,
        jmax: Some(40_000.0),
    };
    let (mut ran, mut refused) = (0, 0);
    for clock in [1e6, 5e7, 1e9, (1u64 << 40) as f64, (1u64 << 53) as f64] {
        for rate in [
            Rate::new(15041, 324).unwrap(),
            Rate::new(319_999, 10).unwrap(),
        ] {
            let Ok(float) = Tracker::new(clock, limits, 0.0, rate) else {
                // a ramp of more than 2^50 ticks: refused by both
                assert!(IntTracker::new(clock, limits, 0.0, rate).is_err());
                continue;
            };
            match IntTracker::new(clock, limits, 0.0, rate) {
                Ok(int) => {
                    let n = 3000;
                    let a: std::vec::Vec<u64> = int.take(n).collect();
                    let b: std::vec::Vec<u64> = float.take(n).collect();
                    assert_eq!(a, b, "clock {clock}, rate {rate:?}");
                    ran += 1;
                }
                Err(e) => {
                    assert_eq!(e, crate::track::TrackError::NotInteger);
                    refused += 1;
                }
            }
        }
    }
    std::println!("{ran} ran, {refused} refused");
    assert!(ran >= 6, "{ran} ran, {refused} refused");
}

/// A constant-jerk piece whose values need more than 512 bits (a coefficient of a
/// thousand binary places), or a piece of higher order, is a typed error when the ramp
/// starts, not a panic or a wrong edge.
#[test]
fn too_wide_or_quartic_pieces_are_refused() {
    use super::IntRamp;
    use crate::track::{RampEdges, TrackError};
    let limits = TrackLimits {
        amax: 200.0,
        jmax: Some(1000.0),
    };
    let t = Tracker::new(F as f64, limits, 0.0, Rate::new(100, 1).unwrap()).unwrap();
    let p = t.ramp_profile().unwrap().clone();
    assert!(IntRamp::start(p.clone(), F).is_ok());
    let k = (0..p.len())
        .find(|&k| matches!(p.piece(k).law, Law::Poly { c3, .. } if c3 != 0.0))
        .unwrap();
    for (c3, c4) in [(1e-300, 0.0), (0.5, 1.0)] {
        let mut q = p.clone();
        if let Law::Poly { c3: a, c4: b, .. } = &mut q.pieces[k].law {
            (*a, *b) = (c3, c4);
        }
        assert_eq!(IntRamp::start(q, F).err(), Some(TrackError::NotInteger));
    }
}

/// `plan --track`'s runs ([`TrackRun`](crate::TrackRun), what the command line and the
/// Python `track(..., integer=True)` play) with S-curve ramps: the integer tracker's edges
/// up to the duration are the float tracker's.
#[test]
fn track_runs_with_jmax_int_equals_float() {
    use super::IntRamp;
    use crate::edges::EdgeGenerator;
    use crate::TrackRun;
    let run = |rate: &str, duration, amax, jmax, start_speed| TrackRun {
        rate: Rate::parse(rate).unwrap(),
        duration,
        start_speed,
        amax: Some(amax),
        jmax: Some(jmax),
    };
    for r in [
        run("46.4228", 3.0, 500.0, 5000.0, 300.0),
        run("15041/324", 30.0, 200.0, 2000.0, 0.0),
        run("31999.9", 0.5, 64000.0, 1e6, 1000.0),
    ] {
        let (a, end) = r.start::<IntRamp>(F as f64).unwrap();
        let (b, _) = r.start::<EdgeGenerator>(F as f64).unwrap();
        let a: std::vec::Vec<u64> = a.take_while(|&e| e <= end).collect();
        let b: std::vec::Vec<u64> = b.take_while(|&e| e <= end).collect();
        assert!(a.len() > 100);
        assert_eq!(a, b, "{r:?}");
    }
}
