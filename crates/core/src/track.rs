//! Open-ended motion (tracking): ramp from the current speed to an exact rate, then cruise
//! at that rate for as long as wanted; the rate can be changed (or the axis stopped) while
//! the stream runs. Memory is O(1): one ramp generator or one cruise accumulator at a time.
//!
//! Ramps are limits-mode profiles planned by [`Profile::plan`] and run by [`EdgeGenerator`].
//! Cruises are exact: with the rate R = num/den steps/s and the clock f Hz (an integer),
//! step i of a cruise whose origin is X₀ ticks lands on `⌈X₀ + i·f/R − ½⌉` (the nearest
//! tick, a half tick going to the earlier tick). X₀ is an exact binary rational (a ramp's end
//! time is an f64, which is one), i·f/R is carried as quotient + remainder in u128, so the
//! edges never drift however long the cruise runs.

use crate::edges::EdgeGenerator;
use crate::error::PlanError;
use crate::profile::{LimitsMove, Move, Order, Profile};
use crate::real::fm;
use thiserror::Error;

/// Why a tracking motion cannot be set up.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum TrackError {
    #[error("'{0}' is not a rate (a decimal number or a fraction NUM/DEN of steps/s)")]
    /// The text is neither a decimal number nor a fraction.
    BadRate(RateText),
    #[error("the rate must be finite and not negative")]
    /// The rate is negative, infinite or NaN.
    NegativeRate,
    #[error("the rate's numerator or denominator is too large (at most 2^64)")]
    /// The rate's reduced fraction does not fit 64-bit parts (or its denominator is 0).
    RateTooFine,
    #[error("the clock must be a whole number of Hz from 1 to 2^53 (got {0})")]
    /// The clock is not a whole number of Hz in range.
    BadClock(f64),
    #[error("amax must be a finite number greater than zero (got {0})")]
    /// amax is not a positive finite number.
    BadAmax(f64),
    #[error("the start speed must be a finite number, not negative (got {0})")]
    /// The start speed is negative or not finite.
    BadStartSpeed(f64),
    #[error("a step period at this rate is shorter than two clock ticks")]
    /// The rate's step period is under two ticks.
    TooFast,
    #[error("the ramp cannot be planned: {0}")]
    /// The ramp to the rate could not be planned.
    Ramp(PlanError),
    #[error("the tick count left the 64-bit range")]
    /// The motion ran past the 64-bit tick range.
    TooLong,
    #[error("the ramp needs values wider than the integer datapath's 512 bits")]
    /// An integer tracker was given a ramp too wide for its datapath (or with pieces other
    /// than constant acceleration or constant jerk, which the tracker does not plan).
    NotInteger,
    #[error("the duration must be a number of seconds greater than zero (got {0})")]
    /// A stretch of tracking to print is not a positive number of seconds.
    BadDuration(f64),
    #[error("a ramp from {from} to {to} steps/s needs amax (or a start speed equal to the rate)")]
    /// A ramp is needed but no acceleration was given.
    NeedsAmax {
        /// The start speed (steps/s).
        from: f64,
        /// The rate (steps/s, nearest f64).
        to: f64,
    },
}

/// The text of a rate that could not be read, kept without allocation.
#[derive(Clone, Debug, PartialEq)]
pub struct RateText {
    buf: [u8; 32],
    len: usize,
}

impl RateText {
    fn new(s: &str) -> Self {
        let mut buf = [0u8; 32];
        let mut len = 0;
        for (i, c) in s.char_indices() {
            if i + c.len_utf8() > buf.len() {
                break;
            }
            len = i + c.len_utf8();
        }
        buf[..len].copy_from_slice(&s.as_bytes()[..len]);
        RateText { buf, len }
    }
}

impl core::fmt::Display for RateText {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(core::str::from_utf8(&self.buf[..self.len]).unwrap_or("?"))
    }
}

/// An exact rate in steps/s: `num/den`, reduced, both below 2^64 (den > 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rate {
    num: u128,
    den: u128,
}

const LIMIT: u128 = 1 << 64;

fn gcd(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

impl Rate {
    /// Standing still.
    pub const ZERO: Rate = Rate { num: 0, den: 1 };

    /// `num/den` steps/s.
    pub fn new(num: u128, den: u128) -> Result<Rate, TrackError> {
        if den == 0 {
            return Err(TrackError::RateTooFine);
        }
        let g = gcd(num, den).max(1);
        let (num, den) = (num / g, den / g);
        if num > LIMIT || den > LIMIT {
            return Err(TrackError::RateTooFine);
        }
        Ok(Rate { num, den })
    }

    /// A decimal number (`46.4228`, `31999.9`, `5e3`) or a fraction `15041/324`, read exactly.
    pub fn parse(s: &str) -> Result<Rate, TrackError> {
        let bad = || TrackError::BadRate(RateText::new(s));
        let t = s.trim();
        if let Some((a, b)) = t.split_once('/') {
            let a = Rate::parse_decimal(a.trim()).ok_or_else(bad)?;
            let b = Rate::parse_decimal(b.trim()).ok_or_else(bad)?;
            if b.num == 0 {
                return Err(bad());
            }
            let num = a.num.checked_mul(b.den).ok_or(TrackError::RateTooFine)?;
            let den = a.den.checked_mul(b.num).ok_or(TrackError::RateTooFine)?;
            return Rate::new(num, den);
        }
        Rate::parse_decimal(t).ok_or_else(bad)
    }

    fn parse_decimal(t: &str) -> Option<Rate> {
        let (mant, exp) = match t.find(['e', 'E']) {
            Some(k) => (&t[..k], t[k + 1..].parse::<i32>().ok()?),
            None => (t, 0),
        };
        let mant = mant.strip_prefix('+').unwrap_or(mant);
        let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
        if int.is_empty() && frac.is_empty() {
            return None;
        }
        let mut num: u128 = 0;
        for c in int.bytes().chain(frac.bytes()) {
            if !c.is_ascii_digit() {
                return None;
            }
            num = num.checked_mul(10)?.checked_add((c - b'0') as u128)?;
        }
        let scale = exp - frac.len() as i32;
        let pow = 10u128.checked_pow(scale.unsigned_abs())?;
        if scale >= 0 {
            Rate::new(num.checked_mul(pow)?, 1).ok()
        } else {
            Rate::new(num, pow).ok()
        }
    }

    /// The exact value of an f64 (a binary rational).
    pub fn from_f64(x: f64) -> Result<Rate, TrackError> {
        if !x.is_finite() || x < 0.0 {
            return Err(TrackError::NegativeRate);
        }
        if x == 0.0 {
            return Ok(Rate::ZERO);
        }
        let (m, e) = split_f64(x);
        if e >= 0 {
            Rate::new(
                (m as u128)
                    .checked_shl(e as u32)
                    .ok_or(TrackError::RateTooFine)?,
                1,
            )
        } else if -e < 128 {
            Rate::new(m as u128, 1u128 << (-e) as u32)
        } else {
            Err(TrackError::RateTooFine)
        }
    }

    /// The reduced numerator (steps).
    pub fn num(&self) -> u128 {
        self.num
    }

    /// The reduced denominator (seconds).
    pub fn den(&self) -> u128 {
        self.den
    }

    /// Whether the rate is zero.
    pub fn is_zero(&self) -> bool {
        self.num == 0
    }

    /// The nearest f64 (for planning ramps and for display).
    pub fn to_f64(&self) -> f64 {
        self.num as f64 / self.den as f64
    }
}

/// `x = m · 2^e` exactly, m an integer below 2^53 (x finite, positive).
fn split_f64(x: f64) -> (u64, i32) {
    let bits = x.to_bits();
    let exp = ((bits >> 52) & 0x7ff) as i32;
    let frac = bits & ((1u64 << 52) - 1);
    if exp == 0 {
        (frac, -1074)
    } else {
        (frac | (1u64 << 52), exp - 1075)
    }
}

/// `⌊a·b / 2^sh⌋` with the full 256-bit product (a, b < 2^128).
fn mul_shr(a: u128, b: u128, sh: u32) -> Option<u128> {
    let m = u64::MAX as u128;
    let (a1, a0, b1, b0) = (a >> 64, a & m, b >> 64, b & m);
    let lo = a0 * b0;
    let mid1 = a0 * b1;
    let mid2 = a1 * b0;
    let (mid, c1) = mid1.overflowing_add(mid2);
    let (lo, c2) = lo.overflowing_add(mid << 64);
    let hi = a1 * b1 + (mid >> 64) + ((c1 as u128) << 64) + c2 as u128;
    let r = if sh >= 256 {
        0
    } else if sh >= 128 {
        hi >> (sh - 128)
    } else if sh == 0 {
        if hi != 0 {
            return None;
        }
        lo
    } else {
        if hi >> sh != 0 {
            return None;
        }
        (lo >> sh) | (hi << (128 - sh))
    };
    Some(r)
}

/// The limits a ramp obeys.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackLimits {
    /// Maximum acceleration (steps/s²).
    pub amax: f64,
    /// Maximum jerk (steps/s³): S-curve ramps when given, trapezoid ramps otherwise.
    pub jmax: Option<f64>,
}

/// The first seconds of open-ended motion, as `multistep plan --track` prints them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackRun {
    /// The rate to ramp to and cruise at.
    pub rate: Rate,
    /// Seconds of edges (the last edge is at most `⌊duration·f⌋`).
    pub duration: f64,
    /// Speed at tick 0 (steps/s).
    pub start_speed: f64,
    /// The ramp's acceleration; needed unless the start speed is the rate.
    pub amax: Option<f64>,
    /// The ramp's jerk (S-curve ramps), if given.
    pub jmax: Option<f64>,
}

impl TrackRun {
    /// The tracker at tick 0 and the last tick to keep, `⌊duration·f⌋`.
    pub fn start<R: RampEdges>(&self, clock_hz: f64) -> Result<(TrackerOf<R>, u64), TrackError> {
        if !(self.duration.is_finite() && self.duration > 0.0) {
            return Err(TrackError::BadDuration(self.duration));
        }
        let amax = match self.amax {
            Some(a) => a,
            // no ramp to plan: amax is never consulted
            None if self.start_speed == self.rate.to_f64() => 1.0,
            None => {
                return Err(TrackError::NeedsAmax {
                    from: self.start_speed,
                    to: self.rate.to_f64(),
                })
            }
        };
        let limits = TrackLimits {
            amax,
            jmax: self.jmax,
        };
        let tracker = TrackerOf::new(clock_hz, limits, self.start_speed, self.rate)?;
        let end = self.duration * clock_hz;
        if end >= (1u64 << 62) as f64 {
            return Err(TrackError::TooLong);
        }
        Ok((tracker, fm::floor(end) as u64))
    }
}

/// A cruise at an exact rate from an exact origin: the quotient + remainder accumulator.
#[derive(Clone, Copy, Debug)]
struct Cruise {
    rate: Rate,
    /// Integer part of the origin X₀ (ticks) plus the whole ticks of i·f/R so far.
    base: u64,
    /// f/R = q + r/d ticks; `rem` is the remainder of i·f/R in units of 1/d.
    q: u64,
    r: u128,
    d: u128,
    rem: u128,
    /// With c the origin's fraction: `rem ≤ lo` → no extra tick (only when c ≤ ½), `rem ≤
    /// hi` → one, else two. That is `⌈c + rem/d − ½⌉` decided with two compares.
    lo: Option<u128>,
    hi: u128,
}

impl Cruise {
    /// A cruise at `rate` whose step 0 is at `origin + frac_num/2^frac_bits` ticks.
    fn new(
        clock: u64,
        rate: Rate,
        origin: u64,
        frac_num: u128,
        frac_bits: u32,
    ) -> Result<Cruise, TrackError> {
        // f/R = f·den/num ticks per step
        let p = (clock as u128)
            .checked_mul(rate.den)
            .ok_or(TrackError::RateTooFine)?;
        let g = gcd(p, rate.num);
        let (p, d) = (p / g, rate.num / g);
        let q = p / d;
        if q < 2 {
            return Err(TrackError::TooFast);
        }
        let q = u64::try_from(q).map_err(|_| TrackError::TooLong)?;
        // thresholds ⌊d·(1 − 2c)/2⌋ and ⌊d·(3 − 2c)/2⌋ with c = n/2^s:
        // d·(k·2^s − 2n) / 2^(s+1)
        let s = frac_bits;
        let one = 1u128.checked_shl(s).ok_or(TrackError::TooLong)?;
        let lo = one
            .checked_sub(2 * frac_num)
            .map(|k| mul_shr(d, k, s + 1).ok_or(TrackError::TooLong))
            .transpose()?;
        let k3 = (3 * one)
            .checked_sub(2 * frac_num)
            .ok_or(TrackError::TooLong)?;
        let hi = mul_shr(d, k3, s + 1).ok_or(TrackError::TooLong)?;
        Ok(Cruise {
            rate,
            base: origin,
            q,
            r: p % d,
            d,
            rem: 0,
            lo,
            hi,
        })
    }

    #[inline(always)]
    fn next_edge(&mut self) -> Option<u64> {
        self.base = self.base.checked_add(self.q)?;
        self.rem += self.r;
        if self.rem >= self.d {
            self.rem -= self.d;
            self.base = self.base.checked_add(1)?;
        }
        let extra = if self.lo.is_some_and(|lo| self.rem <= lo) {
            0
        } else if self.rem <= self.hi {
            1
        } else {
            2
        };
        self.base.checked_add(extra)
    }
}

/// What runs a tracker's ramps: the float [`EdgeGenerator`] ([`Tracker`]) or the integer
/// [`IntRamp`](crate::int::IntRamp) ([`IntTracker`](crate::int::IntTracker)). Both give the
/// edges of the ramp's profile, ticks from the ramp's start.
pub trait RampEdges: Clone + core::fmt::Debug + Sized {
    /// Starts the ramp `profile` on a clock of `clock_hz`.
    fn start(profile: Profile, clock_hz: u64) -> Result<Self, TrackError>;
    /// The next step's edge; `None` after the last.
    fn next_edge(&mut self) -> Option<u64>;
    /// The ramp's profile.
    fn profile(&self) -> &Profile;
}

impl RampEdges for EdgeGenerator {
    fn start(profile: Profile, clock_hz: u64) -> Result<Self, TrackError> {
        EdgeGenerator::new(profile, clock_hz as f64).map_err(TrackError::Ramp)
    }

    #[inline]
    fn next_edge(&mut self) -> Option<u64> {
        self.next()
    }

    fn profile(&self) -> &Profile {
        EdgeGenerator::profile(self)
    }
}

/// What the axis is doing now.
// The ramp's generator is large, but boxing would allocate (the crate is no_std, no alloc).
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Stage<R> {
    /// A ramp started at tick `start`, step `base`, towards `target`.
    Ramp {
        gen: R,
        start: u64,
        base: u64,
        target: Rate,
    },
    Cruise(Cruise),
    Stopped,
}

/// One segment of the motion, as reported by [`Tracker::segment`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TrackSegment {
    /// A ramp from `start_tick` (step `start_step`): the steps of `profile` shifted by both.
    Ramp {
        /// The tick the ramp starts on.
        start_tick: u64,
        /// The motion's step count before the ramp.
        start_step: u64,
    },
    /// A cruise at `rate` whose step 0 (= step `start_step` of the motion) is at
    /// `origin_tick + frac_num / 2^frac_bits` ticks.
    Cruise {
        /// The exact cruise rate.
        rate: Rate,
        /// The motion's step count before the cruise.
        start_step: u64,
        /// The whole ticks of the cruise's origin.
        origin_tick: u64,
        /// The origin's fraction of a tick, over 2^frac_bits.
        frac_num: u128,
        /// Binary places of the origin's fraction.
        frac_bits: u32,
    },
    /// Stopped: the stream has ended until a new rate is set.
    Stopped,
}

/// An open-ended edge stream: ramp to a rate, cruise, change rate, stop.
///
/// Iterating yields the edge tick of every step (1, 2, 3, …) in order; the stream ends only
/// after a stop (and resumes if a new rate is given).
///
/// [`Tracker`] runs ramps in f64, [`IntTracker`](crate::int::IntTracker) in integers; both
/// give the same edges.
#[derive(Clone, Debug)]
pub struct TrackerOf<R: RampEdges> {
    clock: u64,
    limits: TrackLimits,
    stage: Stage<R>,
    /// Origin of the current cruise, kept for [`Tracker::segment`].
    cruise_origin: (u64, u64, u128, u32),
    /// A rate change asked for during a ramp: applied when the ramp ends.
    pending: Option<Rate>,
    steps: u64,
    last_edge: u64,
    /// Speed at the last step (steps/s, for the next ramp's start).
    speed: f64,
}

/// The tracker with float ramps ([`EdgeGenerator`]).
pub type Tracker = TrackerOf<EdgeGenerator>;

impl<R: RampEdges> TrackerOf<R> {
    /// Starts at tick 0, step 0, moving at `start_speed` steps/s, towards `rate`.
    pub fn new(
        clock_hz: f64,
        limits: TrackLimits,
        start_speed: f64,
        rate: Rate,
    ) -> Result<Self, TrackError> {
        if !(clock_hz >= 1.0 && clock_hz <= (1u64 << 53) as f64 && fm::floor(clock_hz) == clock_hz)
        {
            return Err(TrackError::BadClock(clock_hz));
        }
        if !(limits.amax.is_finite() && limits.amax > 0.0) {
            return Err(TrackError::BadAmax(limits.amax));
        }
        if !(start_speed.is_finite() && start_speed >= 0.0) {
            return Err(TrackError::BadStartSpeed(start_speed));
        }
        let mut t = TrackerOf {
            clock: clock_hz as u64,
            limits,
            stage: Stage::Stopped,
            cruise_origin: (0, 0, 0, 0),
            pending: None,
            steps: 0,
            last_edge: 0,
            speed: start_speed,
        };
        t.begin(rate)?;
        Ok(t)
    }

    /// Changes the rate from the last step produced: a ramp from the current speed (a stop
    /// when `rate` is zero), then a cruise at `rate`. During a trapezoid ramp the new ramp
    /// starts at once from the speed at the last step (acceleration may jump, and stays
    /// within amax); during an S-curve ramp the change waits for the ramp's end, so jerk
    /// stays within jmax (the latest such change wins).
    ///
    /// So after any sequence of changes the rate asked for last (or rest) is reached within
    /// the rest of an S-curve ramp under way plus the new ramp: each ramp takes its speed
    /// change over amax (plus amax/jmax for an S-curve) and at most one step period at the
    /// faster of its start speed and rate, a speed that is zero, a rate asked for or at least
    /// √(2·amax).
    pub fn set_rate(&mut self, rate: Rate) -> Result<(), TrackError> {
        // plan it now so a bad rate is refused at once
        let _ = self.plan_ramp(self.speed, rate)?;
        if let Stage::Ramp {
            gen,
            start,
            base,
            target,
        } = &self.stage
        {
            // already ramping there: keep the ramp (and its exact end); a change asked for
            // during it is dropped, the latest wins
            if *target == rate {
                self.pending = None;
                return Ok(());
            }
            if self.limits.jmax.is_some() {
                self.pending = Some(rate);
                return Ok(());
            }
            let p = gen.profile();
            let done = self.steps - *base;
            // The speed at the last step. Before the ramp's first step it is the speed the
            // ramp starts from, at its last step the speed it ends at, exactly: the profile
            // at that step's tick (up to half a tick early) is still amax·½ tick above a
            // stop's zero, and a ramp from such a speed would crawl over its one step for
            // hours. A step inside the ramp is on its fraction of a step at the faster end
            // speed or a whole step of amax from both ends, at √(2·amax) or faster. So every
            // ramp starts from rest, a rate asked for or √(2·amax) and up, and its fraction
            // of a step at constant speed takes at most one step period at one of those.
            let v = if done == 0 {
                self.speed
            } else if done >= p.steps() {
                target.to_f64()
            } else {
                let tau = (self.last_edge - start) as f64 / self.clock as f64;
                p.velocity(tau.min(p.duration())).max(0.0)
            };
            let _ = self.plan_ramp(v, rate)?;
            self.speed = v;
        }
        self.begin(rate)
    }

    /// A controlled stop: [`Tracker::set_rate`] with zero.
    pub fn stop(&mut self) -> Result<(), TrackError> {
        self.set_rate(Rate::ZERO)
    }

    /// Steps produced so far.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Tick of the last step produced (0 before the first).
    pub fn last_edge(&self) -> u64 {
        self.last_edge
    }

    /// The clock the edges are counted in (Hz).
    pub fn clock_hz(&self) -> u64 {
        self.clock
    }

    /// The rate the axis cruises at (or ramps towards), zero when stopping or stopped.
    pub fn rate(&self) -> Rate {
        if let Some(r) = self.pending {
            return r;
        }
        match &self.stage {
            Stage::Ramp { target, .. } => *target,
            Stage::Cruise(c) => c.rate,
            Stage::Stopped => Rate::ZERO,
        }
    }

    /// The segment running now, with what an independent check needs to recompute it.
    pub fn segment(&self) -> TrackSegment {
        match &self.stage {
            Stage::Ramp { start, base, .. } => TrackSegment::Ramp {
                start_tick: *start,
                start_step: *base,
            },
            Stage::Cruise(c) => {
                let (start_step, origin_tick, frac_num, frac_bits) = self.cruise_origin;
                TrackSegment::Cruise {
                    rate: c.rate,
                    start_step,
                    origin_tick,
                    frac_num,
                    frac_bits,
                }
            }
            Stage::Stopped => TrackSegment::Stopped,
        }
    }

    /// The ramp's profile while a ramp runs (its step k is step `start_step + k`, its edge
    /// `start_tick + ` the profile's own edge).
    pub fn ramp_profile(&self) -> Option<&Profile> {
        match &self.stage {
            Stage::Ramp { gen, .. } => Some(gen.profile()),
            _ => None,
        }
    }

    /// Limits-mode ramp from v0 to `rate`: the fewest whole steps that hold the change, so
    /// the profile ends on a step at exactly the target speed (a fraction of a step of
    /// cruise fills the rest). `None` when there is nothing to change.
    fn plan_ramp(&self, v0: f64, rate: Rate) -> Result<Option<Profile>, TrackError> {
        let v1 = rate.to_f64();
        if rate.num() != 0 {
            // refuse rates the cruise could not run before a ramp is planned for them
            let p = (self.clock as u128)
                .checked_mul(rate.den)
                .ok_or(TrackError::RateTooFine)?;
            if p < 2 * rate.num {
                return Err(TrackError::TooFast);
            }
        }
        if v0 == v1 || (v0 == 0.0 && v1 == 0.0) {
            return Ok(None);
        }
        let order = match self.limits.jmax {
            Some(_) => Order::SCurve,
            None => Order::Trapezoid,
        };
        let plan = |steps: u64| {
            Profile::plan(&Move::Limits(LimitsMove {
                steps,
                order,
                vmax: v0.max(v1),
                amax: self.limits.amax,
                jmax: self.limits.jmax,
                smax: None,
                start_speed: v0,
                end_speed: v1,
            }))
        };
        let mut steps = 1u64;
        for _ in 0..3 {
            match plan(steps) {
                Ok(p) => return Ok(Some(p)),
                Err(PlanError::TooShortForLimits { needed, .. }) => {
                    let n = fm::floor(needed) + 1.0;
                    steps = if n as u64 > steps {
                        n as u64
                    } else {
                        steps + 1
                    };
                }
                Err(e) => return Err(TrackError::Ramp(e)),
            }
        }
        plan(steps).map(Some).map_err(TrackError::Ramp)
    }

    /// Starts the ramp (or cruise) towards `rate` at the last step: its tick and position.
    fn begin(&mut self, rate: Rate) -> Result<(), TrackError> {
        self.pending = None;
        let (start, base) = (self.last_edge, self.steps);
        match self.plan_ramp(self.speed, rate)? {
            Some(profile) => {
                let gen = R::start(profile, self.clock)?;
                self.stage = Stage::Ramp {
                    gen,
                    start,
                    base,
                    target: rate,
                };
            }
            None if rate.is_zero() => self.stage = Stage::Stopped,
            None => self.start_cruise(rate, start, 0, 0)?,
        }
        Ok(())
    }

    fn start_cruise(
        &mut self,
        rate: Rate,
        origin: u64,
        frac_num: u128,
        frac_bits: u32,
    ) -> Result<(), TrackError> {
        self.cruise_origin = (self.steps, origin, frac_num, frac_bits);
        self.stage = Stage::Cruise(Cruise::new(self.clock, rate, origin, frac_num, frac_bits)?);
        self.speed = rate.to_f64();
        Ok(())
    }

    /// The ramp that started at tick `start` ended: the cruise's origin is
    /// `start + f·T` ticks, exactly (T the profile's f64 duration).
    fn ramp_done(&mut self, start: u64, duration: f64, target: Rate) -> Result<(), TrackError> {
        self.speed = target.to_f64();
        if let Some(r) = self.pending.take() {
            return self.begin(r);
        }
        if target.is_zero() {
            self.stage = Stage::Stopped;
            return Ok(());
        }
        let (m, e) = split_f64(duration);
        let fm = self.clock as u128 * m as u128;
        let (whole, mut frac, mut bits) = if e >= 0 {
            (fm.checked_shl(e as u32).ok_or(TrackError::TooLong)?, 0, 0)
        } else {
            let s = (-e) as u32;
            if s >= 128 {
                (0, fm, s)
            } else {
                (fm >> s, fm & ((1u128 << s) - 1), s)
            }
        };
        while bits > 0 && frac & 1 == 0 {
            frac >>= 1;
            bits -= 1;
        }
        if bits > 124 {
            return Err(TrackError::TooLong);
        }
        let origin = u64::try_from(whole)
            .ok()
            .and_then(|w| w.checked_add(start))
            .ok_or(TrackError::TooLong)?;
        self.start_cruise(target, origin, frac, bits)
    }
}

impl<R: RampEdges> Iterator for TrackerOf<R> {
    type Item = u64;

    fn next(&mut self) -> Option<u64> {
        loop {
            let edge = match &mut self.stage {
                Stage::Cruise(c) => c.next_edge()?,
                Stage::Stopped => return None,
                Stage::Ramp {
                    gen,
                    start,
                    base: _,
                    target,
                } => match gen.next_edge() {
                    Some(e) => start.checked_add(e)?,
                    None => {
                        let (start, t, target) = (*start, gen.profile().duration(), *target);
                        // a cruise the ramp's numbers do not fit ends the stream
                        self.ramp_done(start, t, target).ok()?;
                        continue;
                    }
                },
            };
            self.steps += 1;
            self.last_edge = edge;
            return Some(edge);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wide_products_shift_exactly() {
        assert_eq!(mul_shr(12345, 67890, 0), Some(12345 * 67890));
        assert_eq!(mul_shr(u128::MAX, 2, 0), None);
        assert_eq!(mul_shr(1 << 127, 1 << 127, 254), Some(1));
        // (2^128 − 1)² = 2^256 − 2^129 + 1
        assert_eq!(mul_shr(u128::MAX, u128::MAX, 128), Some(u128::MAX - 1));
        assert_eq!(mul_shr(u128::MAX, u128::MAX, 129), Some(u128::MAX >> 1));
        assert_eq!(mul_shr(3 << 100, 5 << 90, 190), Some(15));
    }

    /// Origins with a fraction of 100 bits: a hair above a half tick rounds up, exactly a
    /// half tick (the earlier tick) and a hair below round down.
    #[test]
    fn origin_fractions_of_many_bits_decide_half_ticks() {
        let rate = Rate::new(1, 1).unwrap(); // 100 ticks per step at 100 Hz
        for (frac, bits, extra) in [
            ((1u128 << 99) + 1, 100, 1),
            (1 << 99, 100, 0),
            (1, 1, 0),
            ((1 << 99) - 1, 100, 0),
            ((3 << 98) + 1, 100, 1),
            (u128::MAX >> 4, 124, 1),
        ] {
            let mut c = Cruise::new(100, rate, 7, frac, bits).unwrap();
            for k in 1..5u64 {
                assert_eq!(
                    c.next_edge(),
                    Some(7 + 100 * k + extra),
                    "{frac:x}/2^{bits}"
                );
            }
        }
        // 2.5 ticks per step from ½ + ε: ⌈2.5k + ε⌉; from exactly ½: ⌈2.5k⌉
        for (frac, want) in [((1u128 << 99) + 1, [3, 6, 8, 11]), (1 << 99, [3, 5, 8, 10])] {
            let mut c = Cruise::new(100, Rate::new(40, 1).unwrap(), 0, frac, 100).unwrap();
            let got: [u64; 4] = core::array::from_fn(|_| c.next_edge().unwrap());
            assert_eq!(got, want);
        }
    }
}
