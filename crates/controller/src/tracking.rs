//! Tracking on a board axis: the core's open-ended [`Tracker`] as a [`StepSource`], so a
//! tracking axis emits exactly the edges of `multistep plan --track` (shifted to its start
//! tick), and the rates a command may name.

use crate::domain::SignedRate;
use crate::error::CtlError;
use crate::motion::StepSource;
use multistep_core::track::TrackSegment;
use multistep_core::{EdgeGenerator, Num, Profile, Rate, TrackError, TrackLimits, Tracker};

/// The edges of a tracking axis: the core tracker's, shifted to the start tick.
pub struct TrackSource {
    tracker: Tracker,
    start: u64,
    next: Option<u64>,
    limits: TrackLimits,
    /// The longest step period the backend plays (ticks), where it has one.
    max_period: Option<u64>,
}

impl TrackSource {
    /// From rest at tick `start`, ramping to `rate` within `limits`.
    pub fn new(
        clock_hz: f64,
        limits: TrackLimits,
        rate: Rate,
        start: u64,
    ) -> Result<TrackSource, CtlError> {
        let tracker = Tracker::new(clock_hz, limits, 0.0, rate).map_err(track_error)?;
        Ok(TrackSource {
            tracker,
            start,
            next: None,
            limits,
            max_period: None,
        })
    }

    /// Changes the rate from the last edge produced (a stop when `rate` is zero, always
    /// taken).
    pub fn set_rate(&mut self, rate: Rate) -> Result<(), CtlError> {
        self.check_rate(rate)?;
        self.tracker.set_rate(rate).map_err(track_error)
    }

    /// Limits the step periods to what the backend plays (a replay unit's tick width):
    /// from now on a rate with a longer step is refused, this one included.
    pub fn limit_periods(&mut self, max_ticks: u64) -> Result<(), CtlError> {
        self.max_period = Some(max_ticks);
        self.check_rate(self.tracker.rate())
    }

    /// Refuses a rate with a step longer than the backend plays. The longest steps of
    /// tracking at `rate` are its cruise's (⌈f/R⌉ ticks), the first from rest (a ramp's
    /// speed only rises) and the last of its stop (only falls); a stop from any other
    /// speed ends in a step no longer than the first from rest at the highest speed (a
    /// ramp is its mirror) and a ramp between two rates runs no slower than the slower.
    pub fn check_rate(&self, rate: Rate) -> Result<(), CtlError> {
        let Some(max) = self.max_period else {
            return Ok(());
        };
        if rate.is_zero() {
            return Ok(());
        }
        let f = self.tracker.clock_hz();
        let (longest, which) = self.longest_steps(rate)?;
        if longest <= max {
            return Ok(());
        }
        // to four decimals, up
        let slowest = (f as f64 / max as f64 * 1e4).ceil() / 1e4;
        Err(CtlError::Unsupported(format!(
            "the board's replay unit takes steps of at most {max} ticks ({}), and tracking at \
             {} steps/s has a step of {longest} ticks ({}, {which}): a rate of at least {} \
             steps/s{}",
            Secs(max as f64 / f as f64),
            Num(rate.to_f64()),
            Secs(longest as f64 / f as f64),
            Num(slowest),
            if which == "the cruise" {
                ""
            } else {
                " and an amax that leaves rest within that step"
            }
        )))
    }

    /// The longest step period (ticks) of tracking at `rate` and which step it is.
    fn longest_steps(&self, rate: Rate) -> Result<(u64, &'static str), CtlError> {
        let f = self.tracker.clock_hz();
        let cruise = (f as u128 * rate.den()).div_ceil(rate.num().max(1));
        let cruise = u64::try_from(cruise).unwrap_or(u64::MAX);
        let limits = self.limits;
        let from_rest = Tracker::new(f as f64, limits, 0.0, rate)
            .map_err(track_error)?
            .next()
            .unwrap_or(0);
        let mut stop = Tracker::new(f as f64, limits, rate.to_f64(), rate).map_err(track_error)?;
        stop.stop().map_err(track_error)?;
        let last_of_stop = match stop.ramp_profile() {
            Some(p) => last_period(p.clone(), f)?,
            None => 0,
        };
        Ok([
            (cruise, "the cruise"),
            (from_rest, "the first from rest"),
            (last_of_stop, "the last of its stop"),
        ]
        .into_iter()
        .max_by_key(|x| x.0)
        .unwrap_or((cruise, "the cruise")))
    }

    /// Whether the stream came to rest: no edge is left to give (a backend may have closed
    /// it), so a new rate needs a new stream.
    pub fn at_rest(&self) -> bool {
        self.next.is_none() && self.tracker.segment() == TrackSegment::Stopped
    }

    /// The rate cruised at or ramped towards (zero while stopping).
    pub fn rate(&self) -> Rate {
        self.tracker.rate()
    }

    /// The acceleration and jerk the ramps keep to.
    pub fn limits(&self) -> TrackLimits {
        self.limits
    }

    /// [`TrackSource::stop_steps_bound`] as it would be after changing to `rate`.
    pub fn stop_bound_after(&self, rate: Rate) -> Result<u64, CtlError> {
        let mut probe = TrackSource {
            tracker: self.tracker.clone(),
            start: self.start,
            next: None,
            limits: self.limits,
            max_period: self.max_period,
        };
        probe.set_rate(rate)?;
        Ok(probe.stop_steps_bound())
    }

    /// At least the steps a stop asked for now still makes, counted from the last edge
    /// produced: `v²/(2a)` for a trapezoid stop from the speed now, `v²/(2a) + v·a/(2j)`
    /// for an S-curve stop from the faster of the speed now and the target plus the rest
    /// of a ramp under way (a change waits for its end) (seed 000's limits-mode ramps),
    /// plus the rounding of the stop to whole steps.
    pub fn stop_steps_bound(&self) -> u64 {
        let TrackLimits { amax, jmax } = self.limits;
        let now = self.speed_at(self.end_tick());
        // a trapezoid stop starts from the speed now; an S-curve one after the ramp
        let v = match jmax {
            Some(_) => now.max(self.tracker.rate().to_f64()),
            None => now,
        };
        let d = multistep_core::stop_distance(v, amax, jmax);
        let mut ramp_left = 0;
        if let (Some(_), Some(p), TrackSegment::Ramp { start_step, .. }) =
            (jmax, self.tracker.ramp_profile(), self.tracker.segment())
        {
            ramp_left = p.steps().saturating_sub(self.tracker.steps() - start_step);
        }
        (d.ceil().min(1e15) as u64) + ramp_left + 2
    }
}

impl StepSource for TrackSource {
    fn peek(&mut self) -> Option<u64> {
        if self.next.is_none() {
            self.next = self.tracker.next().and_then(|e| self.start.checked_add(e));
        }
        self.next
    }
    fn take(&mut self) {
        self.next = None;
    }
    fn speed_at(&self, tick: u64) -> f64 {
        match self.tracker.segment() {
            TrackSegment::Ramp { start_tick, .. } => {
                let Some(p) = self.tracker.ramp_profile() else {
                    return 0.0;
                };
                let from = self.start.saturating_add(start_tick);
                let t = tick.saturating_sub(from) as f64 / self.tracker.clock_hz() as f64;
                p.velocity(t.min(p.duration())).max(0.0)
            }
            TrackSegment::Cruise { rate, .. } => rate.to_f64(),
            TrackSegment::Stopped => 0.0,
        }
    }
    fn end_tick(&self) -> u64 {
        self.start.saturating_add(self.tracker.last_edge())
    }
    /// Open-ended: no count of steps to go.
    fn steps_left(&self) -> u64 {
        0
    }
    fn as_track(&mut self) -> Option<&mut TrackSource> {
        Some(self)
    }
}

/// The period of a profile's last step (ticks), in O(pieces).
fn last_period(p: Profile, clock_hz: u64) -> Result<u64, CtlError> {
    let n = p.steps();
    let mut gen = EdgeGenerator::new(p, clock_hz as f64)?;
    if n < 2 {
        return Ok(gen.next().unwrap_or(0));
    }
    gen.seek(n - 1);
    let before = gen.next().unwrap_or(0);
    Ok(gen.next().unwrap_or(before).saturating_sub(before))
}

/// Seconds, as a reply shows a time.
struct Secs(f64);

impl std::fmt::Display for Secs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} s", Num(self.0))
    }
}

/// The protocol error for a refused rate.
pub fn track_error(e: TrackError) -> CtlError {
    match e {
        TrackError::TooFast => CtlError::TooFast(format!("rate: {e}")),
        TrackError::Ramp(p) => CtlError::Plan(p),
        TrackError::BadRate(_) | TrackError::NegativeRate | TrackError::RateTooFine => {
            CtlError::syntax(format!("rate: {e}"))
        }
        TrackError::BadAmax(_)
        | TrackError::BadStartSpeed(_)
        | TrackError::BadClock(_)
        | TrackError::BadDuration(_)
        | TrackError::NeedsAmax { .. } => CtlError::Setting(e.to_string()),
        TrackError::TooLong | TrackError::NotInteger => CtlError::Timing(e.to_string()),
    }
}

/// A rate as steps/s: user units are scaled by `steps_per_unit`, exactly when it is a
/// whole number (and the product fits), else as the nearest binary fraction.
pub fn in_steps(r: SignedRate, steps_per_unit: f64) -> Result<Rate, CtlError> {
    if !r.units {
        return Ok(r.rate);
    }
    let spu = steps_per_unit;
    if spu.fract() == 0.0 && spu < 9e15 {
        if let Some(n) = r.rate.num().checked_mul(spu as u128) {
            if let Ok(x) = Rate::new(n, r.rate.den()) {
                return Ok(x);
            }
        }
    }
    Rate::from_f64(r.rate.to_f64() * spu).map_err(track_error)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_source_is_the_tracker_shifted() {
        let limits = TrackLimits {
            amax: 500.0,
            jmax: None,
        };
        let rate = Rate::parse("15041/324").unwrap();
        let mut src = TrackSource::new(1e6, limits, rate, 4321).unwrap();
        let plain = Tracker::new(1e6, limits, 0.0, rate).unwrap();
        for (k, want) in plain.take(2000).enumerate() {
            assert_eq!(src.peek(), Some(4321 + want), "step {k}");
            assert_eq!(src.peek(), Some(4321 + want), "peek is idempotent");
            src.take();
        }
        assert_eq!(src.speed_at(src.end_tick()), rate.to_f64());
    }

    #[test]
    fn a_stream_is_at_rest_once_its_stop_is_drained() {
        let limits = TrackLimits {
            amax: 20_000.0,
            jmax: None,
        };
        let mut src = TrackSource::new(50e6, limits, Rate::new(1000, 1).unwrap(), 0).unwrap();
        for _ in 0..100 {
            src.peek();
            src.take();
        }
        src.set_rate(Rate::ZERO).unwrap();
        assert!(!src.at_rest(), "stopping");
        while src.peek().is_some() {
            assert!(!src.at_rest(), "an edge is left");
            src.take();
        }
        assert!(src.at_rest());
    }

    #[test]
    fn units_scale_exactly_when_steps_per_unit_is_whole() {
        let r = SignedRate::parse("15.041u").unwrap().unwrap();
        // 4,000,000 microsteps per 1,296,000 arcsec is not whole: nearest binary fraction
        let x = in_steps(r, 4e6 / 1.296e6).unwrap();
        assert!((x.to_f64() - 15041.0 / 324.0).abs() < 1e-9);
        let y = in_steps(r, 200.0).unwrap();
        assert_eq!((y.num(), y.den()), (15041, 5));
        let z = in_steps(SignedRate::parse("7").unwrap().unwrap(), 3.0).unwrap();
        assert_eq!(z, Rate::new(7, 1).unwrap());
    }

    #[test]
    fn a_stop_asked_for_now_fits_its_bound() {
        for (rate, amax, jmax) in [
            ("4000", 20000.0, None),
            ("31999.9", 1e5, None),
            ("2500", 8000.0, Some(4e4)),
            ("46.4", 100.0, Some(1e3)),
        ] {
            let limits = TrackLimits { amax, jmax };
            let mut src = TrackSource::new(1e6, limits, Rate::parse(rate).unwrap(), 0).unwrap();
            for n in [1usize, 7, 50, 400, 3000] {
                for _ in 0..n {
                    src.peek();
                    src.take();
                }
                let probe = TrackSource {
                    tracker: src.tracker.clone(),
                    start: 0,
                    next: None,
                    limits,
                    max_period: None,
                };
                let bound = probe.stop_steps_bound();
                let mut s = src.tracker.clone();
                s.stop().unwrap();
                let made = s.count() as u64;
                assert!(made <= bound, "{rate} after {n}: {made} > {bound}");
                if matches!(src.tracker.segment(), TrackSegment::Cruise { .. }) {
                    assert!(
                        bound <= made + made / 8 + 4,
                        "{rate}: bound {bound} is loose ({made})"
                    );
                }
            }
        }
    }
}
