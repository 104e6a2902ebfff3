//! A board's crystal against host time. The board counts ticks of its own oscillator,
//! nominally `clock_hz` a second but off by its tolerance (±50 ppm is 4.3 s a day, 65″ a
//! day at the sidereal rate). The host reads the board's tick counter now and then, stamps
//! each reading with its own clock, fits a line through the readings and gives each
//! tracker the rate in board ticks that makes the axis follow host time: the tracker still
//! runs exactly (crates/core/src/track.rs), only the rate it is given changes.

use crate::error::CtlError;
use multistep_core::{Rate, TrackError};
use std::collections::VecDeque;

/// The crystal errors a simulated board takes (ppm): ten times a common crystal's
/// tolerance, both ways.
pub const PPM_RANGE: (f64, f64) = (-1000.0, 1000.0);

/// Checks a simulated board's crystal error against [`PPM_RANGE`].
pub fn check_ppm(ppm: f64) -> Result<(), CtlError> {
    let (lo, hi) = PPM_RANGE;
    if (lo..=hi).contains(&ppm) {
        Ok(())
    } else {
        Err(CtlError::Setting(format!(
            "ppm must be in [{lo}, {hi}] (got {ppm})"
        )))
    }
}

/// Readings the fit looks at: the newest ones.
pub const WINDOW: usize = 512;

/// Readings (kept ones) the first estimate waits for.
pub const MIN_READINGS: usize = 8;

/// The host time the first estimate's kept readings must span (ns): over a shorter span a
/// millisecond of link jitter is tens of ppm.
pub const MIN_SPAN_NS: u64 = 60_000_000_000;

/// A rate correction is given to the trackers again once the estimate moved by this much
/// (parts per 10^9) from the one they run on: 0.005 ppm, 0.0003″ an hour at the sidereal
/// rate.
pub const RETUNE_PPB: i64 = 5;

/// One reading of the board's tick counter: asked for at host time `sent_ns`, answered at
/// `recv_ns`; the board latched `tick` somewhere between.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reading {
    pub sent_ns: u64,
    pub recv_ns: u64,
    pub tick: u64,
}

/// The board's clock as fitted: `tick ≈ tick0 + ticks_per_ns·(t − t0_ns)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockFit {
    /// The board's rate error (ppm): positive when its ticks come faster than nominal.
    pub ppm: f64,
    /// Board ticks per host nanosecond.
    pub ticks_per_ns: f64,
    /// A host time and the board's fitted tick then.
    pub t0_ns: u64,
    pub tick0: f64,
    /// Readings the fit kept and the readings it looked at.
    pub kept: usize,
    pub seen: usize,
}

impl ClockFit {
    /// The board's tick at host time `t_ns` (nearest; 0 before the board's zero).
    pub fn tick_at(&self, t_ns: u64) -> u64 {
        let dt = t_ns as f64 - self.t0_ns as f64;
        (self.tick0 + self.ticks_per_ns * dt).round().max(0.0) as u64
    }

    /// The rate error in whole parts per 10^9, as the correction uses it.
    pub fn ppb(&self) -> i64 {
        (self.ppm * 1e3).round() as i64
    }
}

/// The least-squares fit of a board's tick counter against host time over its newest
/// [`WINDOW`] readings. A reading's tick was latched at an unknown instant between asking
/// and answer, so each is placed at the middle of its round trip and only the faster half
/// of the window is fitted: a reading delayed on the link (an outlier of minutes is as
/// harmless as one of a millisecond) is dropped, and the kept ones are the least uncertain.
#[derive(Clone, Debug)]
pub struct ClockEstimator {
    clock_hz: f64,
    readings: VecDeque<Reading>,
    fit: Option<ClockFit>,
    min_span_ns: u64,
}

impl ClockEstimator {
    /// For a board whose nominal clock is `clock_hz`.
    pub fn new(clock_hz: f64) -> ClockEstimator {
        ClockEstimator {
            clock_hz,
            readings: VecDeque::with_capacity(WINDOW),
            fit: None,
            min_span_ns: MIN_SPAN_NS,
        }
    }

    /// Fits over a shorter (or longer) span than [`MIN_SPAN_NS`]: readings without link
    /// jitter, such as counts latched together at a SYNC fall.
    pub fn with_min_span(mut self, ns: u64) -> ClockEstimator {
        self.min_span_ns = ns;
        self
    }

    /// Adds a reading and fits again. A reading answered before it was asked, or older
    /// than the last one, is refused (the fit stays as it was).
    pub fn add(&mut self, r: Reading) -> Result<Option<ClockFit>, CtlError> {
        if r.recv_ns < r.sent_ns {
            return Err(CtlError::Timing(format!(
                "a tick reading answered at {} ns before it was asked at {} ns",
                r.recv_ns, r.sent_ns
            )));
        }
        if let Some(last) = self.readings.back() {
            if r.sent_ns < last.sent_ns || r.tick < last.tick {
                return Err(CtlError::Timing(format!(
                    "a tick reading ({} at {} ns) older than the last one ({} at {} ns)",
                    r.tick, r.sent_ns, last.tick, last.sent_ns
                )));
            }
        }
        if self.readings.len() == WINDOW {
            self.readings.pop_front();
        }
        self.readings.push_back(r);
        self.fit = self.refit().or(self.fit);
        Ok(self.fit)
    }

    /// The fit of the readings so far (`None` until there are enough).
    pub fn fit(&self) -> Option<ClockFit> {
        self.fit
    }

    /// Forgets every reading (the board was reset: its counter restarted).
    pub fn restart(&mut self) {
        self.readings.clear();
        self.fit = None;
    }

    fn refit(&self) -> Option<ClockFit> {
        let mut rtts: Vec<u64> = self
            .readings
            .iter()
            .map(|r| r.recv_ns - r.sent_ns)
            .collect();
        rtts.sort_unstable();
        let median = *rtts.get((rtts.len().saturating_sub(1)) / 2)?;
        let kept: Vec<(f64, f64)> = self
            .readings
            .iter()
            .filter(|r| r.recv_ns - r.sent_ns <= median)
            .map(|r| {
                let mid = r.sent_ns as f64 + (r.recv_ns - r.sent_ns) as f64 / 2.0;
                (mid, r.tick as f64)
            })
            .collect();
        let (first, last) = (kept.first()?.0, kept.last()?.0);
        if kept.len() < MIN_READINGS || last - first < self.min_span_ns as f64 {
            return None;
        }
        // Centred on the means, so the products stay far inside f64's 53 bits.
        let n = kept.len() as f64;
        let mx = kept.iter().map(|p| p.0 - first).sum::<f64>() / n;
        let my = kept.iter().map(|p| p.1).sum::<f64>() / n;
        let (mut sxx, mut sxy) = (0.0, 0.0);
        for &(x, y) in &kept {
            let dx = x - first - mx;
            sxx += dx * dx;
            sxy += dx * (y - my);
        }
        if sxx <= 0.0 {
            return None;
        }
        let ticks_per_ns = sxy / sxx;
        let ppm = (ticks_per_ns * 1e9 / self.clock_hz - 1.0) * 1e6;
        if !ppm.is_finite() || ppm.abs() > 1e5 {
            return None;
        }
        Some(ClockFit {
            ppm,
            ticks_per_ns,
            t0_ns: (first + mx).round() as u64,
            tick0: my,
            kept: kept.len(),
            seen: self.readings.len(),
        })
    }
}

/// `rate` (steps a host second) as steps a board second on a board `ppb` parts per 10^9
/// fast: `rate·10^9/(10^9 + ppb)`, exactly when the fraction fits the tracker's 64-bit
/// parts, else the nearest binary fraction (at most one part in 2^52 off).
pub fn board_rate(rate: Rate, ppb: i64) -> Result<Rate, TrackError> {
    if ppb == 0 || rate.is_zero() {
        return Ok(rate);
    }
    const G: i128 = 1_000_000_000;
    let d = G + ppb as i128;
    if d <= 0 {
        return Err(TrackError::NegativeRate);
    }
    let exact = rate
        .num()
        .checked_mul(G as u128)
        .zip(rate.den().checked_mul(d as u128))
        .and_then(|(n, d)| Rate::new(n, d).ok());
    match exact {
        Some(r) => Ok(r),
        None => Rate::from_f64(rate.to_f64() * G as f64 / d as f64),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const F: u64 = 50_000_000;

    /// The board's tick at host time `t_ns` on a crystal `ppm` off (exact).
    fn tick(t_ns: u64, ppm: i64) -> u64 {
        (t_ns as i128 * F as i128 * (1_000_000 + ppm as i128) / 1_000_000_000_000_000) as u64
    }

    #[test]
    fn the_fit_finds_the_crystal_through_jitter_and_delays() {
        for ppm in [-50i64, 0, 37, 50, 1000] {
            let mut e = ClockEstimator::new(F as f64);
            let mut seed = 12345u64;
            for k in 0..200u64 {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let sent = k * 1_000_000_000;
                // 0.2 to 1.2 ms round trips, every seventh delayed by up to 0.5 s
                let mut rtt = 200_000 + (seed >> 33) % 1_000_000;
                if k % 7 == 3 {
                    rtt += (seed >> 20) % 500_000_000;
                }
                let latched = sent + (seed >> 40) % 200_000;
                let r = Reading {
                    sent_ns: sent,
                    recv_ns: sent + rtt,
                    tick: tick(latched, ppm),
                };
                let fit = e.add(r).unwrap();
                // a minute of readings at the least, the faster half of them
                assert!(k >= 60 || fit.is_none(), "reading {k}");
                assert!(k < 70 || fit.is_some(), "reading {k}");
            }
            let fit = e.fit().unwrap();
            assert!((fit.ppm - ppm as f64).abs() < 0.05, "{ppm}: {fit:?}");
            let t = 150_000_000_000;
            assert!(fit.tick_at(t).abs_diff(tick(t, ppm)) < 50 * 200, "{fit:?}");
        }
    }

    #[test]
    fn readings_out_of_order_are_refused() {
        let mut e = ClockEstimator::new(F as f64);
        let r = Reading {
            sent_ns: 10,
            recv_ns: 20,
            tick: 100,
        };
        e.add(r).unwrap();
        let back = Reading { sent_ns: 5, ..r };
        assert!(matches!(e.add(back), Err(CtlError::Timing(_))));
        let inverted = Reading {
            sent_ns: 30,
            recv_ns: 25,
            tick: 200,
        };
        assert!(matches!(e.add(inverted), Err(CtlError::Timing(_))));
        assert!(e.fit().is_none());
    }

    #[test]
    fn a_board_rate_is_exact_and_undoes_the_crystal() {
        let sidereal = Rate::new(15041, 324).unwrap();
        let r = board_rate(sidereal, 50_000).unwrap();
        // 15041·10^9 / (324·1.00005·10^9), reduced
        assert_eq!(
            r,
            Rate::new(15041 * 1_000_000_000, 324 * 1_000_050_000).unwrap()
        );
        assert_eq!(board_rate(sidereal, 0).unwrap(), sidereal);
        assert_eq!(board_rate(Rate::ZERO, 7).unwrap(), Rate::ZERO);
        // too fine for an exact fraction: the nearest binary one
        let fine = Rate::new((1 << 64) - 1, (1 << 63) + 1).unwrap();
        let x = board_rate(fine, -3).unwrap();
        assert!((x.to_f64() / (fine.to_f64() * 1e9 / (1e9 - 3.0)) - 1.0).abs() < 1e-15);
        assert!(board_rate(sidereal, -2_000_000_000).is_err());
    }

    #[test]
    fn ppm_out_of_range_is_refused() {
        assert!(check_ppm(-1000.0).is_ok() && check_ppm(1000.0).is_ok());
        for bad in [1000.5, -2000.0, f64::NAN, f64::INFINITY] {
            let e = check_ppm(bad).unwrap_err().to_string();
            assert!(e.contains("ppm must be in [-1000, 1000]"), "{e}");
        }
    }
}
