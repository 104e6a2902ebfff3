//! Tracking on a board axis: the core's open-ended [`Tracker`] as a [`StepSource`], so a
//! tracking axis emits exactly the edges of `multistep plan --track` (shifted to its start
//! tick), and the rates a command may name.

use crate::error::CtlError;
use crate::motion::StepSource;
use crate::protocol::SignedRate;
use multistep_core::track::TrackSegment;
use multistep_core::{Rate, TrackError, TrackLimits, Tracker};

/// The edges of a tracking axis: the core tracker's, shifted to the start tick.
pub struct TrackSource {
    tracker: Tracker,
    start: u64,
    next: Option<u64>,
    limits: TrackLimits,
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
        })
    }

    /// Changes the rate from the last edge produced (a stop when `rate` is zero).
    pub fn set_rate(&mut self, rate: Rate) -> Result<(), CtlError> {
        self.tracker.set_rate(rate).map_err(track_error)
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
        let mut d = v * v / (2.0 * amax);
        let mut ramp_left = 0;
        if let Some(j) = jmax {
            d += v * amax / (2.0 * j);
            if let (Some(p), TrackSegment::Ramp { start_step, .. }) =
                (self.tracker.ramp_profile(), self.tracker.segment())
            {
                ramp_left = p.steps().saturating_sub(self.tracker.steps() - start_step);
            }
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
