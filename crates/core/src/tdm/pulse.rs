//! The pulse unit of one axis: a counter of the ticks since one period was loaded.
//!
//! Loading period j at tick `load` makes STEP rise at `load + period_j` (the step's edge
//! tick). On time, `load` is the previous edge (or the group's start tick for step 1), so
//! rises land exactly on the planned edges. After an underrun the period is loaded when it
//! arrives, so that edge — and every later one of the axis — is late by the delay; the
//! engine counts and reports it.
//!
//! Falling edge: by default STEP falls half a period (at least one tick) after that period
//! was loaded, so on time it is high for half of the interval to the next edge (seed 000's
//! 50 % duty PWM); the last pulse of a move takes half of its own period. While an
//! underrun delays the next period, the line stays high until it arrives and falls half
//! the late period after that: the line is low for the second half of every period,
//! however long the wait. With a fixed width the line is high for exactly that many ticks.
//! A pulse whose fall is not before the next rise (no low time: a driver would see one step
//! instead of two) is counted as merged.

pub use crate::step_dir::PulseShape;
use core::num::NonZeroU64;

/// One STEP pulse as it leaves the board; ticks count from the board's tick 0 (when the
/// move is loaded and DIR is set).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepPulse {
    pub axis: usize,
    /// 1-based step number.
    pub step: u64,
    pub rise: u64,
    pub fall: u64,
}

#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PulseUnit {
    shape: PulseShape,
    /// Pulses started so far; the last one is still open (its fall not yet known).
    steps: u64,
    start: u64,
    /// Tick the last period was loaded: the previous rise on time, later after an underrun.
    last_load: u64,
    last_rise: u64,
    merged: u64,
    /// `steps` when `last_load` and `last_rise` were last written: the loads after it
    /// were [`load_kept`](Self::load_kept) ones, whose rises the caller keeps.
    kept_from: u64,
}

impl PulseUnit {
    pub fn new(shape: PulseShape) -> PulseUnit {
        PulseUnit {
            shape,
            ..PulseUnit::default()
        }
    }

    /// Tick at which period 1 was loaded (the axis's start).
    pub fn start_tick(&self) -> u64 {
        self.start
    }

    /// Periods loaded so far.
    #[inline]
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Pulses with no low time before the next rise.
    pub fn merged(&self) -> u64 {
        self.merged
    }

    /// Loads the next period at tick `load`; returns the tick STEP rises. Closes the
    /// previous pulse, whose fall depends on this one, and hands it to `sink`.
    #[inline]
    pub fn load<F: FnMut(StepPulse)>(
        &mut self,
        axis: usize,
        load: u64,
        period: u64,
        sink: &mut F,
    ) -> u64 {
        let rise = load + period;
        if self.steps == 0 {
            self.start = load;
            self.last_rise = load;
        } else {
            let fall = match self.shape {
                PulseShape::HalfInterval => load + (period / 2).max(1),
                PulseShape::Fixed { ticks } => self.last_rise + ticks,
            };
            if fall >= rise {
                self.merged += 1;
            }
            sink(StepPulse {
                axis,
                step: self.steps,
                rise: self.last_rise,
                fall,
            });
        }
        self.steps += 1;
        self.last_load = load;
        self.last_rise = rise;
        self.kept_from = self.steps;
        rise
    }

    /// [`load`](Self::load) of a period that arrived in time, after period 1: it is loaded
    /// at the previous rise, so the previous pulse falls half the period later (at least
    /// one tick) and merges only when the period is at most one tick. The same result as
    /// `load(axis, last rise, period, sink)` without its first-period and late-load cases.
    /// `last` is the last rise, which the caller holds already (a load fewer).
    #[inline]
    pub fn load_on_time<F: FnMut(StepPulse)>(
        &mut self,
        axis: usize,
        last: u64,
        period: u64,
        sink: &mut F,
    ) -> u64 {
        debug_assert_eq!(last, self.last_rise);
        self.load_kept::<false, F>(axis, last, period, sink);
        let rise = last + period;
        self.last_load = last;
        self.last_rise = rise;
        self.kept_from = self.steps;
        rise
    }

    /// [`load_on_time`](Self::load_on_time) for a caller that keeps the rises
    /// itself (the engine holds the last rise, which it knows to be `last + period`, and
    /// its FIFO each load tick): the count alone is stored, two stores fewer per period.
    /// `HALF`: the caller knows the shape is [`PulseShape::HalfInterval`], so the shape is
    /// not tested (the engine's loop is compiled per shape).
    /// Before any other load and before [`finish`](Self::finish), hand the rises back by
    /// [`resume`](Self::resume).
    #[inline]
    pub(crate) fn load_kept<const HALF: bool, F: FnMut(StepPulse)>(
        &mut self,
        axis: usize,
        last: u64,
        period: u64,
        sink: &mut F,
    ) {
        debug_assert!(self.steps > 0);
        debug_assert!(!HALF || self.shape == PulseShape::HalfInterval);
        let shape = if HALF {
            PulseShape::HalfInterval
        } else {
            self.shape
        };
        // merging is rare (a period of one tick or a wide fixed pulse): a branch, not an
        // add; half a period of 0 both merges and widens the pulse to one tick
        let fall = match shape {
            // as a NonZeroU64 the usual arm falls through (tested as `half == 0` or
            // `half != 0`, it took one jump more per period)
            PulseShape::HalfInterval => match NonZeroU64::new(period / 2) {
                Some(half) => last + half.get(),
                None => {
                    self.merged += 1;
                    last + 1
                }
            },
            PulseShape::Fixed { ticks } => {
                if ticks >= period {
                    self.merged += 1;
                }
                last + ticks
            }
        };
        sink(StepPulse {
            axis,
            step: self.steps,
            rise: last,
            fall,
        });
        self.steps += 1;
    }

    /// After [`load_kept`](Self::load_kept) loads: `last` is the last rise and `loaded`
    /// the tick the last period was loaded (the previous rise). Nothing to do if the last
    /// load was another kind.
    #[inline]
    pub(crate) fn resume(&mut self, last: u64, loaded: u64) {
        if self.steps != self.kept_from {
            self.last_load = loaded;
            self.last_rise = last;
            self.kept_from = self.steps;
        }
    }

    /// Tick of the last rise.
    #[inline]
    pub fn last_rise(&self) -> u64 {
        self.last_rise
    }

    /// Closes the last pulse of the move.
    pub fn finish<F: FnMut(StepPulse)>(&mut self, axis: usize, sink: &mut F) {
        if self.steps == 0 {
            return;
        }
        let high = match self.shape {
            PulseShape::HalfInterval => ((self.last_rise - self.last_load) / 2).max(1),
            PulseShape::Fixed { ticks } => ticks,
        };
        sink(StepPulse {
            axis,
            step: self.steps,
            rise: self.last_rise,
            fall: self.last_rise + high,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn play(shape: PulseShape, loads: &[(u64, u64)]) -> (Vec<StepPulse>, u64) {
        let mut u = PulseUnit::new(shape);
        let mut out = Vec::new();
        let mut sink = |p| out.push(p);
        for &(load, period) in loads {
            u.load(3, load, period, &mut sink);
        }
        u.finish(3, &mut sink);
        (out, u.merged())
    }

    #[test]
    fn half_interval_duty_on_time() {
        // start at 10; periods 100, 60, 41 loaded on time
        let (p, merged) = play(PulseShape::HalfInterval, &[(10, 100), (110, 60), (170, 41)]);
        let want = [(1, 110, 140), (2, 170, 190), (3, 211, 231)];
        assert_eq!(p.len(), 3);
        for (got, (step, rise, fall)) in p.iter().zip(want) {
            assert_eq!(
                (got.axis, got.step, got.rise, got.fall),
                (3, step, rise, fall)
            );
        }
        assert_eq!(merged, 0);
    }

    #[test]
    fn late_period_shifts_the_next_edge_and_holds_the_line_high() {
        // period 2 arrives 500 ticks after edge 1 (tick 110): edge 2 at 610 + 60; pulse 1
        // falls half of period 2 after its arrival, pulse 2 half of period 2 after its rise
        let (p, _) = play(PulseShape::HalfInterval, &[(10, 100), (610, 60)]);
        assert_eq!((p[0].rise, p[0].fall), (110, 640));
        assert_eq!((p[1].rise, p[1].fall), (670, 700));
        // a late period of one tick: no low time before its edge
        let (p, merged) = play(PulseShape::HalfInterval, &[(0, 10), (50, 1), (51, 4)]);
        assert_eq!((p[0].fall, p[1].rise, p[1].fall), (51, 51, 53));
        assert_eq!(merged, 1);
    }

    /// The in-time path against the general one, for both shapes, periods of 0, 1, 2 ticks
    /// (merged or not) and longer.
    #[test]
    fn load_on_time_equals_load_at_the_previous_rise() {
        for shape in [
            PulseShape::HalfInterval,
            PulseShape::Fixed { ticks: 1 },
            PulseShape::Fixed { ticks: 3 },
        ] {
            let (mut general, mut fast) = (PulseUnit::new(shape), PulseUnit::new(shape));
            let (mut a, mut b) = (Vec::new(), Vec::new());
            general.load(2, 40, 7, &mut |p| a.push(p));
            fast.load(2, 40, 7, &mut |p| b.push(p));
            for period in [0u64, 1, 2, 3, 4, 5, 1000, 1, 0, 2] {
                let load = general.last_rise;
                let want = general.load(2, load, period, &mut |p| a.push(p));
                let last = fast.last_rise();
                assert_eq!(fast.load_on_time(2, last, period, &mut |p| b.push(p)), want);
                assert_eq!(fast, general, "{shape:?}, period {period}");
            }
            assert_eq!(a, b, "{shape:?}");
            assert!(general.merged() > 0, "{shape:?}: merged pulses are covered");
        }
    }

    /// In-time loads whose rises the caller keeps, handed back before `finish`: the same
    /// pulses and the same unit as general loads.
    #[test]
    fn kept_loads_resume_to_the_general_unit() {
        for shape in [PulseShape::HalfInterval, PulseShape::Fixed { ticks: 3 }] {
            let (mut general, mut kept) = (PulseUnit::new(shape), PulseUnit::new(shape));
            let (mut a, mut b) = (Vec::new(), Vec::new());
            general.load(2, 40, 7, &mut |p| a.push(p));
            let mut rises = std::vec![kept.load(2, 40, 7, &mut |p| b.push(p))];
            for period in [0u64, 1, 2, 3, 1000, 5] {
                let load = general.last_rise;
                general.load(2, load, period, &mut |p| a.push(p));
                let last = rises[rises.len() - 1];
                kept.load_kept::<false, _>(2, last, period, &mut |p| b.push(p));
                rises.push(last + period);
            }
            // the last period was loaded at the rise before the last
            kept.resume(rises[rises.len() - 1], rises[rises.len() - 2]);
            assert_eq!(kept, general, "{shape:?}");
            // nothing to hand back after a general load
            kept.resume(0, 0);
            assert_eq!(kept, general, "{shape:?}");
            general.finish(2, &mut |p| a.push(p));
            kept.finish(2, &mut |p| b.push(p));
            assert_eq!(a, b, "{shape:?}");
        }
    }

    #[test]
    fn fixed_width_and_merged_pulses() {
        let (p, merged) = play(
            PulseShape::Fixed { ticks: 5 },
            &[(0, 100), (100, 4), (104, 50)],
        );
        assert_eq!((p[0].rise, p[0].fall), (100, 105));
        assert_eq!((p[1].rise, p[1].fall), (104, 109));
        assert_eq!(merged, 1, "pulse 1 is still high when pulse 2 rises");
    }
}
