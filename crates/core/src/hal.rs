//! A step/direction driver over embedded-hal 1.0 [`OutputPin`]s that plays an edge stream
//! (DESIGN.md §1): DIR is set first and held for a setup time, then STEP rises at each
//! edge tick and falls after half the interval to the next edge (50 % duty, as in seed
//! 000) or after a fixed width.
//!
//! Timing comes from a [`TickTimer`] of the caller's on the same clock as the edges (a
//! free-running hardware counter, a cycle counter, …).

use embedded_hal::digital::OutputPin;

/// A monotonic tick counter on the edge stream's clock.
pub trait TickTimer {
    /// The current tick.
    fn now(&mut self) -> u64;
    /// Returns once `now() >= tick` (at once if already past).
    fn wait_until(&mut self, tick: u64);
}

/// How long STEP stays high.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PulseWidth {
    /// Half of the interval to the next edge (the last pulse: half the previous interval).
    HalfPeriod,
    /// A fixed number of ticks, cut short if the next edge comes first.
    Ticks(u64),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriverConfig {
    /// Ticks between setting DIR and tick 0 of the move.
    pub dir_setup_ticks: u64,
    pub pulse: PulseWidth,
    /// DIR level for forward moves.
    pub forward_is_high: bool,
}

impl Default for DriverConfig {
    fn default() -> Self {
        DriverConfig {
            dir_setup_ticks: 0,
            pulse: PulseWidth::HalfPeriod,
            forward_is_high: true,
        }
    }
}

/// A pin refused a level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveError<S, D> {
    Step(S),
    Dir(D),
}

impl<S: core::fmt::Debug, D: core::fmt::Debug> core::fmt::Display for DriveError<S, D> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DriveError::Step(e) => write!(f, "STEP pin error: {e:?}"),
            DriveError::Dir(e) => write!(f, "DIR pin error: {e:?}"),
        }
    }
}

/// What one move did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Played {
    pub steps: u64,
    /// Edges whose tick had already passed when the driver got to them (it rises at once).
    pub late: u64,
    /// Absolute tick of tick 0 of the move.
    pub start: u64,
}

/// STEP and DIR outputs and a timer.
pub struct StepDir<S, D, T> {
    step: S,
    dir: D,
    timer: T,
    cfg: DriverConfig,
}

impl<S: OutputPin, D: OutputPin, T: TickTimer> StepDir<S, D, T> {
    pub fn new(step: S, dir: D, timer: T, cfg: DriverConfig) -> Self {
        StepDir {
            step,
            dir,
            timer,
            cfg,
        }
    }

    /// Gives the pins and the timer back.
    pub fn release(self) -> (S, D, T) {
        (self.step, self.dir, self.timer)
    }

    /// Plays one move: `edges` are ticks from the move's start (non-decreasing, e.g. an
    /// [`EdgeGenerator`](crate::EdgeGenerator) or [`IntEdgeGenerator`](crate::int::IntEdgeGenerator)).
    /// STEP is left low.
    pub fn play(
        &mut self,
        forward: bool,
        edges: impl IntoIterator<Item = u64>,
    ) -> Result<Played, DriveError<S::Error, D::Error>> {
        let level = forward == self.cfg.forward_is_high;
        if level {
            self.dir.set_high().map_err(DriveError::Dir)?;
        } else {
            self.dir.set_low().map_err(DriveError::Dir)?;
        }
        let start = self.timer.now().saturating_add(self.cfg.dir_setup_ticks);
        self.timer.wait_until(start);
        let mut out = Played {
            start,
            ..Played::default()
        };
        let mut edges = edges.into_iter().peekable();
        let mut prev = 0u64;
        while let Some(e) = edges.next() {
            let rise = start.saturating_add(e);
            if self.timer.now() > rise {
                out.late += 1;
            }
            self.timer.wait_until(rise);
            self.step.set_high().map_err(DriveError::Step)?;
            let next = edges.peek().copied();
            let width = match (self.cfg.pulse, next) {
                (PulseWidth::HalfPeriod, Some(n)) => n.saturating_sub(e) / 2,
                (PulseWidth::HalfPeriod, None) => e.saturating_sub(prev) / 2,
                (PulseWidth::Ticks(w), Some(n)) => w.min(n.saturating_sub(e)),
                (PulseWidth::Ticks(w), None) => w,
            };
            self.timer.wait_until(rise.saturating_add(width));
            self.step.set_low().map_err(DriveError::Step)?;
            out.steps += 1;
            prev = e;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::int::{IntClock, IntEdgeGenerator, IntPhaseMove, IntProfile};
    use embedded_hal_mock::eh1::digital::{Mock, State, Transaction as T};
    use embedded_hal_mock::eh1::MockError;
    use std::vec::Vec;

    /// A timer that jumps to every tick it is asked to wait for, and logs the waits.
    struct Recorder {
        now: u64,
        waits: Vec<u64>,
    }

    impl TickTimer for Recorder {
        fn now(&mut self) -> u64 {
            self.now
        }
        fn wait_until(&mut self, tick: u64) {
            self.waits.push(tick);
            self.now = self.now.max(tick);
        }
    }

    fn pulses(n: usize) -> Vec<T> {
        (0..n)
            .flat_map(|_| [T::set(State::High), T::set(State::Low)])
            .collect()
    }

    #[test]
    fn plays_a_planned_move_with_half_period_pulses() {
        // 6 steps from the integer generator at 1 kHz
        let m = IntPhaseMove {
            steps: 6,
            accel_ticks: 40,
            cruise_ticks: 20,
            decel_ticks: 40,
            ..Default::default()
        };
        let edges: Vec<u64> =
            IntEdgeGenerator::new(IntProfile::phase(&m, IntClock::hz(1000)).unwrap()).collect();
        let step = Mock::new(&pulses(6));
        let dir = Mock::new(&[T::set(State::High)]);
        let timer = Recorder {
            now: 1000,
            waits: Vec::new(),
        };
        let cfg = DriverConfig {
            dir_setup_ticks: 5,
            ..DriverConfig::default()
        };
        let mut d = StepDir::new(step, dir, timer, cfg);
        let played = d.play(true, edges.iter().copied()).unwrap();
        assert_eq!(
            played,
            Played {
                steps: 6,
                late: 0,
                start: 1005
            }
        );
        let (mut step, mut dir, timer) = d.release();
        step.done();
        dir.done();
        // setup, then (rise, fall) per edge: falls halfway to the next edge
        let mut want = std::vec![1005];
        for (k, &e) in edges.iter().enumerate() {
            let next = edges.get(k + 1).copied();
            let prev = if k == 0 { 0 } else { edges[k - 1] };
            let w = next.map_or((e - prev) / 2, |n| (n - e) / 2);
            want.extend([1005 + e, 1005 + e + w]);
        }
        assert_eq!(timer.waits, want);
        assert_eq!(*edges.last().unwrap(), 100);
    }

    #[test]
    fn fixed_width_is_cut_at_the_next_edge_and_reverse_sets_dir_low() {
        let step = Mock::new(&pulses(3));
        let dir = Mock::new(&[T::set(State::Low)]);
        let cfg = DriverConfig {
            pulse: PulseWidth::Ticks(4),
            ..DriverConfig::default()
        };
        let mut d = StepDir::new(
            step,
            dir,
            Recorder {
                now: 0,
                waits: Vec::new(),
            },
            cfg,
        );
        let played = d.play(false, [10, 12, 30]).unwrap();
        assert_eq!(played.steps, 3);
        let (mut step, mut dir, timer) = d.release();
        step.done();
        dir.done();
        assert_eq!(timer.waits, [0, 10, 12, 12, 16, 30, 34]);
    }

    /// A timer that overshoots every wait by `lag` ticks (a slow loop).
    struct Laggy {
        now: u64,
        lag: u64,
    }

    impl TickTimer for Laggy {
        fn now(&mut self) -> u64 {
            self.now
        }
        fn wait_until(&mut self, tick: u64) {
            self.now = self.now.max(tick) + self.lag;
        }
    }

    #[test]
    fn late_edges_are_counted_and_pin_errors_returned() {
        // each wait overshoots by 15 ticks: edges 0, 10 and 20 come too late, 200 does not
        let step = Mock::new(&pulses(4));
        let dir = Mock::new(&[T::set(State::High)]);
        let mut d = StepDir::new(
            step,
            dir,
            Laggy { now: 0, lag: 15 },
            DriverConfig::default(),
        );
        let played = d.play(true, [0, 10, 20, 200]).unwrap();
        assert_eq!(
            played,
            Played {
                steps: 4,
                late: 3,
                start: 0
            }
        );
        let (mut s, mut dr, _) = d.release();
        s.done();
        dr.done();

        let err = MockError::Io(std::io::ErrorKind::Other);
        let step = Mock::new(&[T::set(State::High).with_error(err.clone())]);
        let dir = Mock::new(&[T::set(State::High)]);
        let timer = Recorder {
            now: 0,
            waits: Vec::new(),
        };
        let mut d = StepDir::new(step, dir, timer, DriverConfig::default());
        assert_eq!(d.play(true, [5]), Err(DriveError::Step(err)));
        let (mut s, mut dr, _) = d.release();
        s.done();
        dr.done();
    }
}
