//! One axis of the world around the board: STEP / DIR / ENABLE drive a simulated motor
//! (`multistep_sim::integrate::Incremental`), and the Hall input comes from a simulated
//! sensor (`multistep_sim::hall::HallSensor`) at the mechanics' position.

use multistep_sim::hall::{HallSensor, SensorSettings};
use multistep_sim::integrate::Incremental;
use serde::Serialize;

/// A motor counts as moving this long after its last STEP (s): the rotor settles.
pub const SETTLE_S: f64 = 0.02;

/// How an axis's driver reads its DIR and ENABLE pins (the controller's `invert_dir` and
/// `enable_active_high`); the default is the board's reset levels (all active high).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PinLevels {
    pub invert_dir: bool,
    pub enable_active_high: bool,
}

impl Default for PinLevels {
    fn default() -> Self {
        PinLevels {
            invert_dir: false,
            enable_active_high: true,
        }
    }
}

/// What `state` reports of one axis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AxisReport {
    /// STEP rises seen on the pin (ENABLE on or off).
    pub step_rises: u64,
    /// The mechanics' position (microsteps): the rotor plus every slip.
    pub position: f64,
    /// The motor's commanded position: the STEPs it took while energized, ± by DIR.
    pub commanded: i64,
    /// ENABLE and DIR as the driver reads them (the pins through [`PinLevels`]).
    pub enable: bool,
    pub dir: bool,
    /// The Hall input's level (the sensor's raw output).
    pub hall: bool,
}

pub struct SimAxis {
    motor: Incremental,
    sensor: HallSensor,
    clock_hz: f64,
    pub step_rises: u64,
    /// Microsteps the mechanics slipped against the rotor.
    slip: i64,
    pub enable: bool,
    pub dir: bool,
    levels: PinLevels,
    /// The motor moves (or settles) until this cycle.
    live_until: u64,
    /// An injected glitch runs until this cycle.
    pub glitch_until: u64,
}

impl SimAxis {
    pub fn new(
        motor: Incremental,
        sensor: &SensorSettings,
        levels: PinLevels,
        clock_hz: f64,
    ) -> SimAxis {
        let mut sensor = HallSensor::new(sensor);
        sensor.resync(0, 0);
        SimAxis {
            motor,
            sensor,
            clock_hz,
            step_rises: 0,
            slip: 0,
            enable: false,
            dir: false,
            levels,
            live_until: 0,
            glitch_until: 0,
        }
    }

    /// The mechanics' position (microsteps).
    pub fn position(&self) -> f64 {
        self.motor.rotor_microsteps() + self.slip as f64
    }

    /// The whole microstep the sensor sees.
    fn sensor_pos(&self) -> i64 {
        self.position().round() as i64
    }

    /// The DIR and ENABLE pins' levels, read as the driver is wired.
    pub fn pins(&mut self, dir: bool, enable: bool) {
        self.dir = dir != self.levels.invert_dir;
        self.enable = enable == self.levels.enable_active_high;
    }

    pub fn hall(&self) -> bool {
        self.sensor.level()
    }

    /// A STEP rise at `cycle`.
    pub fn step(&mut self, cycle: u64) {
        self.step_rises += 1;
        if self.enable {
            if cycle >= self.live_until {
                self.motor.rest_to(cycle);
            }
            // ticks never go back and one axis's rises are at least two cycles apart
            let _ = self.motor.edge(cycle, self.dir);
            self.live_until = cycle + (SETTLE_S * self.clock_hz) as u64;
        }
    }

    /// Does the motor still move (so the world must be stepped)?
    pub fn live(&self, cycle: u64) -> bool {
        cycle < self.live_until || cycle < self.glitch_until
    }

    /// Brings motor and sensor to `cycle`: the rotor integrated (while energized and
    /// moving) and the sensor's noise events up to it handled.
    pub fn advance(&mut self, cycle: u64) {
        if self.enable && cycle <= self.live_until {
            self.motor.advance_to(cycle);
        }
        while self.sensor.next_noise_event() <= cycle {
            let t = self.sensor.next_noise_event();
            self.sensor.noise_event(t);
        }
        self.sensor.set_time(cycle);
        let p = self.sensor_pos();
        self.sensor.move_to(cycle, p);
    }

    /// The next cycle at which the sensor's noise changes its level.
    pub fn next_noise(&self) -> u64 {
        self.sensor.next_noise_event()
    }

    /// The mechanics jump by `microsteps` (a lost step, a slipping coupling).
    pub fn slip(&mut self, cycle: u64, microsteps: i64) {
        self.slip = self.slip.saturating_add(microsteps);
        let p = self.sensor_pos();
        self.sensor.move_to(cycle, p);
    }

    /// One Hall glitch of `len` cycles from `cycle` on.
    pub fn glitch(&mut self, cycle: u64, len: u64) {
        self.sensor.glitch_now(cycle, len);
        self.glitch_until = cycle + len + 1;
    }

    pub fn report(&self) -> AxisReport {
        AxisReport {
            step_rises: self.step_rises,
            position: self.position(),
            commanded: self.motor.commanded(),
            enable: self.enable,
            dir: self.dir,
            hall: self.hall(),
        }
    }
}
