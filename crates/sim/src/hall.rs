//! A simulated Hall sensor at a mechanical position (seed 002 §2.3: the sensor marks the
//! mechanical zero), with its disturbances: the raw level is `magnet present XOR noise
//! glitch XOR contact bounce`. No filtering here: whoever reads the sensor (the
//! controller's simulated board, or the FPGA board's debounce in the loop) filters it.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Where the sensor is and how it misbehaves, in microsteps and clock ticks.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorSettings {
    /// True (mechanical) position of the sensor edge met when moving in `home_dir`.
    pub sensor_at: i64,
    /// Width of the active window (microsteps).
    pub width: u64,
    /// +1 or −1: the window lies from `sensor_at` on in this direction.
    pub home_dir: i8,
    /// A periodic axis's period (microsteps): the window repeats.
    pub period: Option<u64>,
    /// Up to this many pairs of extra toggles after each real edge…
    pub bounce_count: u32,
    /// …all within this many ticks of the edge.
    pub bounce_ticks: u64,
    /// Mean ticks between noise glitches (none: no glitches).
    pub glitch_mean_gap: Option<f64>,
    /// Longest glitch (ticks, at least 1).
    pub glitch_max_ticks: u64,
    /// Shortest quiet time between glitches (ticks).
    pub glitch_gap_ticks: u64,
    /// Seed of the glitch and bounce generator.
    pub seed: u64,
}

impl SensorSettings {
    /// From the settings in seconds (`bounce_time`, `glitch_max`, `glitch_gap`, glitches
    /// per second) on a `clock_hz` clock.
    #[allow(clippy::too_many_arguments)]
    pub fn from_seconds(
        sensor_at: i64,
        width: u64,
        home_dir: i8,
        period: Option<u64>,
        bounce_count: u32,
        bounce_time: f64,
        glitch_rate: f64,
        glitch_max: f64,
        glitch_gap: f64,
        seed: u64,
        clock_hz: f64,
    ) -> SensorSettings {
        let ticks = |s: f64| (s * clock_hz).round().max(0.0) as u64;
        SensorSettings {
            sensor_at,
            width,
            home_dir,
            period,
            bounce_count,
            bounce_ticks: ticks(bounce_time),
            glitch_mean_gap: (glitch_rate > 0.0).then(|| clock_hz / glitch_rate),
            glitch_max_ticks: ticks(glitch_max).max(1),
            glitch_gap_ticks: ticks(glitch_gap),
            seed,
        }
    }
}

/// The sensor's raw output over time.
#[derive(Clone, Debug)]
pub struct HallSensor {
    s: SensorSettings,
    rng: StdRng,
    /// The glitch in progress or next to come, as [start, end) ticks.
    glitch: (u64, u64),
    burst: Burst,
    present: bool,
    flips: bool,
    now: u64,
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

impl HallSensor {
    pub fn new(s: &SensorSettings) -> HallSensor {
        HallSensor {
            rng: StdRng::seed_from_u64(s.seed),
            s: s.clone(),
            glitch: (u64::MAX, u64::MAX),
            burst: Burst::default(),
            present: false,
            flips: false,
            now: 0,
        }
    }

    /// Is the magnet in the sensor window at this true position?
    pub fn in_window(&self, true_pos: i64) -> bool {
        // saturating: any position is an answer, never an overflow
        let mut d = true_pos
            .saturating_sub(self.s.sensor_at)
            .saturating_mul(i64::from(self.s.home_dir));
        if let Some(p) = self.s.period {
            d = d.rem_euclid((p as i64).max(1));
        }
        (0..self.s.width as i64).contains(&d)
    }

    /// Starts at `tick` with the magnet at `true_pos`, no bounce, the next glitch drawn.
    pub fn resync(&mut self, tick: u64, true_pos: i64) {
        self.now = tick;
        self.present = self.in_window(true_pos);
        self.flips = false;
        self.burst = Burst::default();
        self.glitch = (u64::MAX, u64::MAX);
        self.schedule_glitch(tick);
    }

    fn schedule_glitch(&mut self, after: u64) {
        if let Some(gap) = self.s.glitch_mean_gap {
            // Exponential gaps (a Poisson process of glitches); lengths up to glitch_max.
            let u: f64 = self.rng.gen_range(f64::EPSILON..1.0);
            let quiet = self
                .s
                .glitch_gap_ticks
                .saturating_add((-u.ln() * gap) as u64)
                .saturating_add(1);
            let start = after.saturating_add(quiet);
            let len = self.rng.gen_range(1..=self.s.glitch_max_ticks);
            self.glitch = (start, start.saturating_add(len));
        }
    }

    /// A glitch of `len` ticks from `tick` on, replacing the one scheduled.
    pub fn glitch_now(&mut self, tick: u64, len: u64) {
        self.now = self.now.max(tick);
        self.glitch = (tick, tick.saturating_add(len.max(1)));
    }

    /// The tick of the next level change from noise (a glitch's start or end, a bounce
    /// toggle); `u64::MAX` for none.
    pub fn next_noise_event(&self) -> u64 {
        let g = if self.glitch_active() {
            self.glitch.1
        } else {
            self.glitch.0
        };
        g.min(self.burst.next.unwrap_or(u64::MAX))
    }

    fn glitch_active(&self) -> bool {
        self.glitch.0 <= self.now && self.now < self.glitch.1
    }

    /// The raw level now.
    pub fn level(&self) -> bool {
        self.present ^ self.glitch_active() ^ self.flips
    }

    /// Handles the noise event at `tick` (from [`Self::next_noise_event`]); returns the
    /// noise events handled (a measure of work).
    pub fn noise_event(&mut self, tick: u64) -> u64 {
        self.now = tick;
        let mut work = 1;
        // Toggles on the same tick cancel in pairs; the level is looked at once.
        while self.burst.next == Some(tick) {
            self.flips = !self.flips;
            self.draw_bounce();
            work += 1;
        }
        if self.glitch.1 == tick {
            self.glitch = (u64::MAX, u64::MAX);
            self.schedule_glitch(tick);
        }
        work
    }

    /// Lets time pass to `tick` with no event on the way.
    pub fn set_time(&mut self, tick: u64) {
        self.now = self.now.max(tick);
    }

    /// The magnet is at `true_pos` from `tick` on: entering or leaving the window starts
    /// a contact bounce (an even number of extra toggles soon after the real edge).
    pub fn move_to(&mut self, tick: u64, true_pos: i64) {
        self.now = tick;
        let present = self.in_window(true_pos);
        if present != self.present {
            self.present = present;
            // A new edge ends the bounce of the previous one.
            self.flips = false;
            self.burst = Burst::default();
            if self.s.bounce_count > 0 && self.s.bounce_ticks > 0 {
                let pairs = self.rng.gen_range(0..=self.s.bounce_count) as u64;
                self.burst = Burst {
                    next: Some(tick + 1),
                    left: 2 * pairs,
                    at: tick as f64,
                    end: tick.saturating_add(self.s.bounce_ticks) as f64,
                };
                self.draw_bounce();
            }
        }
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
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(home_dir: i8, period: Option<u64>) -> SensorSettings {
        SensorSettings::from_seconds(
            100, 50, home_dir, period, 0, 0.0002, 0.0, 0.0005, 0.005, 1, 1e6,
        )
    }

    #[test]
    fn window_follows_home_direction_and_period() {
        let h = HallSensor::new(&settings(-1, None));
        assert!(h.in_window(100) && h.in_window(51) && !h.in_window(50) && !h.in_window(101));
        let h = HallSensor::new(&settings(1, None));
        assert!(h.in_window(100) && h.in_window(149) && !h.in_window(150) && !h.in_window(99));
        let h = HallSensor::new(&settings(1, Some(1000)));
        assert!(h.in_window(1100) && h.in_window(-900) && !h.in_window(1099));
        for h in [settings(1, None), settings(-1, Some(1000))].map(|s| HallSensor::new(&s)) {
            // the extremes answer, never overflow
            let _ = (h.in_window(i64::MIN), h.in_window(i64::MAX));
        }
    }

    #[test]
    fn a_glitch_flips_the_level_for_its_length() {
        let mut h = HallSensor::new(&settings(1, None));
        h.resync(0, 0);
        assert!(!h.level());
        assert_eq!(h.next_noise_event(), u64::MAX, "no glitch rate, no bounce");
        h.glitch_now(10, 5);
        assert!(h.level());
        assert_eq!(h.next_noise_event(), 15);
        h.noise_event(15);
        assert!(!h.level());
        assert_eq!(
            h.next_noise_event(),
            u64::MAX,
            "an injected glitch leaves nothing behind"
        );
        h.move_to(20, 120);
        assert!(h.level(), "in the window");
    }
}
