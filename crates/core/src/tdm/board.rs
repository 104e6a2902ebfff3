//! The engine: k axes, one calculator, one synchronous start.
//!
//! Tick 0: the move is loaded and every DIR line is set. The calculator starts at once and
//! fills every FIFO (by the policy, `min(depth, steps)` periods each); the group starts
//! when that is done and the DIR setup time has passed (see [`Board::start_tick`]). At
//! `start` every pulse unit loads period 1.
//!
//! The simulation is event-driven: time jumps from one calculator decision to the next
//! (idle stretches are skipped); a computation starts every `interval` cycles at most and
//! its period is in the FIFO `latency` cycles after it starts ([`Latencies`]); on an axis
//! whose periods the recurrence finds ([`Axis::recurrent`]) each period takes its own
//! cycles, one period at a time. When a period is computed the engine already knows when
//! its pulse unit needs it (the previous edge), so it knows at once whether it is in time
//! (slack = needed − ready ≥ 0) or an underrun (ready later than needed: the edge and
//! every later one of that axis are late by the difference). Each pulse goes to the sink
//! when its falling edge is known; per axis in step order, across axes in the order the
//! calculator computed them.

use super::calculator::Latencies;
use super::fifo::Fifo;
use super::pulse::{PulseShape, PulseUnit, StepPulse};
pub use super::scheduler::MAX_AXES;
use super::scheduler::{Policy, Queue, TICK_LIMIT};
use super::TdmError;
use crate::edges::EdgeGenerator;
use crate::int::recurrence::{CountedEdges, Recurrence, RecurrenceClocks, WALK_LIMIT};
use crate::int::{ChainEdges, IntProfile, IntTracker};
use crate::profile::Profile;
use crate::step_dir::StepDirTiming;
use crate::track::{Rate, TrackError, Tracker};

/// What a board is built from besides its axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TdmConfig {
    /// Clock (Hz) of the calculator, the pulse units and the edge ticks.
    pub clock_hz: f64,
    pub fifo_depth: usize,
    pub latencies: Latencies,
    pub policy: Policy,
    /// STEP pulse width, and the least ticks between DIR being set (tick 0) and the
    /// group's start.
    pub step_dir: StepDirTiming,
}

impl Default for TdmConfig {
    fn default() -> Self {
        TdmConfig {
            clock_hz: crate::DEFAULT_CLOCK_HZ,
            fifo_depth: 1,
            latencies: Latencies::default(),
            policy: Policy::RoundRobin,
            step_dir: StepDirTiming::default(),
        }
    }
}

/// Per-axis results of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisStats {
    /// Steps emitted.
    pub steps: u64,
    /// Periods that were not in the FIFO when the pulse unit needed them.
    pub underruns: u64,
    /// Sum of the delays those underruns caused: how late the last edge is.
    pub late_ticks: u64,
    /// Least (needed − ready) over periods 2…N; negative iff there was an underrun.
    pub min_slack_ticks: i64,
    /// Tick the pulse unit loaded period 1.
    pub start_tick: u64,
    /// Tick of the last rising edge.
    pub last_rise: u64,
    /// Pulses with no low time before the next one.
    pub merged_pulses: u64,
}

impl AxisStats {
    const NEW: AxisStats = AxisStats {
        steps: 0,
        underruns: 0,
        late_ticks: 0,
        min_slack_ticks: i64::MAX,
        start_tick: 0,
        last_rise: 0,
        merged_pulses: 0,
    };
}

/// Edges pulled from the generator at a time: a batch lets the CPU overlap their
/// independent square roots and divides, and pays the refill's call once per batch (on
/// the 16-axis bench load 32 ran 3.5 instructions per edge fewer than 16, 64 another 1.8
/// fewer, 128 only 0.9 more for twice the buffer; a simulation speed-up, the model is
/// unchanged).
const LOOKAHEAD: usize = 64;

/// A move whose periods the per-step recurrence finds: on quadratic pieces (three at
/// most: phase or limits mode), or on a chain's polynomial pieces.
// the chain is large, but boxing would allocate (the crate is no_std, no alloc)
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Recurrent {
    Quadratic {
        edges: Recurrence<IntProfile<3>, 3>,
        clock: u64,
    },
    Chain(ChainEdges),
}

impl Recurrent {
    /// The next edge and the clocks the recurrence spent on it (out of line: inlined,
    /// its code cost the closed-form axes' loop 4 instructions a period).
    #[inline(never)]
    fn next_with_cost(&mut self, clocks: &RecurrenceClocks) -> Option<(u64, u64)> {
        let before = self.counted().clocks(clocks);
        let e = match self {
            Recurrent::Quadratic { edges, .. } => edges.next(),
            Recurrent::Chain(c) => c.next(),
        }?;
        Some((e, self.counted().clocks(clocks) - before))
    }

    fn counted(&self) -> crate::int::recurrence::RecurrenceCount {
        match self {
            Recurrent::Quadratic { edges, .. } => edges.counted(),
            Recurrent::Chain(c) => c.counted(),
        }
    }

    /// A bound on one period's clocks: a quadratic step's jump, its walk to the limit and
    /// the closed form; a chain step's search, at most one probe per bit of its ticks
    /// twice (doubling, then halving) and a walk.
    fn worst_cost(&self, clocks: &RecurrenceClocks) -> u128 {
        let walk = clocks.jump as u128 + WALK_LIMIT as u128 * clocks.tick as u128;
        match self {
            Recurrent::Quadratic { .. } => walk + clocks.closed as u128,
            Recurrent::Chain(c) => {
                let bits = 64 - c.end_tick().leading_zeros() as u128;
                walk + 2 * (bits + 1) * clocks.jump as u128
            }
        }
    }

    fn restart(&mut self) {
        match self {
            Recurrent::Quadratic { edges, .. } => edges.restart(),
            Recurrent::Chain(c) => c.restart(),
        }
    }

    fn steps(&self) -> u64 {
        match self {
            Recurrent::Quadratic { edges, .. } => edges.steps(),
            Recurrent::Chain(c) => c.steps(),
        }
    }

    fn end_tick(&self) -> u64 {
        match self {
            Recurrent::Quadratic { edges, .. } => edges.end_tick(),
            Recurrent::Chain(c) => c.end_tick(),
        }
    }

    fn clock(&self) -> u64 {
        match self {
            Recurrent::Quadratic { clock, .. } => *clock,
            Recurrent::Chain(c) => c.clock(),
        }
    }
}

/// Marks the branch whose block calls it as rare, so the compiler lays the other one out
/// as the fall-through (a call behind a further test in that block gives no hint).
#[cold]
#[inline(always)]
fn cold() {}

/// Where an axis's edges come from: a move (a known number of steps), a move whose
/// periods the calculator finds by the per-step recurrence (each costing what the
/// recurrence spends on it), or open-ended motion (a tracker, float or integer); each with
/// its state at the start, so the axis can run again.
// the sources are large, but boxing would allocate (the crate is no_std, no alloc)
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Source {
    Move(EdgeGenerator),
    Recur {
        edges: Recurrent,
        clocks: RecurrenceClocks,
    },
    Track {
        now: Tracker,
        start: Tracker,
    },
    IntTrack {
        now: IntTracker,
        start: IntTracker,
    },
}

impl Source {
    fn is_recurrent(&self) -> bool {
        matches!(self, Source::Recur { .. })
    }

    /// On a recurrence's axis, a bound on its periods' cycles plus its last edge: every
    /// period at most a jump, a walk to its limit and a closed form (0 on other sources).
    fn recurrent_bound(&self) -> u128 {
        let Source::Recur { edges, clocks } = self else {
            return 0;
        };
        edges.steps() as u128 * edges.worst_cost(clocks) + edges.end_tick() as u128
    }

    /// A recurrence's cycles for its next `n` periods (None on other sources).
    fn prefill_cost(&self, n: u64) -> Option<u64> {
        let Source::Recur { edges, clocks } = self else {
            return None;
        };
        let mut ahead = edges.clone();
        Some(
            (0..n)
                .map_while(|_| ahead.next_with_cost(clocks))
                .map(|(_, c)| c)
                .sum(),
        )
    }

    fn clock(&self) -> f64 {
        match self {
            Source::Move(g) => g.clock(),
            Source::Recur { edges, .. } => edges.clock() as f64,
            Source::Track { now, .. } => now.clock_hz() as f64,
            Source::IntTrack { now, .. } => now.clock_hz() as f64,
        }
    }

    fn is_tracking(&self) -> bool {
        matches!(self, Source::Track { .. } | Source::IntTrack { .. })
    }
}

/// A rate change (a stop when the rate is zero) for a tracking axis, handed to its source
/// when the calculator's clock reaches `tick`: it applies after the steps computed by then
/// (those already in the FIFO run as computed), as [`Tracker::set_rate`] does after the
/// steps produced.
#[derive(Clone, Debug, PartialEq)]
pub struct TrackCommand {
    /// Calculator tick at which the command arrives.
    pub tick: u64,
    pub axis: usize,
    pub rate: Rate,
    /// Filled by the run: the axis's steps computed when the change was applied (`None`:
    /// not delivered, because the run ended first or the axis had already stopped).
    pub applied_after: Option<u64>,
    /// Filled by the run: the tracker refused the rate (its motion is unchanged).
    pub refused: Option<TrackError>,
}

impl TrackCommand {
    /// `rate` for `axis` at `tick`.
    pub fn new(tick: u64, axis: usize, rate: Rate) -> TrackCommand {
        TrackCommand {
            tick,
            axis,
            rate,
            applied_after: None,
            refused: None,
        }
    }
}

/// One axis: the source of its exact periods, its FIFO and its pulse unit.
#[derive(Clone, Debug)]
pub struct Axis {
    gen: Source,
    /// Steps of the move (`u64::MAX` when open-ended).
    steps: u64,
    /// Edges computed ahead, in `ahead[ahead_pos..]` (a short last batch is put at the
    /// end, so the end is always `LOOKAHEAD`: a compare with a constant, and the read
    /// needs no bounds check).
    ahead: [u64; LOOKAHEAD],
    ahead_pos: usize,
    /// Rise tick minus edge tick of the last step loaded (the group's start until an
    /// underrun delays the axis): the next rise, in time, is its edge plus this, so a
    /// period needs no previous edge stored.
    shift: u64,
    /// A period needed at least this many ticks after its computation starts is in time
    /// and changes no figure: the least slack so far (at least 0) plus the latency
    /// (`i64::MAX` until period 2 sets it: it has no least slack to keep).
    on_time_from: i64,
    fifo: Fifo,
    pulse: PulseUnit,
    stats: AxisStats,
    /// Calculator cycles of the last period computed, on a recurrence's axis.
    cost: u64,
}

impl Axis {
    pub fn new(profile: Profile, clock_hz: f64) -> Result<Axis, TdmError> {
        Axis::with_source(
            profile.steps(),
            Source::Move(EdgeGenerator::new(profile, clock_hz)?),
        )
    }

    /// A move of at most three pieces (phase or limits mode) planned on `clock_hz`, whose
    /// periods the calculator finds by the per-step recurrence: each period costs the
    /// clocks the recurrence spends on it at `clocks` (a closed form for the first two
    /// steps and where a walk gives up), instead of the board's latency. Its edges are
    /// the profile's exactly.
    pub fn recurrent(
        profile: IntProfile<3>,
        clock_hz: u64,
        clocks: RecurrenceClocks,
    ) -> Result<Axis, TdmError> {
        let edges = Recurrent::Quadratic {
            edges: Recurrence::new(profile),
            clock: clock_hz,
        };
        Axis::with_source(edges.steps(), Source::Recur { edges, clocks })
    }

    /// A move of polynomial pieces (scurve, scurve4) whose periods a chain finds by the
    /// per-step recurrence (`edges`, made [`ChainEdges::by_recurrence`]; without, it is
    /// made so here): each period costs the clocks the recurrence spends on it at
    /// `clocks` (its jumps, the ticks walked and the probes of its searches).
    pub fn chain_recurrent(edges: ChainEdges, clocks: RecurrenceClocks) -> Result<Axis, TdmError> {
        let edges = match edges.recurrence_tally() {
            Some(_) => edges,
            None => edges.by_recurrence(),
        };
        let edges = Recurrent::Chain(edges);
        Axis::with_source(edges.steps(), Source::Recur { edges, clocks })
    }

    /// An open-ended axis whose edges are `tracker`'s (from its current state); rates
    /// change through [`Board::run_tracking`]'s commands.
    pub fn tracking(tracker: Tracker) -> Result<Axis, TdmError> {
        Axis::with_source(
            u64::MAX,
            Source::Track {
                start: tracker.clone(),
                now: tracker,
            },
        )
    }

    /// [`Axis::tracking`] with the integer tracker.
    pub fn tracking_int(tracker: IntTracker) -> Result<Axis, TdmError> {
        Axis::with_source(
            u64::MAX,
            Source::IntTrack {
                start: tracker.clone(),
                now: tracker,
            },
        )
    }

    fn with_source(steps: u64, gen: Source) -> Result<Axis, TdmError> {
        Ok(Axis {
            steps,
            gen,
            ahead: [0; LOOKAHEAD],
            ahead_pos: LOOKAHEAD,
            shift: 0,
            on_time_from: i64::MAX,
            cost: 0,
            fifo: Fifo::new(1)?,
            pulse: PulseUnit::default(),
            stats: AxisStats::NEW,
        })
    }

    /// Back to step 0 with an empty FIFO, so the same axes can run again.
    fn reset(&mut self, depth: usize, shape: PulseShape) -> Result<(), TdmError> {
        match &mut self.gen {
            // back to step 1 in place (no copy of the profile)
            Source::Move(g) => g.seek(1),
            Source::Recur { edges, .. } => edges.restart(),
            Source::Track { now, start } => *now = start.clone(),
            Source::IntTrack { now, start } => *now = start.clone(),
        }
        self.ahead_pos = LOOKAHEAD;
        self.shift = 0;
        self.on_time_from = i64::MAX;
        self.cost = 0;
        self.fifo = Fifo::new(depth)?;
        self.pulse = PulseUnit::new(shape);
        self.stats = AxisStats::NEW;
        Ok(())
    }

    /// The exact edge (ticks from the start) of the next step; `TRACK`: in
    /// `run_tracking`'s loop.
    #[inline]
    fn next_edge<const TRACK: bool>(&mut self) -> Option<u64> {
        let pos = self.ahead_pos;
        // in `run` a refill is a move's batch, once per LOOKAHEAD edges: cold (the usual
        // path then falls through and keeps the sink's pointer in a register, 2
        // instructions per period); in `run_tracking` a tracker refills every edge, and
        // the hint cost its path 4
        if !TRACK && pos >= LOOKAHEAD {
            cold();
            return self.refill();
        }
        if TRACK && pos >= LOOKAHEAD {
            return self.refill();
        }
        self.ahead_pos = pos + 1;
        Some(self.ahead[pos])
    }

    /// The next edge when the look-ahead is empty: a move refills it with a batch; a
    /// tracker's edges come one at a time, past it (a rate change applies after the steps
    /// computed), so a tracking axis always lands here.
    #[inline]
    fn refill(&mut self) -> Option<u64> {
        match &mut self.gen {
            Source::Move(g) => {
                let from = LOOKAHEAD - (g.remaining().min(LOOKAHEAD as u64) as usize);
                if from == LOOKAHEAD {
                    return None;
                }
                let n = g.fill(&mut self.ahead[from..]);
                debug_assert_eq!(n, LOOKAHEAD - from);
                self.ahead_pos = from + 1;
                Some(self.ahead[from])
            }
            Source::Recur { edges, clocks } => {
                let (e, cost) = edges.next_with_cost(clocks)?;
                self.cost = cost;
                Some(e)
            }
            Source::Track { now, .. } => now.next(),
            Source::IntTrack { now, .. } => now.next(),
        }
    }

    /// Computes the next period, which starts at tick `t`, is ready `lat` ticks later
    /// (`COST`: the period's own cost, [`Axis::cost`], instead) and is needed at `due`,
    /// and loads it into the pulse unit (closing the previous pulse into `sink`): an
    /// underrun if it is late. Returns the step's rise tick and the tick the FIFO has room
    /// again, `None` if no step was left. `TRACK`: in `run_tracking`'s loop.
    #[inline]
    fn compute<const TRACK: bool, const HALF: bool, const COST: bool, F: FnMut(StepPulse)>(
        &mut self,
        m: usize,
        t: u64,
        lat: u64,
        due: u64,
        sink: &mut F,
    ) -> Option<(u64, u64)> {
        let edge = self.next_edge::<TRACK>()?;
        // `due` is the previous rise, the previous edge plus `shift`
        let rise = edge + self.shift;
        let period = rise - due;
        // ticks are below 2^57 (checked by the board): the difference fits. With
        // per-period costs, `ahead` is counted as if this period took `lat`, so the
        // slack tests below (made for one latency) hold as they are.
        let own = if COST && self.gen.is_recurrent() {
            self.cost
        } else {
            lat
        };
        let ahead = due as i64 - t as i64 - (own as i64 - lat as i64);
        let n = self.computed();
        if ahead < self.on_time_from {
            if ahead < lat as i64 || n == 0 {
                let (rise, room, closed) = self.load_late_or_first(m, t + own, lat, due, period);
                self.shift = rise - edge;
                if let Some(p) = closed {
                    sink(p);
                }
                return Some((rise, room));
            }
            // in time with a new least slack (4.7 % of the periods on the 16-axis bench
            // load, while the moves speed up): that figure alone changes
            self.stats.min_slack_ticks = ahead - lat as i64;
            self.on_time_from = ahead;
        }
        // in time, after period 1 (so `due` is the previous rise). The pulse unit's count
        // is the FIFO's push count; its rises stay with the caller (`need`) and the FIFO
        // until `resume_pulse`
        self.pulse.load_kept::<HALF, F>(m, due, period, sink);
        Some((rise, self.fifo.push_nth_then_room(n, due)))
    }

    /// [`compute`](Self::compute)'s rare cases: period 1 (it fixes the start, so its
    /// slack is not counted) and an underrun (the period is loaded when it arrives; any
    /// period, in time or not, gives the same result here). Returns the rise, the room
    /// tick (read here: read by the caller, it was merged with the in-time path's read
    /// through a computed address, 3 instructions per period) and the pulse it closes,
    /// which the caller hands to the sink (when this call took the sink, the loop
    /// reloaded the sink's state every period). `ready`: the tick the period is in the
    /// FIFO; `lat`: the board's latency, the reference of the slack tests.
    #[inline(never)]
    fn load_late_or_first(
        &mut self,
        m: usize,
        ready: u64,
        lat: u64,
        due: u64,
        period: u64,
    ) -> (u64, u64, Option<StepPulse>) {
        self.resume_pulse(due);
        let load = if ready > due {
            self.stats.underruns += 1;
            self.stats.late_ticks += ready - due;
            ready
        } else {
            due
        };
        // period 1 fixes the start tick, so its slack is 0 by construction: not counted
        let slack = due as i64 - ready as i64;
        if slack < self.stats.min_slack_ticks && self.computed() > 0 {
            self.stats.min_slack_ticks = slack;
        }
        if self.computed() > 0 {
            self.on_time_from = self.stats.min_slack_ticks.max(0) + lat as i64;
        }
        self.fifo.push_nth(self.computed(), load);
        let mut closed = None;
        let rise = self.pulse.load(m, load, period, &mut |p| closed = Some(p));
        (rise, self.fifo.room_after(self.computed()), closed)
    }

    /// Hands the pulse unit the rises of its in-time loads: `last` is the last rise, and
    /// the last period was loaded at the tick the FIFO holds for it.
    fn resume_pulse(&mut self, last: u64) {
        let n = self.computed();
        if n > 0 {
            self.pulse.resume(last, self.fifo.leave_of(n - 1));
        }
    }

    /// Periods computed so far (the pulse unit's count, kept once).
    #[inline]
    fn computed(&self) -> u64 {
        self.pulse.steps()
    }

    /// Closes the last pulse, which rises at `rise` (the move is computed), and records
    /// the pulse unit's figures.
    fn finish<F: FnMut(StepPulse)>(&mut self, m: usize, rise: u64, sink: &mut F) {
        self.resume_pulse(rise);
        self.pulse.finish(m, sink);
        self.stats.steps = self.computed();
        self.stats.last_rise = rise;
        self.stats.start_tick = self.pulse.start_tick();
        self.stats.merged_pulses = self.pulse.merged();
    }

    /// Periods not computed yet (`u64::MAX` while a tracker runs).
    fn remaining(&self) -> u64 {
        match &self.gen {
            Source::Move(g) => g.remaining() + (LOOKAHEAD - self.ahead_pos) as u64,
            Source::Recur { edges, .. } => edges.steps() - edges.counted().steps,
            Source::Track { now, .. } if !now.rate().is_zero() || now.ramp_profile().is_some() => {
                u64::MAX
            }
            Source::IntTrack { now, .. }
                if !now.rate().is_zero() || now.ramp_profile().is_some() =>
            {
                u64::MAX
            }
            _ => 0,
        }
    }

    /// The move's profile (`None` on a tracking axis).
    pub fn profile(&self) -> Option<&Profile> {
        match &self.gen {
            Source::Move(g) => Some(g.profile()),
            _ => None,
        }
    }

    /// Gives a tracking axis's source a new rate; `Ok(false)` on a move.
    fn set_rate(&mut self, rate: Rate) -> Result<bool, TrackError> {
        match &mut self.gen {
            Source::Move(_) | Source::Recur { .. } => Ok(false),
            Source::Track { now, .. } => now.set_rate(rate).map(|_| true),
            Source::IntTrack { now, .. } => now.set_rate(rate).map(|_| true),
        }
    }

    pub fn stats(&self) -> &AxisStats {
        &self.stats
    }
}

/// Aggregate results of a run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Report {
    pub axes: usize,
    /// The group's start tick (period 1 loaded on every axis).
    pub start_tick: u64,
    /// Last rising edge of any axis.
    pub end_tick: u64,
    pub edges: u64,
    pub underruns: u64,
    /// Largest delay of any axis's last edge.
    pub max_late_ticks: u64,
    pub min_slack_ticks: i64,
    /// Cycles between computation starts (t_calc of seed eq. (12)).
    pub interval_cycles: u64,
    /// Cycles from a computation's start to its FIFO write.
    pub latency_cycles: u64,
    /// Issue cycles used: `interval_cycles` per period computed (on a recurrence's axis,
    /// each period's own cycles).
    pub busy_cycles: u64,
    /// Latest minus earliest axis start tick (a synchronous group must show 0).
    pub start_skew_ticks: u64,
    pub merged_pulses: u64,
}

impl Report {
    /// Issue cycles used over the run's span, tick 0 to the last edge.
    pub fn calculator_utilization(&self) -> f64 {
        if self.end_tick == 0 {
            return 0.0;
        }
        self.busy_cycles as f64 / self.end_tick as f64
    }
}

/// The engine over caller-provided axes.
pub struct Board<'a> {
    cfg: TdmConfig,
    axes: &'a mut [Axis],
}

impl<'a> Board<'a> {
    /// Checks the configuration and resets every axis to step 0.
    pub fn new(cfg: TdmConfig, axes: &'a mut [Axis]) -> Result<Board<'a>, TdmError> {
        if axes.is_empty() {
            return Err(TdmError::NoAxes);
        }
        if axes.len() > MAX_AXES {
            return Err(TdmError::TooManyAxes {
                axes: axes.len(),
                max: MAX_AXES,
            });
        }
        if cfg.latencies.interval() == 0 {
            return Err(TdmError::ZeroCycles);
        }
        if cfg.step_dir.pulse == (PulseShape::Fixed { ticks: 0 }) {
            return Err(TdmError::ZeroPulseWidth);
        }
        // Worst case: every period computed after the last edge of the longest move.
        // (tracking axes are bounded by the run's horizon, checked when it is given)
        let moves = || {
            axes.iter().filter_map(|a| match &a.gen {
                Source::Move(g) => Some(g),
                _ => None,
            })
        };
        let work: u128 = moves().map(|g| g.profile().steps() as u128).sum::<u128>()
            * cfg.latencies.latency() as u128
            + moves()
                .map(|g| g.last_edge_tick() as u128)
                .max()
                .unwrap_or(0)
            + cfg.step_dir.dir_setup_ticks as u128
            + axes
                .iter()
                .map(|a| a.gen.recurrent_bound())
                .fold(0, u128::saturating_add);
        if work >= TICK_LIMIT as u128 {
            return Err(TdmError::TooLong);
        }
        for (m, a) in axes.iter_mut().enumerate() {
            if a.gen.clock() != cfg.clock_hz {
                return Err(TdmError::ClockMismatch {
                    axis: m,
                    axis_hz: a.gen.clock(),
                    board_hz: cfg.clock_hz,
                });
            }
            a.reset(cfg.fifo_depth, cfg.step_dir.pulse)?;
        }
        Ok(Board { cfg, axes })
    }

    /// The group's start: every FIFO filled and the DIR setup time over. The P prefill
    /// periods (`Σ_m min(depth, steps_m)`) start every interval; the last is ready one
    /// latency after its start: `max(dir_setup, (P − 1)·interval + latency)`.
    pub fn start_tick(&self) -> u64 {
        let depth = self.cfg.fifo_depth as u64;
        let (ii, lat) = (self.cfg.latencies.interval(), self.cfg.latencies.latency());
        let fill = if self.costs_vary() {
            // one period after the other: the recurrence's at their own costs, the
            // others at the interval (the last one's latency after its start)
            let (mut spent, mut closed) = (0u64, false);
            for a in self.axes.iter() {
                let n = a.remaining().min(depth);
                match a.gen.prefill_cost(n) {
                    Some(c) => spent += c,
                    None => {
                        spent += n * ii;
                        closed |= n > 0;
                    }
                }
            }
            spent + if closed { lat - ii } else { 0 }
        } else {
            match self
                .axes
                .iter()
                .map(|a| a.remaining().min(depth))
                .sum::<u64>()
            {
                0 => 0,
                p => (p - 1).saturating_mul(ii).saturating_add(lat),
            }
        };
        self.cfg.step_dir.dir_setup_ticks.max(fill)
    }

    /// Runs every axis to its last step, handing each pulse to `sink`. Open-ended
    /// (tracking) axes have no last step: this run ends with the last move, and cuts
    /// them there (with no move, at once); they run by [`Board::run_tracking`].
    pub fn run<F: FnMut(StepPulse)>(self, sink: F) -> Report {
        let half = self.cfg.step_dir.pulse == PulseShape::HalfInterval;
        match (half, self.costs_vary()) {
            (true, false) => self.run_inner::<false, true, false, F>(TICK_LIMIT, &mut [], sink),
            (false, false) => self.run_inner::<false, false, false, F>(TICK_LIMIT, &mut [], sink),
            (true, true) => self.run_inner::<false, true, true, F>(TICK_LIMIT, &mut [], sink),
            (false, true) => self.run_inner::<false, false, true, F>(TICK_LIMIT, &mut [], sink),
        }
    }

    /// Some axis's periods each cost their own cycles ([`Axis::recurrent`]).
    fn costs_vary(&self) -> bool {
        self.axes.iter().any(|a| a.gen.is_recurrent())
    }

    /// Runs until the calculator's clock passes `until` (or every axis is done), handing
    /// each pulse to `sink` and each command to its tracking axis when the clock reaches
    /// its tick (`commands` in tick order; the run fills in when each applied). At the
    /// horizon every axis still running closes its last pulse as a move's last pulse.
    /// Moves run exactly as in [`Board::run`].
    pub fn run_tracking<F: FnMut(StepPulse)>(
        self,
        until: u64,
        commands: &mut [TrackCommand],
        sink: F,
    ) -> Result<Report, TdmError> {
        if until >= TICK_LIMIT / 2 {
            return Err(TdmError::TooLong);
        }
        for c in commands.iter() {
            if !self.axes.get(c.axis).is_some_and(|a| a.gen.is_tracking()) {
                return Err(TdmError::NotTracking { axis: c.axis });
            }
        }
        if commands.windows(2).any(|w| w[1].tick < w[0].tick) {
            return Err(TdmError::CommandOrder);
        }
        let half = self.cfg.step_dir.pulse == PulseShape::HalfInterval;
        Ok(match (half, self.costs_vary()) {
            (true, false) => self.run_inner::<true, true, false, F>(until, commands, sink),
            (false, false) => self.run_inner::<true, false, false, F>(until, commands, sink),
            (true, true) => self.run_inner::<true, true, true, F>(until, commands, sink),
            (false, true) => self.run_inner::<true, false, true, F>(until, commands, sink),
        })
    }

    /// The engine's loop. `TRACK`: tracking commands and a horizon (`run_tracking`);
    /// without, `run` drops their checks from the per-edge path. `HALF`: every pulse unit
    /// has half-interval pulses (the in-time path then does not test the shape). `COST`:
    /// some axis's periods each take their own cycles (a recurrence's), one at a time.
    fn run_inner<const TRACK: bool, const HALF: bool, const COST: bool, F: FnMut(StepPulse)>(
        self,
        until: u64,
        commands: &mut [TrackCommand],
        mut sink: F,
    ) -> Report {
        let k = self.axes.len();
        let (ii, lat) = (self.cfg.latencies.interval(), self.cfg.latencies.latency());
        // Hot scheduling state, contiguous and outside the (large) axes.
        let mut need = [0u64; MAX_AXES];
        let mut queue = Queue::default();
        for (m, a) in self.axes.iter().enumerate() {
            if a.remaining() > 0 {
                queue.insert(m, 0, 0);
            }
        }
        let start = self.start_tick();
        need[..k].fill(start);
        for a in self.axes.iter_mut() {
            // step 0 "rises" at the start
            a.shift = start;
        }

        let policy = self.cfg.policy;
        let mut t = 0u64;
        // the axis served last (round-robin goes on after it)
        let mut last = usize::MAX;
        let mut cmd = 0usize;
        let mut busy = 0u64;
        let mut done = [false; MAX_AXES];
        let mut moves_left = self
            .axes
            .iter()
            .filter(|a| !a.gen.is_tracking() && a.remaining() > 0)
            .count();
        // `run` ends with the last move (checked when one ends, not per period);
        // `run_tracking` at the horizon
        let empty = !TRACK && moves_left == 0;
        // a loop after one check (its end is the break below), which the compiler lays out
        // better than `if … { loop { … } }` (2 instructions per period fewer, measured)
        #[allow(clippy::while_immutable_condition)]
        while !empty {
            // `run` stops when its last move ends, so the queue is never empty here
            let picked = queue.pick_from::<TRACK>(policy, t, &need, last);
            if TRACK {
                // commands due by the next decision (or by the horizon when the queue is idle)
                let now = picked.map_or(until, |(now, _)| now.min(until.saturating_add(1)));
                while let Some(c) = commands.get_mut(cmd).filter(|c| c.tick <= now) {
                    cmd += 1;
                    let a = &mut self.axes[c.axis];
                    if done[c.axis] {
                        continue;
                    }
                    match a.set_rate(c.rate) {
                        Ok(_) => c.applied_after = Some(a.computed()),
                        Err(e) => c.refused = Some(e),
                    }
                }
            }
            let Some((now, m)) = picked else { break };
            if TRACK && now > until {
                break;
            }
            t = now;
            last = m;
            let a = &mut self.axes[m];
            let Some((rise, room)) =
                a.compute::<TRACK, HALF, COST, F>(m, t, lat, need[m], &mut sink)
            else {
                // a tracker that stopped: its last pulse closes as a move's last pulse
                done[m] = true;
                if a.computed() > 0 {
                    a.finish(m, need[m], &mut sink);
                }
                continue;
            };
            need[m] = rise;
            if COST {
                let spent = if a.gen.is_recurrent() { a.cost } else { ii };
                busy += spent;
                t += spent;
            } else {
                t += ii;
            }
            if a.computed() == a.steps {
                done[m] = true;
                moves_left -= 1;
                a.finish(m, rise, &mut sink);
                if !TRACK && moves_left == 0 {
                    break;
                }
            } else {
                // a room tick by the next decision is as good as now. The core's scheduler
                // sees a FIFO's room the tick after the pop that made it (it does not
                // look at pops, which keeps the pulse unit's edge test out of its pick)
                queue.insert(m, room + 1, t);
            }
        }
        for (m, a) in self.axes.iter_mut().enumerate() {
            if !done[m] && a.computed() > 0 {
                a.finish(m, need[m], &mut sink);
            }
        }
        self.report(start, COST.then_some(busy))
    }

    /// The run's figures; `busy`: the calculator's cycles, when its periods' costs vary.
    fn report(&self, start_tick: u64, busy: Option<u64>) -> Report {
        let mut r = Report {
            axes: self.axes.len(),
            start_tick,
            end_tick: 0,
            edges: 0,
            underruns: 0,
            max_late_ticks: 0,
            min_slack_ticks: i64::MAX,
            interval_cycles: self.cfg.latencies.interval(),
            latency_cycles: self.cfg.latencies.latency(),
            busy_cycles: 0,
            start_skew_ticks: 0,
            merged_pulses: 0,
        };
        let (mut first, mut last) = (u64::MAX, 0);
        for a in self.axes.iter() {
            let s = &a.stats;
            r.end_tick = r.end_tick.max(s.last_rise);
            r.edges += s.steps;
            r.underruns += s.underruns;
            r.max_late_ticks = r.max_late_ticks.max(s.late_ticks);
            r.min_slack_ticks = r.min_slack_ticks.min(s.min_slack_ticks);
            r.merged_pulses += s.merged_pulses;
            first = first.min(s.start_tick);
            last = last.max(s.start_tick);
        }
        r.start_skew_ticks = last - first;
        // else one issue interval per period computed
        r.busy_cycles = busy.unwrap_or(r.edges * r.interval_cycles);
        r
    }
}
