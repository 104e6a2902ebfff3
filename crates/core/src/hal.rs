//! A step/direction driver over embedded-hal 1.0 [`OutputPin`]s that plays an edge stream
//! (DESIGN.md §1): DIR is set first and held for a setup time, then STEP rises at each
//! edge tick and falls after half the interval to the next edge (50 % duty, as in seed
//! 000) or after a fixed width.
//!
//! Timing comes from a [`TickTimer`] of the caller's (a free-running hardware counter, a
//! cycle counter, …), and the edges are planned on that timer's clock ([`edges_for`]), so
//! the two cannot disagree about what a tick is.
//!
//! Two forms: [`StepDir::play`] drives a whole move, busy-waiting on the timer; a
//! [`Stepper`] is driven from a timer interrupt instead: each [`Stepper::poll`] does what
//! is due and returns the next deadline to arm the timer compare for.

use crate::edges::EdgeGenerator;
use crate::error::PlanError;
use crate::profile::Profile;
use core::borrow::Borrow;
use embedded_hal::digital::OutputPin;

/// A monotonic tick counter; its rate is the clock the edges are planned on.
pub trait TickTimer {
    /// Ticks per second.
    fn hz(&self) -> u32;
    /// The current tick.
    fn now(&mut self) -> u64;
    /// Returns once `now() >= tick` (at once if already past).
    fn wait_until(&mut self, tick: u64);
}

/// The edges of `profile` on `timer`'s clock; pass `&profile` to keep one copy of the
/// pieces (the generator then holds only its own state).
pub fn edges_for<P: Borrow<Profile>, T: TickTimer>(
    profile: P,
    timer: &T,
) -> Result<EdgeGenerator<P>, PlanError> {
    EdgeGenerator::new(profile, f64::from(timer.hz()))
}

pub use crate::step_dir::{PulseShape, StepDirTiming};

/// How the driver sets DIR and shapes STEP.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DriverConfig {
    /// STEP pulse width and DIR setup (the TDM engine's own type).
    pub step_dir: StepDirTiming,
    /// DIR level for forward moves.
    pub forward_is_high: bool,
}

impl Default for DriverConfig {
    fn default() -> Self {
        DriverConfig {
            step_dir: StepDirTiming::default(),
            forward_is_high: true,
        }
    }
}

/// A pin refused a level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DriveError<S, D> {
    /// The STEP pin's error.
    Step(S),
    /// The DIR pin's error.
    Dir(D),
}

impl<S: core::fmt::Debug, D: core::fmt::Debug> core::error::Error for DriveError<S, D> {}

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
    /// Pulses sent.
    pub steps: u64,
    /// Edges whose tick had already passed when the driver got to them (it rises at once).
    pub late: u64,
    /// Absolute tick of tick 0 of the move.
    pub start: u64,
}

/// STEP and DIR outputs and a timer: plays whole moves, busy-waiting.
pub struct StepDir<S, D, T> {
    step: S,
    dir: D,
    timer: T,
    cfg: DriverConfig,
}

impl<S: OutputPin, D: OutputPin, T: TickTimer> StepDir<S, D, T> {
    /// A driver on these pins and timer.
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

    /// The edges of `profile` on this driver's timer clock.
    pub fn edges(&self, profile: Profile) -> Result<EdgeGenerator, PlanError> {
        edges_for(profile, &self.timer)
    }

    /// Plays one move, busy-waiting on the timer: `edges` are ticks from the move's start
    /// (non-decreasing, e.g. an [`EdgeGenerator`] or
    /// [`IntEdgeGenerator`](crate::int::IntEdgeGenerator)). STEP is left low.
    pub fn play(
        &mut self,
        forward: bool,
        edges: impl IntoIterator<Item = u64>,
    ) -> Result<Played, DriveError<S::Error, D::Error>> {
        let now = self.timer.now();
        let mut run = Stepper::start(&mut self.step, &mut self.dir, forward, edges, now, self.cfg)?;
        self.timer.wait_until(run.start_tick());
        // an edge is late if its tick has passed before the driver waits for it; once
        // waited for, it is set as at its deadline
        while let Some(deadline) = run.poll(self.timer.now())? {
            self.timer.wait_until(deadline);
            if run.poll(deadline)?.is_none() {
                break;
            }
        }
        Ok(run.played())
    }
}

/// What the STEP line waits for next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Next {
    /// STEP rises at this tick (the edge, relative to the start, alongside).
    Rise {
        at: u64,
        edge: u64,
    },
    /// STEP falls at this tick.
    Fall {
        at: u64,
    },
    Done,
}

/// One move driven from a timer interrupt: [`start`](Stepper::start) sets DIR, then every
/// [`poll`](Stepper::poll) at the current tick sets the pins that are due and returns the
/// next deadline. Nothing blocks; the edges are pulled one at a time (O(1) memory).
pub struct Stepper<S, D, E: Iterator<Item = u64>> {
    step: S,
    dir: D,
    edges: core::iter::Peekable<E>,
    pulse: PulseShape,
    start: u64,
    prev: u64,
    next: Next,
    out: Played,
}

impl<S: OutputPin, D: OutputPin, E: Iterator<Item = u64>> Stepper<S, D, E> {
    /// Sets DIR for the move and schedules it: tick 0 of the move is `now` plus the DIR
    /// setup time. `step` and `dir` may be pins or `&mut` pins.
    pub fn start(
        step: S,
        mut dir: D,
        forward: bool,
        edges: impl IntoIterator<IntoIter = E>,
        now: u64,
        cfg: DriverConfig,
    ) -> Result<Self, DriveError<S::Error, D::Error>> {
        if forward == cfg.forward_is_high {
            dir.set_high().map_err(DriveError::Dir)?;
        } else {
            dir.set_low().map_err(DriveError::Dir)?;
        }
        let start = now.saturating_add(cfg.step_dir.dir_setup_ticks);
        let mut edges = edges.into_iter().peekable();
        let next = match edges.next() {
            Some(e) => Next::Rise {
                at: start.saturating_add(e),
                edge: e,
            },
            None => Next::Done,
        };
        Ok(Stepper {
            step,
            dir,
            edges,
            pulse: cfg.step_dir.pulse,
            start,
            prev: 0,
            next,
            out: Played {
                start,
                ..Played::default()
            },
        })
    }

    /// Absolute tick of tick 0 of the move.
    pub fn start_tick(&self) -> u64 {
        self.start
    }

    /// Sets whatever is due at `now` (a rise, a fall, or both when they coincide) and
    /// returns the next deadline, or `None` once the move is done (STEP low). An edge
    /// whose tick has passed rises at once and is counted as late.
    pub fn poll(&mut self, now: u64) -> Result<Option<u64>, DriveError<S::Error, D::Error>> {
        loop {
            match self.next {
                Next::Done => return Ok(None),
                Next::Rise { at, .. } | Next::Fall { at } if now < at => return Ok(Some(at)),
                Next::Rise { at, edge } => {
                    if now > at {
                        self.out.late += 1;
                    }
                    self.step.set_high().map_err(DriveError::Step)?;
                    let next = self.edges.peek().copied();
                    let width = match (self.pulse, next) {
                        (PulseShape::HalfInterval, Some(n)) => (n.saturating_sub(edge) / 2).max(1),
                        (PulseShape::HalfInterval, None) => {
                            (edge.saturating_sub(self.prev) / 2).max(1)
                        }
                        (PulseShape::Fixed { ticks }, _) => ticks,
                    };
                    // cut at the next rise: the line must be low before it can rise again
                    let width = next.map_or(width, |n| width.min(n.saturating_sub(edge)));
                    // a late rise keeps its width from when it actually rose
                    self.next = Next::Fall {
                        at: at.max(now).saturating_add(width),
                    };
                    self.prev = edge;
                }
                Next::Fall { .. } => {
                    self.step.set_low().map_err(DriveError::Step)?;
                    self.out.steps += 1;
                    self.next = match self.edges.next() {
                        Some(e) => Next::Rise {
                            at: self.start.saturating_add(e),
                            edge: e,
                        },
                        None => Next::Done,
                    };
                }
            }
        }
    }

    /// What the move has done so far.
    pub fn played(&self) -> Played {
        self.out
    }

    /// Gives the pins back.
    pub fn release(self) -> (S, D) {
        (self.step, self.dir)
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
        fn hz(&self) -> u32 {
            1000
        }
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
            step_dir: StepDirTiming {
                dir_setup_ticks: 5,
                ..StepDirTiming::default()
            },
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
            step_dir: StepDirTiming {
                pulse: PulseShape::Fixed { ticks: 4 },
                ..StepDirTiming::default()
            },
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
        // the fall cut at 12 and the next rise at 12 are one wait
        assert_eq!(timer.waits, [0, 10, 12, 16, 30, 34]);
    }

    /// A timer that overshoots every wait by `lag` ticks (a slow loop).
    struct Laggy {
        now: u64,
        lag: u64,
    }

    impl TickTimer for Laggy {
        fn hz(&self) -> u32 {
            1000
        }
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

    #[test]
    fn poll_form_returns_each_deadline_and_sets_the_pins_due() {
        // an interrupt handler that runs at each deadline it is given, late by `lag` ticks
        for lag in [0u64, 3] {
            let step = Mock::new(&pulses(3));
            let dir = Mock::new(&[T::set(State::High)]);
            let cfg = DriverConfig {
                step_dir: StepDirTiming {
                    dir_setup_ticks: 7,
                    ..StepDirTiming::default()
                },
                ..DriverConfig::default()
            };
            let mut s = Stepper::start(step, dir, true, [10u64, 20, 40], 100, cfg).unwrap();
            assert_eq!(s.start_tick(), 107);
            let mut deadlines = Vec::new();
            let mut now = 100;
            while let Some(d) = s.poll(now).unwrap() {
                assert!(d > now, "a deadline is in the future");
                deadlines.push(d);
                now = d + lag;
            }
            let p = s.played();
            assert_eq!((p.steps, p.start), (3, 107));
            if lag == 0 {
                // rises at 107 + e, falls halfway to the next edge (the last: half its own)
                assert_eq!(deadlines, [117, 122, 127, 137, 147, 157]);
                assert_eq!(p.late, 0);
            } else {
                assert_eq!(p.late, 3);
            }
            let (mut st, mut dr) = s.release();
            st.done();
            dr.done();
        }
    }

    #[test]
    fn edges_are_planned_on_the_timer_clock() {
        let timer = Recorder {
            now: 0,
            waits: Vec::new(),
        };
        let d = StepDir::new(
            Mock::new(&[]),
            Mock::new(&[]),
            timer,
            DriverConfig::default(),
        );
        let p = crate::Profile::limits(&crate::LimitsMove::trapezoid(10, 100.0, 1000.0)).unwrap();
        let g = d.edges(p.clone()).unwrap();
        assert_eq!(g.clock(), 1000.0);
        assert_eq!(g.last_edge_tick(), (p.duration() * 1000.0).round() as u64);
        let (mut s, mut dr, _) = d.release();
        s.done();
        dr.done();
    }

    /// One pulse type, one set of widths: the driver's pulses are the TDM pulse unit's.
    #[test]
    fn pulses_have_the_tdm_pulse_units_widths() {
        use crate::tdm::{PulseUnit, StepPulse};
        for (shape, edges) in [
            (PulseShape::HalfInterval, [10u64, 11, 20, 40]),
            (PulseShape::Fixed { ticks: 3 }, [10, 15, 20, 40]),
        ] {
            // the TDM unit, every period loaded on time
            let mut unit = PulseUnit::new(shape);
            let mut tdm: Vec<StepPulse> = Vec::new();
            let mut prev = 0;
            for &e in &edges {
                unit.load(0, prev, e - prev, &mut |p| tdm.push(p));
                prev = e;
            }
            unit.finish(0, &mut |p| tdm.push(p));
            // the driver, polled at each deadline: rises and falls alternate
            let cfg = DriverConfig {
                step_dir: StepDirTiming {
                    pulse: shape,
                    ..StepDirTiming::default()
                },
                ..DriverConfig::default()
            };
            let step = Mock::new(&pulses(4));
            let dir = Mock::new(&[T::set(State::High)]);
            let mut s = Stepper::start(step, dir, true, edges, 0, cfg).unwrap();
            let mut times = Vec::new();
            let mut now = 0;
            while let Some(d) = s.poll(now).unwrap() {
                times.push(d);
                now = d;
            }
            let (mut st, mut dr) = s.release();
            st.done();
            dr.done();
            let want: Vec<u64> = tdm.iter().flat_map(|p| [p.rise, p.fall]).collect();
            // a fall on the next rise is one deadline
            let mut want_deadlines = want.clone();
            want_deadlines.dedup();
            assert_eq!(times, want_deadlines, "{shape:?}");
        }
    }
}
