//! Open-ended motion against exact references written here in integers: every cruise edge
//! is recomputed as `⌈X₀ + k·f·den/num − ½⌉` by one u128 division (no accumulator), the
//! cruise origin X₀ is recomputed from the ramp's f64 duration, every ramp edge is checked
//! against the ramp profile shifted to its start, and positions at sampled ticks are
//! closed forms (cruise) or ⌊p(t + ½ tick)⌋ (ramp).

use multistep_core::int::IntTracker;
use multistep_core::track::RampEdges;
use multistep_core::track::TrackSegment;
use multistep_core::{EdgeGenerator, Profile, Rate, TrackError, TrackLimits, Tracker, TrackerOf};
use proptest::prelude::*;

const F: u64 = 50_000_000;

/// `x = m · 2^e`, m an integer (x > 0, normal).
fn decompose(x: f64) -> (u128, i32) {
    let bits = x.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32;
    assert!(e > 0, "subnormal");
    (((bits & ((1 << 52) - 1)) | (1 << 52)) as u128, e - 1075)
}

/// The exact cruise reference: origin X₀ = o + c/2^b ticks, step k ≥ 1 at X₀ + k·f·den/num.
#[derive(Clone, Copy, Debug)]
struct CruiseRef {
    num: u128,
    den: u128,
    start_step: u64,
    o: u128,
    c: u128,
    b: u32,
}

impl CruiseRef {
    /// `⌈X₀ + k·f·den/num − ½⌉` in one division: numerator and denominator times 2^(b+1)·num
    /// (when that fits in u128, else [`CruiseRef::edge_wide`]).
    fn edge(&self, k: u64) -> u64 {
        let direct = || {
            let s = 1u128.checked_shl(self.b)?;
            let d = (2 * s).checked_mul(self.num)?;
            let x = d
                .checked_mul(self.o)?
                .checked_add(2 * self.num * self.c)?
                .checked_add(
                    (k as u128)
                        .checked_mul(F as u128 * self.den)?
                        .checked_mul(2 * s)?,
                )?
                - s * self.num;
            Some(x.div_ceil(d) as u64)
        };
        direct().unwrap_or_else(|| self.edge_wide(k))
    }

    /// The same in 256-bit compares: k·f·den = n·num + ρ, then `⌈c/2^b + ρ/num − ½⌉` is 0, 1
    /// or 2 by comparing `2c·num + 2ρ·2^b` with `num·2^b` and `3·num·2^b`.
    fn edge_wide(&self, k: u64) -> u64 {
        let kp = k as u128 * (F as u128 * self.den);
        let (n, rho) = (kp / self.num, kp % self.num);
        let lhs = Wide::mul(2 * self.c, self.num).add(Wide::mul(2 * rho, 1).shl(self.b));
        let half = Wide::mul(self.num, 1).shl(self.b);
        let three_halves = Wide::mul(3 * self.num, 1).shl(self.b);
        let extra = if lhs <= half {
            0
        } else if lhs <= three_halves {
            1
        } else {
            2
        };
        (self.o + n + extra) as u64
    }

    /// Steps of this cruise with edge ≤ t (edges are non-decreasing: a binary search).
    fn count_to(&self, t: u64) -> u64 {
        let (mut lo, mut hi) = (0u64, 1u64 << 40);
        while lo < hi {
            let mid = lo + (hi - lo).div_ceil(2);
            if self.edge(mid) <= t {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
        lo
    }
}

/// A 256-bit unsigned integer as (high, low) halves: just what the reference needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Wide(u128, u128);

impl Wide {
    fn mul(a: u128, b: u128) -> Wide {
        let m = u64::MAX as u128;
        let (a1, a0, b1, b0) = (a >> 64, a & m, b >> 64, b & m);
        let (p00, p01, p10, p11) = (a0 * b0, a0 * b1, a1 * b0, a1 * b1);
        let (mid, carry_mid) = p01.overflowing_add(p10);
        let (lo, carry_lo) = p00.overflowing_add(mid << 64);
        Wide(
            p11 + (mid >> 64) + ((carry_mid as u128) << 64) + carry_lo as u128,
            lo,
        )
    }
    fn add(self, o: Wide) -> Wide {
        let (lo, c) = self.1.overflowing_add(o.1);
        Wide(self.0 + o.0 + c as u128, lo)
    }
    fn shl(self, b: u32) -> Wide {
        match b {
            0 => self,
            1..=127 => Wide((self.0 << b) | (self.1 >> (128 - b)), self.1 << b),
            _ => Wide(self.1 << (b - 128), 0),
        }
    }
}

/// Streams a tracker, checking every edge, and the position at every sample tick.
struct Checker {
    ramp: Option<(EdgeGenerator, Profile, u64, u64)>,
    cruise: Option<CruiseRef>,
    last: u64,
    steps: u64,
    edges: u64,
    amax: f64,
    ramp_edges: u64,
    cruise_edges: u64,
    samples: u64,
}

impl Checker {
    fn new(amax: f64) -> Self {
        Checker {
            ramp: None,
            cruise: None,
            last: 0,
            steps: 0,
            edges: 0,
            amax,
            ramp_edges: 0,
            cruise_edges: 0,
            samples: 0,
        }
    }

    /// Position at tick `t` by the references of the segment now running (t between the
    /// last edge and the next).
    /// The position at tick `t` by the closed form: exact on a cruise; on a ramp
    /// `floor(p(t + ½))` in f64, so a sample within f64's few ulps of a step's exact time may
    /// read either count.
    fn reference_position(&self, t: u64) -> core::ops::RangeInclusive<u64> {
        if let Some(c) = &self.cruise {
            let n = c.start_step + c.count_to(t);
            return n..=n;
        }
        let (_, p, start, base) = self.ramp.as_ref().unwrap();
        let tau = ((t - start) as f64 + 0.5) / F as f64;
        let x = p.position(tau);
        let tol = 1e-9 + 8.0 * f64::EPSILON * x.abs();
        base + (x - tol).floor() as u64..=base + (x + tol).floor() as u64
    }

    /// Which segment the references describe: (ramp?, its first step).
    fn segment_id(&self) -> (bool, u64) {
        match (&self.ramp, &self.cruise) {
            (_, Some(c)) => (false, c.start_step),
            (Some((_, _, _, b)), None) => (true, *b),
            (None, None) => (false, u64::MAX),
        }
    }

    /// Runs until the edge after `until` (or the stream's end), checking samples on the way:
    /// a sample between two edges of one segment must equal that segment's closed form.
    fn run<R: RampEdges>(
        &mut self,
        tr: &mut TrackerOf<R>,
        until: u64,
        samples: &mut impl Iterator<Item = u64>,
    ) {
        let mut next_sample = samples.next();
        let mut between = Vec::new();
        while let Some(e) = tr.next() {
            between.clear();
            while let Some(s) = next_sample.filter(|&s| s < e) {
                if s >= self.last {
                    between.push(s);
                }
                next_sample = samples.next();
            }
            let (before, steps_before) = (self.segment_id(), self.steps);
            self.check(tr, e);
            if self.segment_id() == before {
                for &s in &between {
                    let want = self.reference_position(s);
                    assert!(
                        want.contains(&steps_before),
                        "position at tick {s}: {steps_before}, closed form {want:?}"
                    );
                    self.samples += 1;
                }
            }
            if e > until {
                break;
            }
        }
    }

    fn check<R: RampEdges>(&mut self, tr: &TrackerOf<R>, e: u64) {
        self.steps += 1;
        self.edges += 1;
        assert_eq!(tr.steps(), self.steps);
        assert!(e > self.last || self.steps == 1, "edges go forward");
        match tr.segment() {
            TrackSegment::Ramp {
                start_tick,
                start_step,
            } => {
                self.cruise = None;
                let fresh = !matches!(&self.ramp, Some((_, _, s, b)) if *s == start_tick && *b == start_step);
                if fresh {
                    let p = tr.ramp_profile().unwrap().clone();
                    let (_, a) = p.peaks();
                    assert!(a <= self.amax * (1.0 + 1e-12), "ramp accel {a} > amax");
                    let g = EdgeGenerator::new(p.clone(), F as f64).unwrap();
                    self.ramp = Some((g, p, start_tick, start_step));
                }
                let (g, p, start, base) = self.ramp.as_mut().unwrap();
                // the ramp is its profile shifted to its start tick and step
                assert_eq!(
                    Some(e - *start),
                    g.next(),
                    "ramp edge of step {}",
                    self.steps
                );
                let i = (self.steps - *base) as f64;
                let t = |x: f64| x / F as f64;
                let lo = p.position(t((e - *start) as f64 - 0.5));
                let hi = p.position(t((e - *start) as f64 + 0.5));
                // f64 evaluates the position to a few ulps of it (the edges themselves are
                // checked above against the generator, whose exactness has its own tests)
                let tol = 1e-9 + 8.0 * f64::EPSILON * i;
                assert!(
                    lo < i + tol && i <= hi + tol,
                    "nearest tick of ramp step {i}: p(e - ½) = {lo}, p(e + ½) = {hi}"
                );
                self.ramp_edges += 1;
            }
            TrackSegment::Cruise {
                rate,
                start_step,
                origin_tick,
                frac_num,
                frac_bits,
            } => {
                if self.cruise.map_or(true, |c| c.start_step != start_step) {
                    // the origin is the ramp's start + f·T exactly (or the start itself)
                    if let Some((_, p, start, base)) = self.ramp.take() {
                        assert_eq!(start_step, base + p.steps());
                        let (m, ex) = decompose(p.duration());
                        let s = (-ex) as u32;
                        assert!(frac_bits <= s);
                        let lhs = ((origin_tick - start) as u128 * (1u128 << s))
                            + (frac_num << (s - frac_bits));
                        assert_eq!(lhs, F as u128 * m, "cruise origin = ramp start + f·T");
                        let last_ramp = start as f64 + (F as f64 * p.duration()).round();
                        assert!(
                            self.last as f64 == last_ramp,
                            "last ramp edge is round(f·T)"
                        );
                    } else {
                        assert_eq!((frac_num, frac_bits), (0, 0));
                        assert_eq!(origin_tick, self.last);
                    }
                    self.cruise = Some(CruiseRef {
                        num: rate.num(),
                        den: rate.den(),
                        start_step,
                        o: origin_tick as u128,
                        c: frac_num,
                        b: frac_bits,
                    });
                }
                let c = self.cruise.unwrap();
                assert_eq!(
                    e,
                    c.edge(self.steps - c.start_step),
                    "cruise step {}",
                    self.steps
                );
                self.cruise_edges += 1;
            }
            TrackSegment::Stopped => panic!("an edge while stopped"),
        }
        self.last = e;
    }
}

fn hours(h: u64) -> u64 {
    h * 3600 * F
}

/// 15.041″/s on 4,000,000 microsteps per revolution (1,296,000″): 4e6·15.041/1.296e6.
fn sidereal() -> Rate {
    Rate::new(4_000_000 * 15_041, 1_296_000 * 1000).unwrap()
}

#[test]
fn sidereal_rate_is_exact() {
    let r = sidereal();
    assert_eq!((r.num(), r.den()), (15041, 324));
    assert!((r.to_f64() - 46.422_839_506_172_84).abs() < 1e-12);
    assert_eq!(Rate::parse("15041/324").unwrap(), r);
    assert_eq!(
        Rate::parse(" 31999.9 ").unwrap(),
        Rate::new(319_999, 10).unwrap()
    );
    assert_eq!(Rate::parse("3.2e4").unwrap(), Rate::new(32_000, 1).unwrap());
    assert_eq!(Rate::parse("46.5/1.5").unwrap(), Rate::new(31, 1).unwrap());
    assert_eq!(Rate::from_f64(0.1).unwrap().to_f64(), 0.1);
    assert_eq!(Rate::from_f64(0.1).unwrap().den(), 1 << 55);
    for bad in ["", "abc", "1..2", "-3", "1/0", "1/", "nan", "1e99999"] {
        assert!(Rate::parse(bad).is_err(), "{bad:?}");
    }
    assert!(matches!(Rate::parse("x1"), Err(TrackError::BadRate(_))));
}

#[test]
fn sidereal_24_hours_exact_from_rest() {
    let limits = TrackLimits {
        amax: 200.0,
        jmax: None,
    };
    let mut tr = Tracker::new(F as f64, limits, 0.0, sidereal()).unwrap();
    let mut ck = Checker::new(limits.amax);
    // sample every 7 minutes and a few odd ticks
    let mut samples = (0..)
        .map(|k: u64| k * 420 * F + k * 12_345 % F)
        .take_while(|&t| t < hours(24));
    ck.run(&mut tr, hours(24), &mut samples);
    assert!(ck.ramp_edges > 0 && ck.cruise_edges > 4_000_000);
    assert!(ck.samples > 200, "{} samples", ck.samples);
    // 0 ticks of accumulated error: the last edge is the nearest tick to the exact time
    let c = ck.cruise.unwrap();
    let k = ck.steps - c.start_step;
    let exact2 = |e: u64| {
        // 2^(b+1)·num·(e − X₀ − k·f·den/num) as a signed integer
        let s = 1i128 << c.b;
        (2 * s * c.num as i128) * (e as i128 - c.o as i128)
            - 2 * c.num as i128 * c.c as i128
            - 2 * s * (k as i128) * (F as i128) * c.den as i128
    };
    let err = exact2(ck.last);
    let half = (1i128 << c.b) * c.num as i128;
    assert!(-half <= err && err < half, "last edge within half a tick");
}

#[test]
fn fast_rate_one_hour_exact() {
    let limits = TrackLimits {
        amax: 64_000.0,
        jmax: None,
    };
    let rate = Rate::parse("31999.9").unwrap();
    let mut tr = Tracker::new(F as f64, limits, 1000.0, rate).unwrap();
    let mut ck = Checker::new(limits.amax);
    let mut samples = (0..)
        .map(|k: u64| k * 9 * F + 7 * k)
        .take_while(|&t| t < hours(1));
    ck.run(&mut tr, hours(1), &mut samples);
    assert!(ck.cruise_edges > 115_000_000);
    assert!(ck.samples > 300, "{} samples", ck.samples);
}

#[test]
fn rate_changes_while_tracking_stay_exact() {
    let limits = TrackLimits {
        amax: 5_000.0,
        jmax: None,
    };
    let mut tr = Tracker::new(F as f64, limits, 0.0, sidereal()).unwrap();
    let mut ck = Checker::new(limits.amax);
    let mut none = core::iter::empty();
    let mut samples = (1..).map(|k: u64| k * 3_333_331);
    ck.run(&mut tr, F * 60, &mut samples);
    // faster, a change during the ramp (waits for its end), slower, stop, restart
    let plan: [(&str, u64); 6] = [
        ("319999/10", 5),
        ("1234.5678", 0),
        ("1000/3", 20),
        ("0", 10),
        ("7", 30),
        ("15041/324", 60),
    ];
    for (rate, secs) in plan {
        tr.set_rate(Rate::parse(rate).unwrap()).unwrap();
        if secs == 0 {
            continue;
        }
        let until = ck.last + secs * F;
        ck.run(&mut tr, until, &mut samples);
        assert_eq!(tr.rate(), Rate::parse(rate).unwrap());
        if rate == "0" {
            assert!(tr.next().is_none(), "stopped");
            assert!(matches!(tr.segment(), TrackSegment::Stopped));
        }
    }
    ck.run(&mut tr, ck.last + 30 * F, &mut none);
    assert!(
        ck.ramp_edges > 1000 && ck.cruise_edges > 5_000 && ck.samples > 100,
        "{} {} {}",
        ck.ramp_edges,
        ck.cruise_edges,
        ck.samples
    );
}

#[test]
fn scurve_ramps_and_no_ramp_start() {
    let limits = TrackLimits {
        amax: 2_000.0,
        jmax: Some(20_000.0),
    };
    // already at the rate: a cruise from tick 0
    let r = Rate::parse("100").unwrap();
    let mut tr = Tracker::new(F as f64, limits, 100.0, r).unwrap();
    let edges: Vec<u64> = (&mut tr).take(3).collect();
    assert_eq!(edges, [500_000, 1_000_000, 1_500_000]);
    let mut ck = Checker::new(limits.amax);
    ck.last = 1_500_000;
    ck.steps = 3;
    ck.cruise = Some(CruiseRef {
        num: 100,
        den: 1,
        start_step: 0,
        o: 0,
        c: 0,
        b: 0,
    });
    tr.set_rate(Rate::parse("2500.25").unwrap()).unwrap();
    ck.cruise = None;
    ck.run(&mut tr, ck.last + 5 * F, &mut core::iter::empty());
    tr.stop().unwrap();
    ck.run(&mut tr, u64::MAX, &mut core::iter::empty());
    assert!(tr.next().is_none());
}

#[test]
fn bad_input_is_one_typed_error() {
    let l = TrackLimits {
        amax: 100.0,
        jmax: None,
    };
    let r = Rate::parse("10").unwrap();
    assert!(matches!(
        Tracker::new(1.5, l, 0.0, r),
        Err(TrackError::BadClock(_))
    ));
    let bad_a = TrackLimits { amax: 0.0, ..l };
    assert!(matches!(
        Tracker::new(1e6, bad_a, 0.0, r),
        Err(TrackError::BadAmax(_))
    ));
    assert!(matches!(
        Tracker::new(1e6, l, -1.0, r),
        Err(TrackError::BadStartSpeed(_))
    ));
    // a period under two ticks
    let fast = Rate::parse("600000").unwrap();
    assert_eq!(
        Tracker::new(1e6, l, 0.0, fast).err(),
        Some(TrackError::TooFast)
    );
    let mut tr = Tracker::new(1e6, l, 0.0, r).unwrap();
    assert_eq!(tr.set_rate(fast), Err(TrackError::TooFast));
    assert_eq!(tr.rate(), r, "a refused change leaves the rate");
}

/// A random exact rate between 0.5 and 2·10⁵ steps/s with a denominator up to 2^24.
fn any_rate() -> impl Strategy<Value = Rate> {
    (0.5f64..2e5, 1u128..(1 << 24))
        .prop_map(|(r, den)| Rate::new(((r * den as f64) as u128).max(1), den).unwrap())
}

/// One random tracking case: a ramp to `r1`, a cruise, a change to `r2` and a stop, every
/// edge checked; by the float or the integer tracker.
fn tracking_case(
    int: bool,
    r1: Rate,
    r2: Rate,
    start: f64,
    amax_x: f64,
    scurve: bool,
    samples_step: u64,
) -> Result<(), TestCaseError> {
    let (v1, v2) = (r1.to_f64(), r2.to_f64());
    // relative to the faster rate, so every ramp takes at most about 2 s
    let amax = v1.max(v2) * amax_x;
    let limits = TrackLimits {
        amax,
        jmax: scurve.then_some(amax * 20.0),
    };
    if int {
        let tr = IntTracker::new(F as f64, limits, start * v1, r1).unwrap();
        tracking_case_on(tr, r1, r2, start, amax, samples_step)
    } else {
        let tr = Tracker::new(F as f64, limits, start * v1, r1).unwrap();
        tracking_case_on(tr, r1, r2, start, amax, samples_step)
    }
}

fn tracking_case_on<R: RampEdges>(
    mut tr: TrackerOf<R>,
    r1: Rate,
    r2: Rate,
    start: f64,
    amax: f64,
    samples_step: u64,
) -> Result<(), TestCaseError> {
    let (v1, v2) = (r1.to_f64(), r2.to_f64());
    let mut ck = Checker::new(amax);
    let mut samples = (1..).map(|k| k * samples_step);
    // the longest ramp, then n steps at the slower rate but at most 3 s, so a tiny rate
    // beside a fast one does not make a case of billions of edges
    let ramp = (start * v1).max(v1).max(v2) / amax + 1.0 / 10.0;
    let until = |ck: &Checker, n: u64| {
        ck.last + ((ramp + (n as f64 / v1.min(v2)).min(3.0)) * F as f64) as u64
    };
    let end = until(&ck, 3000);
    ck.run(&mut tr, end, &mut samples);
    tr.set_rate(r2).unwrap();
    let end = until(&ck, 3000).max(ck.last + F / 10);
    ck.run(&mut tr, end, &mut samples);
    tr.stop().unwrap();
    ck.run(&mut tr, u64::MAX, &mut samples);
    prop_assert!(tr.next().is_none());
    prop_assert!(ck.cruise_edges > 0);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Random rates, start speeds and limits (short ramps give origins with many fraction
    /// bits): every edge exact through a ramp, a cruise, a rate change and a stop.
    #[test]
    fn random_tracking_is_exact(r1 in any_rate(), r2 in any_rate(), start in 0.0f64..3.0,
                                amax_exp in -0.3f64..4.0, scurve in any::<bool>(),
                                int in any::<bool>(), samples_step in 10_000u64..10_000_000) {
        // amax from 0.5 to 10⁴ times the faster rate, log-uniform: ramps of 2 s to 100 µs
        tracking_case(int, r1, r2, start, 10f64.powf(amax_exp), scurve, samples_step)?;
    }
}

/// A change during a trapezoid ramp starts at once, from the speed at the last step; a stop
/// during a ramp takes the shortest distance amax allows.
#[test]
fn changes_during_a_trapezoid_ramp_start_at_once() {
    let limits = TrackLimits {
        amax: 1000.0,
        jmax: None,
    };
    let mut tr = Tracker::new(F as f64, limits, 0.0, Rate::new(10_000, 1).unwrap()).unwrap();
    let mut ck = Checker::new(limits.amax);
    ck.run(&mut tr, 3 * F, &mut core::iter::empty());
    let v = 1000.0 * ck.last as f64 / F as f64; // the ramp's speed at its last step
    tr.set_rate(Rate::new(5_000, 1).unwrap()).unwrap();
    let p = tr.ramp_profile().expect("a new ramp at once");
    assert!(
        (p.velocity(0.0) - v).abs() < 1e-3 * v,
        "{} vs {v}",
        p.velocity(0.0)
    );
    ck.run(&mut tr, ck.last + F / 2, &mut core::iter::empty());
    let (steps, v) = (ck.steps, 1000.0 * (3.0 + 0.5));
    tr.stop().unwrap();
    ck.run(&mut tr, u64::MAX, &mut core::iter::empty());
    let braking = (ck.steps - steps) as f64;
    let least = v * v / (2.0 * limits.amax);
    assert!(
        braking >= least - 1.0 && braking <= least + 2.0,
        "{braking} vs {least}"
    );
    assert!(tr.next().is_none());
}

/// A signed tracking command as the board gives it: a rate of the other sign is a stop,
/// then a new stream from rest the other way once the stop ends.
#[derive(Clone, Copy, Debug)]
struct Cmd {
    negative: bool,
    rate: Rate,
}

/// How far the stream runs before the next command.
#[derive(Clone, Copy, Debug)]
enum Gap {
    /// This many edges.
    Steps(u64),
    /// Up to `k` steps before the end of the ramp under way (0: its last step), so a
    /// command lands where a ramp's speed is near its end speed.
    RampEnd(u64),
}

/// One axis driven by signed commands as the controller drives it (`board/tracking.rs`):
/// each stream checked edge by edge against the exact references, the streams' ticks
/// joined on one time line.
struct Axis<R: RampEdges> {
    limits: TrackLimits,
    /// The stream now, its first tick, its checker.
    tr: Option<(TrackerOf<R>, u64, Checker)>,
    negative: bool,
    /// A reversal: once the stop under way ends, this rate the other way.
    then: Option<Rate>,
    /// The last edge on the common time line.
    last: u64,
}

impl<R: RampEdges> Axis<R> {
    fn new(limits: TrackLimits) -> Self {
        Axis {
            limits,
            tr: None,
            negative: false,
            then: None,
            last: 0,
        }
    }

    fn start(&mut self, negative: bool, rate: Rate) {
        let tr = TrackerOf::<R>::new(F as f64, self.limits, 0.0, rate).unwrap();
        self.tr = Some((tr, self.last, Checker::new(self.limits.amax)));
        self.negative = negative;
        self.then = None;
    }

    /// Changes the rate of the stream under way; the checker forgets a ramp replaced.
    fn set_rate(&mut self, rate: Rate) {
        let (tr, _, ck) = self.tr.as_mut().unwrap();
        let before = (tr.segment(), tr.ramp_profile().cloned());
        tr.set_rate(rate).unwrap();
        if (tr.segment(), tr.ramp_profile().cloned()) != before {
            ck.ramp = None;
        }
    }

    fn command(&mut self, c: Cmd) {
        let zero = c.rate.is_zero();
        if self.tr.is_none() {
            if !zero {
                self.start(c.negative, c.rate);
            }
            return;
        }
        if zero || c.negative == self.negative {
            self.then = None;
            self.set_rate(c.rate);
        } else {
            self.then = Some(c.rate);
            self.set_rate(Rate::ZERO);
        }
    }

    /// The next edge on the common time line; a stream that ends starts the reversal's.
    fn step(&mut self) -> Option<u64> {
        loop {
            let (tr, origin, ck) = self.tr.as_mut()?;
            if let Some(e) = tr.next() {
                ck.check(tr, e);
                let e = *origin + e;
                assert!(e > self.last || self.last == 0, "edges go forward");
                self.last = e;
                return Some(e);
            }
            self.tr = None;
            let rate = self.then.take()?;
            self.start(!self.negative, rate);
        }
    }

    fn run(&mut self, gap: Gap) {
        let n = match (gap, &self.tr) {
            (Gap::Steps(n), _) => n,
            (Gap::RampEnd(k), Some((tr, _, _))) => match (tr.segment(), tr.ramp_profile()) {
                (TrackSegment::Ramp { start_step, .. }, Some(p)) => {
                    (start_step + p.steps()).saturating_sub(tr.steps() + k)
                }
                _ => 0,
            },
            _ => 0,
        };
        for _ in 0..n {
            if self.step().is_none() {
                return;
            }
        }
    }

    /// Runs until the stream cruises at `want` the right way, or rests when `want` is
    /// zero; the tick it got there (a cruise's exact origin, rounded up).
    fn settle(&mut self, want: Cmd) -> u64 {
        loop {
            if let Some((tr, origin, _)) = &self.tr {
                if let TrackSegment::Cruise {
                    rate, origin_tick, ..
                } = tr.segment()
                {
                    if !want.rate.is_zero() && self.then.is_none() {
                        assert_eq!((rate, self.negative), (want.rate, want.negative));
                        return origin + origin_tick + 1;
                    }
                }
            }
            if self.step().is_none() {
                assert!(want.rate.is_zero(), "the stream ended before {want:?}");
                return self.last;
            }
        }
    }
}

/// Drives `cmds` (each after its gap) and checks that the last is reached within the
/// ramps the limits allow; returns the seconds it took and the bound.
fn settles<R: RampEdges>(limits: TrackLimits, cmds: &[(Gap, Cmd)]) -> (f64, f64) {
    let mut ax = Axis::<R>::new(limits);
    let mut at = 0;
    for &(gap, c) in cmds {
        ax.run(gap);
        // a change starts from the last step made
        at = ax.last;
        ax.command(c);
    }
    let done = ax.settle(cmds.last().unwrap().1);
    let took = done.saturating_sub(at) as f64 / F as f64;
    // Every ramp is planned from 0, from a rate asked for, or from the speed at one of a
    // trapezoid ramp's steps (at least √(2·amax) short of its last); it takes the speed
    // change over amax (plus amax/jmax for an S-curve) and less than one step at its
    // faster end. After the last command at most three ramps run: the rest of an S-curve
    // ramp under way, a stop (a reversal) and the ramp to the rate.
    let a = limits.amax;
    let fastest = cmds.iter().map(|c| c.1.rate.to_f64()).fold(0.0, f64::max);
    let slowest = cmds
        .iter()
        .map(|c| c.1.rate.to_f64())
        .filter(|&v| v > 0.0)
        .fold(a.sqrt(), f64::min);
    let ramp = fastest / a + limits.jmax.map_or(0.0, |j| a / j) + 1.0 / slowest;
    let bound = 3.0 * ramp + 1e-3;
    (took, bound)
}

/// `track Z 2763; track Z -2667; track Z 0; track Z -1832; track Z 1188; stop Z`, with the
/// new rate landing on one of the last steps of the stop: the stop from the last step of a
/// ramp to rest took one step at the speed left over there (0.000169 steps/s, ~1.6 h).
#[test]
fn a_stop_just_after_a_stop_ends_does_not_crawl() {
    let limits = TrackLimits {
        amax: 20_000.0,
        jmax: None,
    };
    let cmd = |r: i64| Cmd {
        negative: r < 0,
        rate: Rate::new(r.unsigned_abs() as u128, 1).unwrap(),
    };
    for k in 0..3 {
        for first in (1..160).step_by(3).map(Gap::Steps).chain([Gap::RampEnd(0)]) {
            let cmds = [
                (Gap::Steps(0), cmd(2763)),
                (first, cmd(-2667)),
                (Gap::Steps(5), cmd(0)),
                (Gap::Steps(3), cmd(-1832)),
                (Gap::RampEnd(k), cmd(1188)),
                (Gap::Steps(0), cmd(0)),
            ];
            let (took, bound) = settles::<EdgeGenerator>(limits, &cmds);
            assert!(took <= bound, "{k} {first:?}: {took} s > {bound} s");
            let (took, bound) = settles::<multistep_core::int::IntRamp>(limits, &cmds);
            assert!(took <= bound, "int, {k} {first:?}: {took} s > {bound} s");
        }
    }
}

fn any_cmd() -> impl Strategy<Value = Cmd> {
    (
        any::<bool>(),
        prop_oneof![1 => Just(0.0), 3 => -1.0f64..3.7],
        1u128..1000,
    )
        .prop_map(|(negative, lg, den)| {
            let rate = if lg == 0.0 {
                Rate::ZERO
            } else {
                // 0.1 to 5000 steps/s, log-uniform
                Rate::new(((10f64.powf(lg) * den as f64) as u128).max(1), den).unwrap()
            };
            Cmd {
                negative: negative && !rate.is_zero(),
                rate,
            }
        })
}

fn any_gap() -> impl Strategy<Value = Gap> {
    prop_oneof![
        2 => Just(Gap::Steps(0)),
        1 => (1u64..4).prop_map(Gap::Steps),
        2 => (4u64..3000).prop_map(Gap::Steps),
        3 => (0u64..3).prop_map(Gap::RampEnd),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    /// Random signed rates, stops and reversals at random steps (many at or next to a
    /// ramp's end), trapezoid or S-curve ramps, float or integer tracker: every edge is
    /// exact and goes forward, and the last command's rate (or rest) is reached within the
    /// ramps the limits allow.
    #[test]
    fn any_commands_settle_within_the_ramps(
        cmds in proptest::collection::vec((any_gap(), any_cmd()), 1..10),
        amax_exp in 2.0f64..5.0, jerk in prop::option::of(1.0f64..100.0),
        int in any::<bool>(),
    ) {
        let amax = 10f64.powf(amax_exp);
        let limits = TrackLimits { amax, jmax: jerk.map(|k| k * amax) };
        let (took, bound) = if int {
            settles::<multistep_core::int::IntRamp>(limits, &cmds)
        } else {
            settles::<EdgeGenerator>(limits, &cmds)
        };
        prop_assert!(took <= bound, "{took} s > {bound} s");
    }
}
