//! A simulated Hall sensor and the debounce filter that reads it (seed 002 §2.3: the
//! sensor marks the mechanical zero; software filtering rejects short interference).
//!
//! The raw level is `magnet present XOR noise glitch XOR contact bounce`. The filter
//! accepts a new level only after it held for `debounce` ticks without a break (so pulses
//! shorter than that are rejected). The edge it reports is where the new level *first*
//! appeared, unless the old level came back for a whole debounce time since (then that
//! first appearance was a glitch). With every disturbance shorter than the debounce time
//! and disturbances at least a debounce time apart, the reported edge is the real edge or
//! up to one glitch plus one debounce time early — and never late, whatever the bounce.

use crate::axis::SimSettings;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

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

/// The sensor window in true coordinates and the noise around it.
#[derive(Clone, Debug)]
pub struct HallSim {
    sensor_at: i64,
    width: u64,
    home_dir: i64,
    period: Option<u64>,
    bounce_count: u32,
    bounce_ticks: u64,
    glitch_mean_gap: Option<f64>,
    glitch_max_ticks: u64,
    glitch_gap_ticks: u64,
    rng: StdRng,
    // Noise: the glitch in progress or next to come, as [start, end) ticks.
    glitch: (u64, u64),
    burst: Burst,
    present: bool,
    flips: bool,
    // Filter state.
    raw: bool,
    raw_since: u64,
    /// Where the new level first appeared (count, true position), while unconfirmed.
    candidate: Option<(i64, i64)>,
    filtered: bool,
    debounce_ticks: u64,
    now: u64,
    /// Noise events handled so far (the board's measure of its own work).
    pub work: u64,
}

/// The contact bounce after one real edge: `left` toggles still to come, uniform in
/// (start, end] and drawn one at a time in time order, so memory stays constant whatever
/// the bounce count.
#[derive(Clone, Debug, Default)]
struct Burst {
    next: Option<u64>,
    left: u64,
    at: f64,
    end: f64,
}

impl HallSim {
    pub fn new(
        sim: &SimSettings,
        home_dir: i8,
        period: Option<u64>,
        debounce_s: f64,
        clock_hz: f64,
    ) -> HallSim {
        let ticks = |s: f64| (s * clock_hz).round().max(0.0) as u64;
        HallSim {
            sensor_at: sim.sensor_at,
            width: sim.sensor_width,
            home_dir: home_dir as i64,
            period,
            bounce_count: sim.bounce_count,
            bounce_ticks: ticks(sim.bounce_time),
            glitch_mean_gap: (sim.glitch_rate > 0.0).then(|| clock_hz / sim.glitch_rate),
            glitch_max_ticks: ticks(sim.glitch_max).max(1),
            glitch_gap_ticks: ticks(sim.glitch_gap),
            rng: StdRng::seed_from_u64(sim.seed),
            glitch: (u64::MAX, u64::MAX),
            burst: Burst::default(),
            present: false,
            flips: false,
            raw: false,
            raw_since: 0,
            candidate: None,
            filtered: false,
            debounce_ticks: ticks(debounce_s).max(1),
            now: 0,
            work: 0,
        }
    }

    /// Is the magnet in the sensor window at this true position?
    pub fn in_window(&self, true_pos: i64) -> bool {
        let mut d = (true_pos - self.sensor_at) * self.home_dir;
        if let Some(p) = self.period {
            d = d.rem_euclid(p as i64);
        }
        (0..self.width as i64).contains(&d)
    }

    /// Starts watching at `tick` with the axis at rest: the levels are whatever the window
    /// says, with no history (the filter has had all the time it needs while idle).
    pub fn resync(&mut self, tick: u64, count: i64, true_pos: i64) {
        self.now = tick;
        self.present = self.in_window(true_pos);
        self.flips = false;
        self.burst = Burst::default();
        self.raw = self.present;
        self.filtered = self.present;
        self.raw_since = tick;
        self.candidate = None;
        let _ = count;
        self.glitch = (u64::MAX, u64::MAX);
        self.schedule_glitch(tick);
    }

    pub fn filtered(&self) -> bool {
        self.filtered
    }

    fn schedule_glitch(&mut self, after: u64) {
        if let Some(gap) = self.glitch_mean_gap {
            // Exponential gaps (a Poisson process of glitches); lengths up to glitch_max.
            let u: f64 = self.rng.gen_range(f64::EPSILON..1.0);
            let quiet = self
                .glitch_gap_ticks
                .saturating_add((-u.ln() * gap) as u64)
                .saturating_add(1);
            let start = after.saturating_add(quiet);
            let len = self.rng.gen_range(1..=self.glitch_max_ticks);
            self.glitch = (start, start.saturating_add(len));
        }
    }

    fn next_noise_event(&self) -> u64 {
        let g = if self.flips_glitch_active() {
            self.glitch.1
        } else {
            self.glitch.0
        };
        g.min(self.burst.next.unwrap_or(u64::MAX))
    }

    fn flips_glitch_active(&self) -> bool {
        self.glitch.0 <= self.now && self.now < self.glitch.1
    }

    fn level(&self) -> bool {
        self.present ^ self.flips_glitch_active() ^ self.flips
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
        let lvl = self.level();
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
            let next = self.next_noise_event();
            if next > until {
                break;
            }
            // A confirmation due before the next noise event comes first.
            if let Some(ev) = self.check_filter(next) {
                return Some(ev);
            }
            self.now = next;
            self.work += 1;
            // Toggles on the same tick cancel in pairs; the level is looked at once.
            while self.burst.next == Some(next) {
                self.flips = !self.flips;
                self.draw_bounce();
                self.work += 1;
            }
            if self.glitch.1 == next {
                self.schedule_glitch(next);
            }
            if let Some(ev) = self.apply_level(next, count, true_pos) {
                return Some(ev);
            }
        }
        self.now = self.now.max(until);
        self.check_filter(until)
    }

    /// The next bounce toggle: the smallest of `left` uniform times in (at, end] is
    /// at + (end − at)·(1 − u^(1/left)) (order statistics), drawn without storing the rest.
    fn draw_bounce(&mut self) {
        let b = &mut self.burst;
        if b.left == 0 {
            b.next = None;
            return;
        }
        let u: f64 = self.rng.gen_range(f64::EPSILON..1.0);
        let x = b.at + (b.end - b.at) * (1.0 - u.powf(1.0 / b.left as f64));
        b.left -= 1;
        b.at = x.clamp(b.at, b.end);
        let floor = b.next.unwrap_or(0);
        b.next = Some(
            (b.at.ceil() as u64)
                .max(floor)
                .min((b.end as u64).max(floor)),
        );
    }

    /// The axis steps at `tick` to `true_pos` (call `advance(tick, …)` first).
    pub fn step(&mut self, tick: u64, count: i64, true_pos: i64) -> Option<FilteredEdge> {
        self.now = tick;
        let present = self.in_window(true_pos);
        if present != self.present {
            self.present = present;
            // Contact bounce: an even number of extra toggles soon after the real edge.
            // A new edge ends the bounce of the previous one.
            self.flips = false;
            self.burst = Burst::default();
            if self.bounce_count > 0 && self.bounce_ticks > 0 {
                let pairs = self.rng.gen_range(0..=self.bounce_count) as u64;
                self.burst = Burst {
                    next: Some(tick + 1),
                    left: 2 * pairs,
                    at: tick as f64,
                    end: tick.saturating_add(self.bounce_ticks) as f64,
                };
                self.draw_bounce();
            }
        }
        self.apply_level(tick, count, true_pos)
    }
}

#[cfg(test)]
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
