//! A simulated Hall sensor and the debounce filter that reads it (seed 002 §2.3: the
//! sensor marks the mechanical zero; software filtering rejects short interference).
//!
//! The raw level is `magnet present XOR noise glitch XOR contact bounce`
//! (`multistep_sim::hall`). The filter
//! accepts a new level only after it held for `debounce` ticks without a break (so pulses
//! shorter than that are rejected). The edge it reports is where the new level *first*
//! appeared, unless the old level came back for a whole debounce time since (then that
//! first appearance was a glitch). With every disturbance shorter than the debounce time
//! and disturbances at least a debounce time apart, the reported edge is the real edge or
//! up to one glitch plus one debounce time early — and never late, whatever the bounce.

#[cfg(feature = "sim")]
use crate::axis::SimSettings;
#[cfg(feature = "sim")]
use multistep_sim::hall::{HallSensor, SensorSettings};

/// A level change confirmed by the debounce filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilteredEdge {
    /// Tick at which the filter confirmed it (start of the stable level + debounce).
    pub tick: u64,
    pub active: bool,
    /// Counted position when the stable level began.
    pub count_at_start: i64,
    /// Simulated mechanical position when the stable level began.
    pub true_at_start: i64,
}

/// The simulated sensor (`multistep_sim::hall`, the same model the hardware-in-the-loop
/// board reads) and the debounce filter that reads it.
#[cfg(feature = "sim")]
#[derive(Clone, Debug)]
pub struct HallSim {
    sensor: HallSensor,
    // Filter state.
    raw: bool,
    raw_since: u64,
    /// Where the new level first appeared (count, true position), while unconfirmed.
    candidate: Option<(i64, i64)>,
    filtered: bool,
    debounce_ticks: u64,
    /// Noise events handled so far (the board's measure of its own work).
    pub work: u64,
}

#[cfg(feature = "sim")]
impl HallSim {
    pub fn new(
        sim: &SimSettings,
        home_dir: i8,
        period: Option<u64>,
        debounce_s: f64,
        clock_hz: f64,
    ) -> HallSim {
        let sensor = HallSensor::new(&SensorSettings::from_seconds(
            sim.sensor_at,
            sim.sensor_width,
            home_dir,
            period,
            sim.bounce_count,
            sim.bounce_time,
            sim.glitch_rate,
            sim.glitch_max,
            sim.glitch_gap,
            sim.seed,
            clock_hz,
        ));
        HallSim {
            sensor,
            raw: false,
            raw_since: 0,
            candidate: None,
            filtered: false,
            debounce_ticks: ((debounce_s * clock_hz).round().max(0.0) as u64).max(1),
            work: 0,
        }
    }

    /// Is the magnet in the sensor window at this true position?
    pub fn in_window(&self, true_pos: i64) -> bool {
        self.sensor.in_window(true_pos)
    }

    /// Starts watching at `tick` with the axis at rest: the levels are whatever the window
    /// says, with no history (the filter has had all the time it needs while idle).
    pub fn resync(&mut self, tick: u64, count: i64, true_pos: i64) {
        self.sensor.resync(tick, true_pos);
        let present = self.sensor.in_window(true_pos);
        self.raw = present;
        self.filtered = present;
        self.raw_since = tick;
        self.candidate = None;
        let _ = count;
    }

    pub fn filtered(&self) -> bool {
        self.filtered
    }

    /// Confirms the raw level if it has held long enough by `tick`, or drops the
    /// candidate edge if the old level has.
    fn check_filter(&mut self, tick: u64) -> Option<FilteredEdge> {
        let held = self.raw_since.saturating_add(self.debounce_ticks);
        if held > tick {
            return None;
        }
        if self.raw == self.filtered {
            self.candidate = None;
            return None;
        }
        self.filtered = self.raw;
        let (c, t) = self.candidate.take().unwrap_or((0, 0));
        Some(FilteredEdge {
            tick: held,
            active: self.raw,
            count_at_start: c,
            true_at_start: t,
        })
    }

    fn apply_level(&mut self, tick: u64, count: i64, true_pos: i64) -> Option<FilteredEdge> {
        let ev = self.check_filter(tick);
        let lvl = self.sensor.level();
        if lvl != self.raw {
            self.raw = lvl;
            self.raw_since = tick;
            if lvl != self.filtered && self.candidate.is_none() {
                self.candidate = Some((count, true_pos));
            }
        }
        ev
    }

    /// Advances time to `until` with the axis standing at (count, true_pos). Returns the
    /// first filtered edge on the way; the caller calls again to continue past it.
    pub fn advance(&mut self, until: u64, count: i64, true_pos: i64) -> Option<FilteredEdge> {
        loop {
            let next = self.sensor.next_noise_event();
            if next > until {
                break;
            }
            // A confirmation due before the next noise event comes first.
            if let Some(ev) = self.check_filter(next) {
                return Some(ev);
            }
            self.work += self.sensor.noise_event(next);
            if let Some(ev) = self.apply_level(next, count, true_pos) {
                return Some(ev);
            }
        }
        self.sensor.set_time(until);
        self.check_filter(until)
    }

    /// The axis steps at `tick` to `true_pos` (call `advance(tick, …)` first).
    pub fn step(&mut self, tick: u64, count: i64, true_pos: i64) -> Option<FilteredEdge> {
        self.sensor.move_to(tick, true_pos);
        self.apply_level(tick, count, true_pos)
    }
}

#[cfg(all(test, feature = "sim"))]
mod tests {
    use super::*;

    fn sim() -> SimSettings {
        SimSettings {
            sensor_at: 100,
            sensor_width: 50,
            ..SimSettings::default()
        }
    }

    #[test]
    fn window_follows_home_direction_and_period() {
        let h = HallSim::new(&sim(), -1, None, 0.001, 1e6);
        assert!(h.in_window(100) && h.in_window(51) && !h.in_window(50) && !h.in_window(101));
        let h = HallSim::new(&sim(), 1, None, 0.001, 1e6);
        assert!(h.in_window(100) && h.in_window(149) && !h.in_window(150) && !h.in_window(99));
        let h = HallSim::new(&sim(), 1, Some(1000), 0.001, 1e6);
        assert!(h.in_window(1100) && h.in_window(-900) && !h.in_window(1099));
    }

    #[test]
    fn pulse_shorter_than_debounce_is_rejected_and_longer_accepted() {
        // Noise-free sensor; move into the window for 999 ticks, out, then in for good.
        let mut h = HallSim::new(&sim(), 1, None, 0.001, 1e6); // debounce 1000 ticks
        h.resync(0, 0, 99);
        assert_eq!(h.advance(10, 99, 99), None);
        assert_eq!(h.step(10, 100, 100), None); // enters
        assert_eq!(h.advance(1009, 100, 100), None);
        assert_eq!(h.step(1009, 99, 99), None); // leaves after 999 ticks: rejected
        assert_eq!(h.advance(5000, 99, 99), None);
        assert!(!h.filtered());
        assert_eq!(h.step(5000, 100, 100), None);
        let ev = h.advance(7000, 100, 100).expect("confirmed");
        assert_eq!((ev.tick, ev.active, ev.count_at_start), (6000, true, 100));
        assert!(h.filtered());
        // A dropout shorter than debounce neither confirms nor moves the edge back.
        assert_eq!(h.step(7000, 99, 99), None);
        assert_eq!(h.advance(7500, 99, 99), None);
        assert_eq!(h.step(7500, 100, 100), None);
        assert_eq!(h.advance(20_000, 100, 100), None);
        // Leaving with a bounce back in: the edge is the first leaving step.
        assert_eq!(h.step(20_000, 99, 99), None);
        assert_eq!(h.advance(20_100, 99, 99), None);
        assert_eq!(h.step(20_100, 100, 100), None);
        assert_eq!(h.advance(20_200, 100, 100), None);
        assert_eq!(h.step(20_200, 99, 99), None);
        let ev = h.advance(30_000, 99, 99).expect("confirmed");
        assert_eq!((ev.tick, ev.active, ev.count_at_start), (21_200, false, 99));
    }
}
