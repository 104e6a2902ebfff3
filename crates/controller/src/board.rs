//! One controller board: its axes, their moves, homing, and the store. What happens at
//! the pins is a [`BoardBackend`] (simulated mechanics and sensors, or the FPGA board).
//! Time is explicit — every method takes the board tick `now` — so the same code runs in
//! real time under [`crate::Controller`] and in virtual time in tests.

use crate::axis::{AxisSettings, AxisState, AxisStatus, Link, MAX_POSITION};
use crate::backend::{BoardBackend, Launch, PinEvent};
use crate::config::BoardConfig;
use crate::error::CtlError;
use crate::hall::FilteredEdge;
use crate::motion::StepSource;
use crate::protocol::{Amount, MoveOpts};
use crate::store::{AxisRecord, MountRecord, MovingMarker, NamedPosition, Store};
use multistep_core::int::IntProfile;
use multistep_core::tdm::TdmConfig;
use multistep_core::{MoveSpec, Profile};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

mod adopt;
mod clock;
mod driver;
mod homing;
mod preview;
mod sync;
mod tracking;

pub use clock::ClockState;
use homing::HomePhase;
pub use preview::{PlannedAxis, PreviewPlan};

/// Most steps (summed over its axes) of one move or group: the TDM engine times every
/// edge before the move starts (about 40 ns each), so this bounds the time a move takes
/// to start (about 4 s at most, outside the board lock).
pub const MAX_TIMED_STEPS: u64 = 100_000_000;

/// Axes an e-stop halted whose records are still to be written ([`Board::record_halted`]).
#[must_use]
pub struct Halted(Vec<usize>);

/// A group move planned and waiting for its TDM timing and start.
pub struct PendingGroup {
    plan: Vec<(usize, i64)>,
    profiles: Vec<Option<Profile>>,
    /// The backend's own plans of the moves (see [`BoardBackend::plan_datapath`]).
    datapaths: Vec<Option<IntProfile>>,
    /// Count and settings of each axis when planned; the start checks they still hold.
    before: Vec<(i64, AxisSettings)>,
    tdm: TdmConfig,
}

impl PendingGroup {
    /// Runs the TDM engine over the group (none needed when nothing moves).
    pub fn time(&self) -> Result<Option<multistep_core::tdm::Report>, CtlError> {
        let moving: Vec<Profile> = self.profiles.iter().flatten().cloned().collect();
        if moving.is_empty() {
            return Ok(None);
        }
        crate::motion::tdm_report(&moving, &self.tdm).map(Some)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Purpose {
    Move,
    Home(HomePhase),
}

struct Motion {
    dir: i64,
    /// The load's position at the end (see [`Axis::slack`]).
    target: i64,
    /// Motor count and slack where the motion began: the slack at any later count of
    /// this (monotone) motion is [`slack_after`] of them.
    motor0: i64,
    slack0: i64,
    purpose: Purpose,
    /// Set by a controlled stop or a homing trigger: the plan was replaced by a stop ramp.
    stopping: bool,
    /// Homing: the edge that triggered the stop.
    edge: Option<FilteredEdge>,
    /// Open-ended motion (`track`): its rate, lease and what follows a stop.
    track: Option<tracking::TrackState>,
}

struct Axis {
    name: String,
    settings: AxisSettings,
    /// The load's position as of the last advance: the backend's (motor) count minus
    /// `slack`.
    count: i64,
    /// Motor minus load, in [0, backlash]: the play between them is a dead band the motor
    /// crosses before the load follows, so `backlash` after a move forward, 0 after one
    /// backward.
    slack: i64,
    homed: bool,
    trusted: bool,
    state: AxisState,
    fault: Option<String>,
    motion: Option<Motion>,
    drift: Option<i64>,
    drift_checks: u64,
    move_start: Option<u64>,
    move_end: Option<u64>,
    /// A moving marker is on disk.
    marked: bool,
    /// The (from, target) of that marker.
    marker: Option<(i64, i64)>,
    /// Direction of the last move (+1/-1), for the DIR line level.
    last_dir: i64,
    /// The driver's ENABLE line.
    driver: driver::Driver,
}

impl Axis {
    fn record(&self, moving: Option<MovingMarker>, sim_position: i64) -> AxisRecord {
        AxisRecord {
            position: self.count,
            homed: self.homed,
            trusted: self.trusted,
            moving,
            sim_position,
            slack: self.slack,
        }
    }

    fn backlash(&self) -> i64 {
        self.settings.backlash as i64
    }

    /// The slack once the motor count reads `motor` (the motion under way, if any).
    fn slack_at(&self, motor: i64) -> i64 {
        match &self.motion {
            Some(m) => slack_after(m.slack0, motor - m.motor0, self.backlash()),
            None => self.slack,
        }
    }

    /// Motor steps a move of `d` steps of the load makes: |d| plus the slack still to
    /// take up in its direction (none for a move that goes on the same way).
    fn motor_steps(&self, d: i64) -> u64 {
        let take_up = match d.signum() {
            1 => self.backlash() - self.slack,
            -1 => self.slack,
            _ => return 0,
        };
        d.unsigned_abs() + take_up.max(0) as u64
    }

    fn period(&self) -> Option<i64> {
        self.settings.period.map(|p| p as i64)
    }
}

/// The slack after the motor moved `moved` steps (one way) from slack `slack0`: the
/// motor crosses the dead band [0, backlash] before it drives the load.
fn slack_after(slack0: i64, moved: i64, backlash: i64) -> i64 {
    slack0.saturating_add(moved).clamp(0, backlash.max(0))
}

/// `x` reduced to the shortest signed way around a period: (-P/2, P/2].
fn shortest(x: i64, p: i64) -> i64 {
    let r = x.rem_euclid(p);
    if 2 * r > p {
        r - p
    } else {
        r
    }
}

pub struct Board {
    name: String,
    clock_hz: f64,
    tdm: TdmConfig,
    axes: Vec<Axis>,
    store: Arc<Store>,
    estopped: bool,
    now: u64,
    /// Problems met while advancing (store failures), reported by `info`.
    warnings: Vec<String>,
    /// The pins: simulated mechanics and sensors, or the FPGA board.
    pins: Box<dyn BoardBackend>,
    /// The next group start arms it for the SYNC line instead (board/sync.rs).
    arming: bool,
    /// The tick of a halt asked for and not yet applied (`u64::MAX`: none): time does not
    /// advance past it meanwhile (see [`Board::set_halt_tick`]).
    halt_tick: Arc<AtomicU64>,
    /// The board's crystal against host time, and the tracking rates corrected by it.
    clock: clock::BoardClock,
}

/// The stored settings of an axis, brought into range; `None` (use the board config) if
/// there are none or they cannot be read. What was changed goes to `warnings`.
fn stored_settings(store: &Store, axis: &str, warnings: &mut Vec<String>) -> Option<AxisSettings> {
    let mut s = match store.settings(axis) {
        Ok(s) => s?,
        Err(e) => {
            warnings.push(format!(
                "axis {axis}: stored settings unreadable ({e}); using the board config"
            ));
            return None;
        }
    };
    for note in s.clamp_to_ranges() {
        warnings.push(format!("axis {axis}: stored {note}"));
    }
    match s.validate() {
        Ok(()) => {
            let _ = store.put_settings(axis, &s);
            Some(s)
        }
        Err(e) => {
            warnings.push(format!(
                "axis {axis}: stored settings refused ({e}); using the board config"
            ));
            None
        }
    }
}

impl Board {
    /// Opens the board: settings from the store (else the config), positions restored;
    /// an axis that was moving when the board died comes back untrusted and unhomed.
    #[cfg(feature = "sim")]
    pub fn open(config: &BoardConfig, store: Store) -> Result<Board, CtlError> {
        let sim = crate::backend::SimBackend::new(config.board.clock_hz, config.axes.len());
        Board::open_with(config, store, Box::new(sim))
    }

    /// [`Board::open`] on the given pins. A backend that reads its counts back from
    /// hardware keeps them; an axis whose count differs from the stored one comes back
    /// untrusted.
    pub fn open_with(
        config: &BoardConfig,
        store: Store,
        mut pins: Box<dyn BoardBackend>,
    ) -> Result<Board, CtlError> {
        config.validate()?;
        let store = Arc::new(store);
        let clock_hz = pins.clock_hz().unwrap_or(config.board.clock_hz);
        // a board that kept this host's session: its counts and motions go on
        let adopted = pins.adopted();
        let mut axes = Vec::new();
        let mut warnings = Vec::new();
        let sim = store.sim();
        let homings = adopt::stored_homings(&store, config);
        for ac in &config.axes {
            let settings = match stored_settings(&store, &ac.name, &mut warnings) {
                Some(s) => s,
                None => ac.settings.clone(),
            };
            let rec = store.axis(&ac.name)?.unwrap_or_default();
            let mut sim_pos = rec.sim_position;
            let slack = rec.slack.clamp(0, settings.backlash as i64);
            let mut axis = Axis {
                name: ac.name.clone(),
                settings,
                count: rec.position,
                slack,
                homed: rec.homed,
                trusted: rec.trusted,
                state: AxisState::Idle,
                fault: None,
                motion: None,
                drift: None,
                drift_checks: 0,
                move_start: None,
                move_end: None,
                marked: false,
                marker: None,
                last_dir: 1,
                driver: driver::Driver::default(),
            };
            let i = axes.len();
            // a motion the adopted board still runs goes on: `moving` until it ends
            if let Some(dir) = pins.adopted_motion(i).filter(|_| adopted) {
                axis.last_dir = dir;
                axis.state = AxisState::Moving;
                // the record was written as the motion began: its position and slack
                let from = rec.moving.as_ref().map_or(rec.position, |m| m.from);
                axis.motion = Some(Motion {
                    dir,
                    target: rec
                        .moving
                        .as_ref()
                        .map_or(pins.count(i) - slack, |m| m.target),
                    motor0: from + slack,
                    slack0: slack,
                    purpose: Purpose::Move,
                    stopping: false,
                    edge: None,
                    track: None,
                });
            }
            if let Some(m) = rec.moving.clone().filter(|_| adopted) {
                // The host died mid-move, the board did not: the count is the board's.
                pins.configure(i, &axis.settings);
                let motor = pins.count(i);
                axis.slack = axis.slack_at(motor);
                axis.count = motor - axis.slack;
                if axis.motion.is_some() {
                    axis.marked = true;
                    axis.marker = Some((m.from, m.target));
                } else {
                    store.put_axis(&axis.name, &axis.record(None, axis.count))?;
                }
            } else if let Some(m) = rec.moving {
                // Died mid-move: the count says `from`; the mechanics stayed where they were
                // (last written down while moving, else where the move began). Untrusted
                // until homed.
                axis.count = m.from;
                if let Some(sm) = sim.get(&ac.name) {
                    if (sm.from, sm.target) == (m.from, m.target) {
                        sim_pos = sm.sim_position;
                    }
                }
                axis.homed = false;
                axis.trusted = false;
                store.put_axis(&axis.name, &axis.record(None, sim_pos))?;
            }
            pins.configure(i, &axis.settings);
            pins.attach(i, axis.count + axis.slack, sim_pos);
            let read = pins.count(i);
            if read != axis.count + axis.slack && !axis.marked {
                warnings.push(format!(
                    "axis {}: the board counts {read}, the store says {}; untrusted until homed",
                    axis.name,
                    axis.count + axis.slack
                ));
                axis.count = read - axis.slack;
                axis.homed = false;
                axis.trusted = false;
                store.put_axis(&axis.name, &axis.record(None, pins.sim_position(i)))?;
            }
            axes.push(axis);
        }
        if adopted {
            adopt::end_adopted_homings(&mut axes, pins.as_mut(), &store, &mut warnings, &homings)?;
        }
        let kept = store.clone();
        pins.keep_session(Box::new(move |s| {
            kept.put_link_session(s).map_err(|e| e.to_string())
        }));
        Ok(Board {
            name: config.board.name.clone(),
            clock_hz,
            tdm: config.board.tdm(),
            axes,
            store,
            estopped: false,
            now: 0,
            warnings,
            pins,
            arming: false,
            halt_tick: Arc::new(AtomicU64::new(u64::MAX)),
            clock: clock::BoardClock::new(clock_hz),
        })
    }

    /// Limits the work of one `advance` (steps plus sensor events): past it the board's
    /// clock falls behind the wall clock instead of holding every command up. `None`
    /// (the default, for virtual time) advances all the way.
    /// Shares the tick of a pending halt with whoever asks for halts without the board: an
    /// advance under way when a halt is asked for stops there, so the halt applies at the
    /// tick it was asked at.
    pub fn set_halt_tick(&mut self, tick: Arc<AtomicU64>) {
        self.halt_tick = tick;
    }

    /// Shares the flag set while a halt waits for the board: the backend's batches of
    /// link frames end early for it.
    pub fn set_halt_flag(&mut self, flag: Arc<std::sync::atomic::AtomicBool>) {
        self.pins.set_urgent_flag(flag);
    }

    pub fn set_work_budget(&mut self, budget: Option<u64>) {
        self.pins.set_work_budget(budget);
    }

    /// Work done so far (steps plus sensor events), and the most any one advance did.
    pub fn work(&self) -> (u64, u64) {
        self.pins.work()
    }

    /// This board with its simulated pins as hardware is: the simulation's own commands
    /// (`sim …`) are refused.
    #[cfg(feature = "sim")]
    pub fn without_simulation(mut self) -> Board {
        if self.pins.is_simulated() {
            let mut sim = crate::backend::SimBackend::new(self.clock_hz, self.axes.len())
                .without_simulation();
            for (i, ax) in self.axes.iter().enumerate() {
                sim.configure(i, &ax.settings);
                sim.attach(i, ax.count + ax.slack, self.pins.sim_position(i));
            }
            self.pins = Box::new(sim);
        }
        self
    }

    pub fn is_simulated(&self) -> bool {
        self.pins.is_simulated()
    }

    /// What stands behind the axes: "simulated" or the board's link.
    pub fn backend(&self) -> String {
        self.pins.describe()
    }

    /// The board's own e-stop input is active.
    pub fn estop_input(&self) -> bool {
        self.pins.estop_input()
    }

    /// True while time must be advanced: an axis moves, an idle driver waits for its
    /// release, or hardware needs polling also while idle (board resets, its e-stop input,
    /// the link).
    pub fn needs_polling(&self) -> bool {
        self.busy() || self.release_pending() || self.pins.polls_when_idle()
    }

    pub fn name(&self) -> &str {
        &self.name
    }
    pub fn clock_hz(&self) -> f64 {
        self.clock_hz
    }
    pub fn now(&self) -> u64 {
        self.now
    }
    pub fn axis_names(&self) -> Vec<String> {
        self.axes.iter().map(|a| a.name.clone()).collect()
    }
    pub fn is_estopped(&self) -> bool {
        self.estopped
    }
    /// True while any axis moves or homes.
    pub fn busy(&self) -> bool {
        self.axes.iter().any(|a| a.motion.is_some())
    }

    /// The named axes, or all of them when none are named.
    fn indices(&self, axes: &[String]) -> Result<Vec<usize>, CtlError> {
        if axes.is_empty() {
            Ok((0..self.axes.len()).collect())
        } else {
            axes.iter().map(|a| self.index(a)).collect()
        }
    }

    /// An axis by name or, when no axis has that name, by its 0-based number on the board.
    fn index(&self, name: &str) -> Result<usize, CtlError> {
        self.axes
            .iter()
            .position(|a| a.name == name)
            .or_else(|| axis_number(name).filter(|&i| i < self.axes.len()))
            .ok_or_else(|| CtlError::UnknownAxis(name.to_string()))
    }

    // ---- time ----------------------------------------------------------------------------

    /// Runs every axis up to tick `now`: steps, sensor, homing phases, persistence.
    /// With a work budget (see [`Board::set_work_budget`]) the backend may stop short of
    /// `now`; the board's clock then falls behind.
    pub fn advance(&mut self, now: u64) {
        let now = now.min(self.halt_tick.load(Ordering::SeqCst)).max(self.now);
        self.pins.begin_advance();
        loop {
            // A jog lease lapsing first: run up to it, then stop that axis there.
            let until = self.next_lease().map_or(now, |l| l.min(now));
            while let Some((i, ev)) = self.pins.poll(until) {
                self.sync_count(i);
                self.on_event(i, ev);
            }
            self.now = self.pins.now().max(self.now);
            if self.now < until || !self.stop_lapsed_leases() {
                break;
            }
        }
        for i in 0..self.axes.len() {
            self.sync_count(i);
            self.track_wrap(i);
        }
        self.release_idle();
    }

    /// The axis's slack and load position from the backend's (motor) count.
    fn sync_count(&mut self, i: usize) {
        let motor = self.pins.count(i);
        let ax = &mut self.axes[i];
        ax.slack = ax.slack_at(motor);
        ax.count = motor - ax.slack;
    }

    /// Shifts axis `i`'s count by `delta` (motor and load alike: the slack is kept).
    pub(super) fn rebase(&mut self, i: usize, delta: i64, mechanics: bool) -> Result<(), CtlError> {
        self.pins.rebase(i, delta, mechanics)?;
        if let Some(m) = self.axes[i].motion.as_mut() {
            m.motor0 += delta;
        }
        self.sync_count(i);
        Ok(())
    }

    fn on_event(&mut self, i: usize, ev: PinEvent) {
        match ev {
            PinEvent::Sensor {
                edge,
                speed,
                triggered,
            } => {
                self.on_sensor(i, edge, speed, triggered);
                self.track_step(i);
            }
            PinEvent::Step => self.track_step(i),
            PinEvent::End { end } => {
                let Some(m) = self.axes[i].motion.take() else {
                    return;
                };
                let end = end.max(self.axes[i].move_start.unwrap_or(0));
                self.on_motion_end(i, m, end);
            }
            PinEvent::Lost { why } => {
                let now = self.pins.now();
                let ax = &mut self.axes[i];
                eprintln!("warning: board {}: axis {}: {why}", self.name, ax.name);
                if self.warnings.len() < 100 {
                    self.warnings.push(format!("axis {}: {why}", ax.name));
                }
                if ax.motion.take().is_some() {
                    ax.state = AxisState::Fault;
                    ax.fault = Some(why);
                    ax.move_end = Some(now);
                }
                ax.homed = false;
                ax.trusted = false;
                ax.marked = false;
                self.persist(i);
            }
            PinEvent::Late { why } => {
                self.axis_fault(i, why);
                self.persist(i);
            }
            PinEvent::Estop => self.estop_now(),
        }
    }

    fn on_sensor(&mut self, i: usize, ev: FilteredEdge, speed: f64, triggered: Option<i64>) {
        let ax = &mut self.axes[i];
        let Some(m) = ax.motion.as_mut() else { return };
        let h = ax.settings.home_dir as i64;
        let b = ax.settings.backlash as i64;
        let slack = slack_after(m.slack0, ev.count_at_start - m.motor0, b);
        // Homing takes its edge with the slack taken up towards home_dir: only such a pass
        // is compared, and then motor and load are a fixed distance apart, whichever of
        // them the sensor sees.
        let taken_up = slack == if h > 0 { b } else { 0 };
        if m.purpose == Purpose::Move && ev.active && m.dir == h && !m.stopping && taken_up {
            // Closed-loop check (seed 002 §2.3): entering the sensor in the homing
            // direction, the count must read home_offset at the edge.
            let mut d = ev.count_at_start - slack - ax.settings.home_offset;
            if let Some(p) = ax.settings.period {
                d = shortest(d, p as i64);
            }
            ax.drift = Some(d);
            ax.drift_checks += 1;
            // A confirmed edge is early by at most what the axis covers in two
            // debounce times (see hall.rs).
            let tol = 1 + (2.0 * speed * ax.settings.debounce).ceil() as i64;
            if ax.homed && d.abs() > tol {
                ax.trusted = false;
            }
        }
        if let Some(target) = triggered {
            m.edge = Some(ev);
            m.stopping = true;
            m.target = target - slack_after(m.slack0, target - m.motor0, b);
        }
    }

    fn on_motion_end(&mut self, i: usize, m: Motion, end: u64) {
        let ax = &mut self.axes[i];
        ax.move_end = Some(end);
        ax.driver.idle_since = end;
        self.wrap_into_period(i);
        let ax = &mut self.axes[i];
        ax.state = AxisState::Idle;
        let result = match m.purpose {
            Purpose::Move => Ok(()),
            Purpose::Home(phase) => self.next_home_phase(i, phase, &m, end),
        };
        if let Err(e) = result {
            let ax = &mut self.axes[i];
            ax.state = AxisState::Fault;
            ax.fault = Some(e.to_string());
        }
        self.persist(i);
        if let Some(t) = m.track {
            self.track_ended(i, t, m.dir, end);
        }
    }

    /// A periodic axis's count into `[0, period)`: the same place, renamed.
    pub(super) fn wrap_into_period(&mut self, i: usize) {
        let ax = &self.axes[i];
        let Some(p) = ax.period() else { return };
        let shift = ax.count.rem_euclid(p) - ax.count;
        if shift == 0 {
            return;
        }
        if let Err(e) = self.rebase(i, shift, true) {
            let name = &self.axes[i].name;
            self.warnings.push(format!("axis {name}: {e}"));
        }
    }

    /// Writes the axis record. While a sequence of moves runs (homing phases, the park
    /// after homing) the marker written at its start stays on disk, untouched.
    fn persist(&mut self, i: usize) {
        let ax = &mut self.axes[i];
        if ax.motion.is_some() && ax.marked {
            return;
        }
        let marker = ax.motion.as_ref().map(|m| MovingMarker {
            from: ax.count,
            target: m.target,
            homing: matches!(m.purpose, Purpose::Home(_)),
        });
        ax.marked = marker.is_some();
        ax.marker = marker.as_ref().map(|m| (m.from, m.target));
        let rec = ax.record(marker, self.pins.sim_position(i));
        if let Err(e) = self.store.put_axis(&ax.name, &rec) {
            // The disk holds an older record (the store writes this one once it can).
            self.axis_fault(i, format!("position not stored: {e}"));
        }
    }

    /// A fault of axis `i`, said on stderr and in `info`. Reported after the motion's end,
    /// the axis shows it until its next motion.
    fn axis_fault(&mut self, i: usize, why: String) {
        let ax = &mut self.axes[i];
        eprintln!("warning: board {}: axis {}: {why}", self.name, ax.name);
        if self.warnings.len() < 100 {
            self.warnings.push(format!("axis {}: {why}", ax.name));
        }
        if ax.motion.is_none() {
            ax.state = AxisState::Fault;
        }
        ax.fault = Some(why);
    }

    // ---- starting motion -----------------------------------------------------------------

    /// Starts a planned move on axis `i` at tick `start`, marker first.
    fn launch(
        &mut self,
        i: usize,
        p: Profile,
        datapath: Option<IntProfile>,
        dir: i64,
        purpose: Purpose,
        start: u64,
    ) -> Result<(), CtlError> {
        let stop_on_sensor = match purpose {
            Purpose::Home(phase) => phase.stop_on_sensor(),
            Purpose::Move => None,
        };
        let l = Launch {
            axis: i,
            datapath,
            dir,
            stop_on_sensor,
            // From rest: the filter has long settled on the present level. (Homing phases
            // follow each other without a resync, so the sensor's history carries over.)
            resync_sensor: purpose == Purpose::Move,
            profile: p,
        };
        self.launch_group(vec![(l, purpose)], None, start)
            .map(|_| ())
    }

    /// Starts moves together through the backend (TDM-timed with a `report`), each
    /// axis's moving marker durable first. Returns the start tick.
    fn launch_group(
        &mut self,
        moves: Vec<(Launch, Purpose)>,
        report: Option<&multistep_core::tdm::Report>,
        now: u64,
    ) -> Result<u64, CtlError> {
        let mut marked = Vec::new();
        let mut launches = Vec::new();
        for (l, purpose) in moves {
            let steps = l.profile.steps();
            if let Err(e) = self.launch_source(l.axis, steps, l.dir, purpose, now) {
                self.unlaunch(&marked);
                return Err(e);
            }
            marked.push(l.axis);
            launches.push(l);
        }
        let started = if self.arming {
            self.pins.sync_line().and_then(|s| s.arm(launches, now))
        } else {
            self.pins.start(launches, report, &self.tdm, now)
        };
        match started {
            Ok((start, _)) => {
                for &i in &marked {
                    self.axes[i].move_start = Some(start);
                }
                Ok(start)
            }
            Err(e) => {
                self.unlaunch(&marked);
                Err(e)
            }
        }
    }

    /// Takes back moves whose start failed: idle again, markers off the disk.
    fn unlaunch(&mut self, axes: &[usize]) {
        for &i in axes {
            let ax = &mut self.axes[i];
            ax.motion = None;
            ax.state = AxisState::Idle;
            ax.move_start = ax.move_end;
            ax.marked = false;
            self.persist(i);
        }
    }

    /// The bookkeeping of a move of `steps` motor steps on axis `i` from `start`; the
    /// moving marker is written first (once per sequence of moves).
    fn launch_source(
        &mut self,
        i: usize,
        steps: u64,
        dir: i64,
        purpose: Purpose,
        start: u64,
    ) -> Result<(), CtlError> {
        let sim_pos = self.pins.sim_position(i);
        let ax = &mut self.axes[i];
        let moved = dir * steps as i64;
        let target = ax.count + ax.slack + moved - slack_after(ax.slack, moved, ax.backlash());
        if !ax.marked {
            let rec = ax.record(
                Some(MovingMarker {
                    from: ax.count,
                    target,
                    homing: matches!(purpose, Purpose::Home(_)),
                }),
                sim_pos,
            );
            self.store.put_axis(&ax.name, &rec)?;
            ax.marked = true;
            ax.marker = Some((ax.count, target));
        }
        ax.motion = Some(Motion {
            dir,
            target,
            motor0: ax.count + ax.slack,
            slack0: ax.slack,
            purpose,
            stopping: false,
            edge: None,
            track: None,
        });
        ax.state = AxisState::Moving;
        ax.fault = None;
        ax.move_start = Some(start);
        ax.move_end = None;
        ax.last_dir = dir;
        Ok(())
    }

    /// Starts a move given as its step source on axis `i` at `start` (simulated pins).
    pub fn launch_step_source(
        &mut self,
        i: usize,
        src: Box<dyn StepSource>,
        dir: i64,
        start: u64,
    ) -> Result<(), CtlError> {
        self.check_can_move(i)?;
        let steps = src.steps_left();
        self.launch_source(i, steps, dir, Purpose::Move, start)?;
        if let Err(e) = self.pins.start_source(i, src, dir, start) {
            self.unlaunch(&[i]);
            return Err(e);
        }
        Ok(())
    }

    /// The backend's own plan of the move `spec` (see [`BoardBackend::plan_datapath`]);
    /// the host's profile stays the reference for speeds and timing.
    fn datapath(&self, spec: &MoveSpec) -> Result<Option<IntProfile>, CtlError> {
        self.pins.plan_datapath(spec)
    }

    fn check_can_move(&self, i: usize) -> Result<(), CtlError> {
        if self.estopped {
            return Err(CtlError::EStopped);
        }
        let ax = &self.axes[i];
        match ax.state {
            AxisState::Moving | AxisState::Homing | AxisState::Tracking => Err(CtlError::Busy {
                axis: ax.name.clone(),
                state: ax.state.name(),
            }),
            _ => Ok(()),
        }
    }

    /// Busy unless axis `i` has no motion under way.
    pub(super) fn check_at_rest(&self, i: usize) -> Result<(), CtlError> {
        let ax = &self.axes[i];
        match ax.motion {
            Some(_) => Err(CtlError::Busy {
                axis: ax.name.clone(),
                state: ax.state.name(),
            }),
            None => Ok(()),
        }
    }

    fn amount_steps(&self, i: usize, a: Amount) -> Result<i64, CtlError> {
        match a {
            Amount::Steps(n) => Ok(n),
            Amount::Units(u) => {
                let x = (u * self.axes[i].settings.steps_per_unit).round();
                if x.abs() <= MAX_POSITION as f64 {
                    Ok(x as i64)
                } else {
                    Err(CtlError::syntax(format!(
                        "{u} units is {x:e} microsteps, outside ±{MAX_POSITION}"
                    )))
                }
            }
        }
    }

    /// The signed number of steps a move makes: periodic axes take the shortest way
    /// (seed 002 §2.1: the part beyond the period is dropped); others are checked against
    /// the soft limits.
    fn delta(&self, i: usize, amount: Amount, absolute: bool) -> Result<i64, CtlError> {
        let ax = &self.axes[i];
        let n = self.amount_steps(i, amount)?;
        if let Some(p) = ax.period() {
            // Reduced first: no overflow whatever n is (the count is already in [0, p)).
            let r = n.rem_euclid(p);
            return Ok(shortest(if absolute { r - ax.count } else { r }, p));
        }
        // i128: a target of i64::MIN or a sum that overflows is reported as it is.
        let target = if absolute {
            n as i128
        } else {
            ax.count as i128 + n as i128
        };
        let s = &ax.settings;
        let max = MAX_POSITION as i128;
        let (lo, hi) = (
            s.soft_min.map_or(-max, |x| x as i128).max(-max),
            s.soft_max.map_or(max, |x| x as i128).min(max),
        );
        if target < lo || target > hi {
            return Err(CtlError::OutOfLimits {
                axis: ax.name.clone(),
                target,
                min: lo.to_string(),
                max: hi.to_string(),
            });
        }
        Ok(target as i64 - ax.count)
    }

    fn resolve_opts(&self, opts: &MoveOpts) -> Result<MoveOpts, CtlError> {
        match &opts.preset {
            None => Ok(opts.clone()),
            Some(name) => {
                let p = self
                    .store
                    .preset(name)?
                    .ok_or_else(|| CtlError::UnknownName {
                        what: "preset",
                        name: name.clone(),
                    })?;
                Ok(opts.over(&p))
            }
        }
    }

    /// The core's move description for `steps` on axis `i`: explicit options, then the
    /// preset, then the axis defaults; limits mode unless phase times are given.
    fn spec<'a>(&self, i: usize, steps: u64, o: &'a MoveOpts) -> MoveSpec<'a> {
        let s = &self.axes[i].settings;
        let mut spec = MoveSpec {
            profile: o.profile.as_deref(),
            steps: Some(steps),
            params: o.params,
            ..MoveSpec::default()
        };
        let p = &mut spec.params;
        if o.has_phase_times() {
            (p.vmax, p.amax, p.jmax, p.smax) = (None, None, None, None);
        } else {
            (p.accel_time, p.cruise_time, p.decel_time) = (None, None, None);
            p.vmax = Some(p.vmax.unwrap_or(s.vmax));
            p.amax = Some(p.amax.unwrap_or(s.amax));
            p.jmax = p.jmax.or(s.jmax);
            p.smax = p.smax.or(s.smax);
        }
        spec
    }

    fn check_peaks(&self, i: usize, p: &Profile) -> Result<(), CtlError> {
        let s = &self.axes[i].settings;
        let (v, a) = p.peaks();
        let tol = 1.0 + 1e-9;
        if v > s.vmax * tol || a > s.amax * tol {
            return Err(CtlError::TooFast(format!(
                "axis {}: the move peaks at {v:.3} steps/s and {a:.3} steps/s², above vmax {} / amax {}",
                self.axes[i].name, s.vmax, s.amax
            )));
        }
        Ok(())
    }

    fn family_name<'a>(&'a self, i: usize, o: &'a MoveOpts) -> &'a str {
        o.profile
            .as_deref()
            .unwrap_or(&self.axes[i].settings.profile)
    }

    fn plan(&self, i: usize, steps: u64, opts: &MoveOpts) -> Result<Profile, CtlError> {
        let mut o = self.resolve_opts(opts)?;
        o.profile = Some(self.family_name(i, &o).to_string());
        let p = self.spec(i, steps, &o).plan_on_clock(self.clock_hz)?;
        self.check_peaks(i, &p)?;
        Ok(p)
    }

    // ---- commands ------------------------------------------------------------------------

    /// Relative (`absolute == false`) or absolute move of one axis, started at `now`.
    pub fn move_axis(
        &mut self,
        axis: &str,
        amount: Amount,
        absolute: bool,
        opts: &MoveOpts,
        now: u64,
    ) -> Result<i64, CtlError> {
        self.group_move(&[(axis.to_string(), amount)], absolute, false, opts, now)
            .map(|t| t[0])
    }

    /// Moves several axes starting on the same tick; with `sync` they also finish on the
    /// same tick. Returns the targets. Nothing starts unless every axis can.
    pub fn group_move(
        &mut self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
        now: u64,
    ) -> Result<Vec<i64>, CtlError> {
        let pending = self.plan_group_move(targets, absolute, sync, opts, now)?;
        let report = pending.time()?;
        self.start_group_move(pending, report.as_ref(), now)
    }

    /// The first half of [`Board::group_move`]: plans the group from the positions now.
    /// Its TDM timing ([`PendingGroup::time`]) needs no board, so a service can run it
    /// without holding the board up, then call [`Board::start_group_move`].
    pub fn plan_group_move(
        &mut self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
        now: u64,
    ) -> Result<PendingGroup, CtlError> {
        self.advance(now);
        let (plan, profiles) = self.plan_group(targets, absolute, sync, opts)?;
        let datapaths = self.plan_datapaths(&plan, &profiles, sync, opts)?;
        let before = plan
            .iter()
            .map(|&(i, _)| (self.axes[i].count, self.axes[i].settings.clone()))
            .collect();
        Ok(PendingGroup {
            plan,
            profiles,
            datapaths,
            before,
            tdm: self.tdm,
        })
    }

    /// The second half of [`Board::group_move`]: starts a planned, timed group, unless an
    /// axis of it moved, changed or was stopped meanwhile (then nothing starts and the
    /// answer is `Busy`: plan again).
    pub fn start_group_move(
        &mut self,
        pending: PendingGroup,
        report: Option<&multistep_core::tdm::Report>,
        now: u64,
    ) -> Result<Vec<i64>, CtlError> {
        self.advance(now);
        let PendingGroup {
            plan,
            profiles,
            datapaths,
            before,
            ..
        } = pending;
        for (&(i, _), (count, settings)) in plan.iter().zip(&before) {
            self.check_can_move(i)?;
            let ax = &self.axes[i];
            if ax.count != *count || ax.settings != *settings {
                // Another move ran meanwhile: as if this one came while it ran.
                return Err(CtlError::Busy {
                    axis: ax.name.clone(),
                    state: AxisState::Moving.name(),
                });
            }
        }
        // One TDM run times the whole group: one start tick for every axis.
        let mut launches = Vec::new();
        for ((&(i, d), p), datapath) in plan.iter().zip(profiles).zip(datapaths) {
            if let Some(profile) = p {
                let l = Launch {
                    axis: i,
                    profile,
                    datapath,
                    dir: d.signum(),
                    stop_on_sensor: None,
                    resync_sensor: true,
                };
                launches.push((l, Purpose::Move));
            }
        }
        // One start tick for the group, once every moving axis's driver is energized and
        // settled.
        let start = if launches.is_empty() {
            self.now
        } else {
            let ready = self.energize_for_motion(launches.iter().map(|l| l.0.axis))?;
            self.launch_group(launches, report, ready)?
        };
        let mut out = Vec::new();
        for &(i, d) in &plan {
            let ax = &mut self.axes[i];
            if d == 0 || ax.motion.is_none() {
                ax.move_start = Some(start);
                ax.move_end = Some(start);
            }
            let t = ax.count + d;
            out.push(ax.period().map_or(t, |p| t.rem_euclid(p)));
        }
        Ok(out)
    }

    /// The backend's own plans of a planned group's moves.
    fn plan_datapaths(
        &self,
        plan: &[(usize, i64)],
        profiles: &[Option<Profile>],
        sync: bool,
        opts: &MoveOpts,
    ) -> Result<Vec<Option<IntProfile>>, CtlError> {
        let o = self.resolve_opts(opts)?;
        // A sync group's phases, in whole ticks: the same on every axis (plan_sync gives
        // every axis the phase times ta·s, tb·s, tc·s).
        let (ta, tb, tc) = sync_phases(&o);
        let whole = |t: f64| (t * self.clock_hz).round() / self.clock_hz;
        plan.iter()
            .zip(profiles)
            .map(|(&(i, d), p)| {
                let Some(p) = p else { return Ok(None) };
                let mut o = o.clone();
                o.profile = Some(self.family_name(i, &o).to_string());
                if sync {
                    let s = p.duration() / (ta + tb + tc);
                    let p = &mut o.params;
                    (p.accel_time, p.cruise_time, p.decel_time) = (
                        Some(whole(ta * s)),
                        Some(whole(tb * s)),
                        Some(whole(tc * s)),
                    );
                    (p.start_speed, p.end_speed) = (None, None);
                }
                self.datapath(&self.spec(i, self.axes[i].motor_steps(d), &o))
            })
            .collect()
    }

    /// Same start and finish: every axis gets the same phase times (a quarter accelerating,
    /// half cruising, a quarter decelerating unless given), stretched until every axis is
    /// within its vmax and amax. Peaks scale as 1/s and 1/s² with the time scale s.
    fn plan_sync(
        &self,
        plan: &[(usize, i64)],
        opts: &MoveOpts,
    ) -> Result<Vec<Option<Profile>>, CtlError> {
        let opts = self.resolve_opts(opts)?;
        let (ta, tb, tc) = sync_phases(&opts);
        let phase = |i: usize, d: i64, s: f64| -> Result<Profile, CtlError> {
            let mut o = opts.clone();
            o.profile = Some(self.family_name(i, &opts).to_string());
            let p = &mut o.params;
            (p.accel_time, p.cruise_time, p.decel_time) =
                (Some(ta * s), Some(tb * s), Some(tc * s));
            (p.start_speed, p.end_speed) = (None, None);
            Ok(self
                .spec(i, self.axes[i].motor_steps(d), &o)
                .plan_on_clock(self.clock_hz)?)
        };
        let mut scale: f64 = if opts.has_phase_times() { 1.0 } else { 0.0 };
        for &(i, d) in plan.iter().filter(|p| p.1 != 0) {
            let (v, a) = phase(i, d, 1.0)?.peaks();
            let s = &self.axes[i].settings;
            scale = scale.max(multistep_core::time_scale(v, a, s.vmax, s.amax));
        }
        plan.iter()
            .map(|&(i, d)| {
                if d == 0 {
                    return Ok(None);
                }
                let p = phase(i, d, scale * (1.0 + 1e-12))?;
                self.check_peaks(i, &p)?;
                Ok(Some(p))
            })
            .collect()
    }

    /// Controlled stop (decelerates at amax) of one axis or all; homing is abandoned.
    pub fn stop(&mut self, axis: Option<&str>, now: u64) -> Result<(), CtlError> {
        self.advance(now);
        let which: Vec<usize> = match axis {
            Some(a) => vec![self.index(a)?],
            None => (0..self.axes.len()).collect(),
        };
        for i in which {
            if self.stop_tracking(i) {
                continue;
            }
            let b = self.axes[i].backlash();
            if let Some(m) = self.axes[i].motion.as_mut() {
                m.purpose = Purpose::Move;
                if !m.stopping {
                    m.stopping = true;
                    let motor = self.pins.stop(i, self.now)?;
                    m.target = motor - slack_after(m.slack0, motor - m.motor0, b);
                }
                self.axes[i].state = AxisState::Moving;
            }
        }
        Ok(())
    }

    /// Emergency stop: every axis halts on the spot and the board refuses motion until
    /// `reset`. An axis that was moving is marked untrusted: a real motor halted at speed
    /// can slip, so its count may be wrong (the simulation itself loses no steps).
    pub fn estop(&mut self, now: u64) {
        self.advance(now);
        self.estop_now();
    }

    /// [`Board::estop`] at the board's present tick.
    fn estop_now(&mut self) {
        let halted = self.estop_halt();
        self.record_halted(halted);
    }

    /// The first half of [`Board::estop`]: the pins halt and the board refuses motion.
    /// The halted axes' records are written by [`Board::record_halted`] (disk writes: a
    /// service answers the e-stop before them).
    pub fn estop_latch(&mut self, now: u64) -> Halted {
        self.advance(now);
        self.estop_halt()
    }

    fn estop_halt(&mut self) -> Halted {
        self.estopped = true;
        self.pins.estop(self.now);
        let mut halted = Vec::new();
        for (i, ax) in self.axes.iter_mut().enumerate() {
            if ax.motion.take().is_some() {
                ax.state = AxisState::Fault;
                ax.fault = Some("emergency stop".into());
                ax.trusted = false;
                ax.move_end = Some(self.now);
                halted.push(i);
            }
        }
        Halted(halted)
    }

    /// Writes down the axes an e-stop halted (untrusted, no longer moving).
    pub fn record_halted(&mut self, halted: Halted) {
        for i in halted.0 {
            self.persist(i);
        }
    }

    /// Clears an emergency stop and axis faults.
    pub fn reset(&mut self, now: u64) {
        self.advance(now);
        if let Err(e) = self.pins.clear_estop() {
            if self.warnings.len() < 100 {
                self.warnings.push(format!("reset: {e}"));
            }
            return;
        }
        self.estopped = false;
        for ax in &mut self.axes {
            if ax.state == AxisState::Fault {
                ax.state = AxisState::Idle;
                ax.fault = None;
            }
        }
    }

    pub fn status(&mut self, axes: &[String], now: u64) -> Result<Vec<AxisStatus>, CtlError> {
        self.advance(now);
        self.status_now(axes)
    }

    /// [`Board::status`] as last advanced, without advancing (no link exchange).
    pub fn status_now(&self, axes: &[String]) -> Result<Vec<AxisStatus>, CtlError> {
        let idx = self.indices(axes)?;
        let store = self.store.check().word();
        let link_state = self.pins.link_state();
        Ok(idx
            .into_iter()
            .map(|i| {
                let ax = &self.axes[i];
                let speed = ax
                    .motion
                    .as_ref()
                    .map_or(0.0, |m| m.dir as f64 * self.pins.speed(i, self.now));
                let track = ax.motion.as_ref().and_then(|m| m.track.as_ref());
                // The link down: the axis cannot be reached, whatever it was doing.
                let link = self.pins.fault(i);
                AxisStatus {
                    axis: ax.name.clone(),
                    number: i,
                    position: ax.count,
                    units: ax.count as f64 / ax.settings.steps_per_unit,
                    state: if link.is_some() {
                        AxisState::Fault
                    } else {
                        ax.state
                    },
                    homed: ax.homed,
                    // Not reachable: its count cannot be confirmed.
                    trusted: ax.trusted && link.is_none(),
                    target: ax
                        .motion
                        .as_ref()
                        .filter(|_| track.is_none())
                        .map(|m| m.target),
                    speed,
                    sensor: self.pins.sensor(i),
                    slack: ax.slack,
                    drift: ax.drift,
                    drift_checks: ax.drift_checks,
                    move_start: ax.move_start,
                    move_end: match (&ax.motion, track) {
                        (Some(_), Some(_)) => None,
                        (Some(_), None) => self.pins.end_tick(i),
                        (None, _) => ax.move_end,
                    },
                    fault: link.or_else(|| ax.fault.clone()),
                    sim_position: self.pins.sim_position(i),
                    dir_level: (ax.last_dir > 0) != ax.settings.invert_dir,
                    rate: track.map(|t| t.signed_rate()),
                    clock_ppm: self.clock_state().ppm,
                    clock_fix: self.clock_fix(),
                    enabled: ax.driver.enabled,
                    enable_level: ax.driver.enabled == ax.settings.enable_active_high,
                    store: store.into(),
                    link: link_state.map(|l| if l.up { Link::Up } else { Link::Down }),
                    age_ms: link_state
                        .and_then(|l| l.read_at)
                        .map(|t| t.elapsed().as_millis() as u64),
                }
            })
            .collect())
    }

    /// The board is reached over a link ([`BoardBackend::link_state`]).
    pub fn has_link(&self) -> bool {
        self.pins.link_state().is_some()
    }

    pub fn settings(&self, axis: &str) -> Result<&AxisSettings, CtlError> {
        Ok(&self.axes[self.index(axis)?].settings)
    }

    /// Changes one setting (idle axes only) and stores it.
    pub fn set(&mut self, axis: &str, key: &str, value: &str, now: u64) -> Result<(), CtlError> {
        self.advance(now);
        let i = self.index(axis)?;
        if self.axes[i].motion.is_some() {
            let ax = &self.axes[i];
            return Err(CtlError::Busy {
                axis: ax.name.clone(),
                state: ax.state.name(),
            });
        }
        let mut s = self.axes[i].settings.clone();
        s.set(key, value)?;
        // stored under the name, also when the axis was given by number
        let name = self.axes[i].name.clone();
        self.store.put_settings(&name, &s)?;
        self.pins.configure(i, &s);
        let ax = &self.axes[i];
        let slack = new_slack(ax.slack, ax.backlash(), s.backlash as i64, ax.last_dir);
        let renamed = slack - ax.slack;
        self.axes[i].settings = s;
        if renamed != 0 {
            // The load stays where it is, the motor too: only its count is renamed.
            self.axes[i].slack = slack;
            self.rebase(i, renamed, true)?;
            self.persist(i);
        }
        // a new period applies at once: the position is read in [0, period) from now on
        if key == "period" && self.axes[i].period().is_some() {
            self.wrap_into_period(i);
            self.persist(i);
        }
        Ok(())
    }

    /// Saves the current positions of `axes` (all when empty) under `name`.
    pub fn save_position(
        &mut self,
        name: &str,
        axes: &[String],
        now: u64,
    ) -> Result<NamedPosition, CtlError> {
        self.advance(now);
        let idx = self.indices(axes)?;
        let mut pos = NamedPosition::new();
        for i in idx {
            let ax = &self.axes[i];
            if ax.motion.is_some() {
                return Err(CtlError::Busy {
                    axis: ax.name.clone(),
                    state: ax.state.name(),
                });
            }
            pos.insert(ax.name.clone(), ax.count);
        }
        self.store.put_named(name, &pos)?;
        Ok(pos)
    }

    /// Moves to a named position (a group move: same start tick).
    pub fn goto(&mut self, name: &str, opts: &MoveOpts, now: u64) -> Result<Vec<i64>, CtlError> {
        let targets = self.goto_targets(name)?;
        self.group_move(&targets, true, false, opts, now)
    }

    /// A named position as the absolute targets of a group move.
    pub fn goto_targets(&self, name: &str) -> Result<Vec<(String, Amount)>, CtlError> {
        let pos = self
            .store
            .named_position(name)?
            .ok_or_else(|| CtlError::UnknownName {
                what: "position",
                name: name.to_string(),
            })?;
        Ok(pos
            .into_iter()
            .map(|(a, p)| (a, Amount::Steps(p)))
            .collect())
    }

    /// A telescope mount's stored record (sync offsets), by the mount's key.
    pub fn mount_record(&self, key: &str) -> Result<Option<MountRecord>, CtlError> {
        self.store.mount(key)
    }
    pub fn put_mount_record(&mut self, key: &str, r: &MountRecord) -> Result<(), CtlError> {
        self.store.put_mount(key, r)
    }

    pub fn named_positions(&self) -> Result<BTreeMap<String, NamedPosition>, CtlError> {
        self.store.named()
    }

    pub fn forget(&mut self, name: &str) -> Result<(), CtlError> {
        if self.store.forget_named(name)? {
            Ok(())
        } else {
            Err(CtlError::UnknownName {
                what: "position",
                name: name.to_string(),
            })
        }
    }

    /// Stores a speed preset once its family and values pass a move's checks.
    pub fn set_preset(&mut self, name: &str, opts: &MoveOpts) -> Result<(), CtlError> {
        opts.check_values()?;
        self.store.put_preset(name, opts)
    }

    pub fn presets(&self) -> Result<BTreeMap<String, MoveOpts>, CtlError> {
        self.store.presets()
    }

    /// `setpos AXIS N`: an idle axis's count becomes `to` (reduced into the period, or
    /// within the soft limits), nothing moves — the same place renamed, as homing
    /// re-references it; stored like any position. The sensor's edge is no longer at
    /// `home_offset`, so the axis is no longer homed (its trust is unchanged).
    pub fn set_position(&mut self, axis: &str, to: Amount, now: u64) -> Result<i64, CtlError> {
        self.advance(now);
        let i = self.index(axis)?;
        self.check_at_rest(i)?;
        // as a moveto's target: reduced into the period, or checked against the limits
        let count = self.axes[i].count;
        let mut to = count + self.delta(i, to, true)?;
        if let Some(p) = self.axes[i].period() {
            to = to.rem_euclid(p);
        }
        self.rebase(i, to - count, true)?;
        let ax = &mut self.axes[i];
        ax.homed = false;
        self.persist(i);
        Ok(self.axes[i].count)
    }

    /// Simulation: the mechanics lose `steps` steps that the count does not see.
    pub fn sim_slip(&mut self, axis: &str, steps: i64, now: u64) -> Result<(), CtlError> {
        if !self.pins.is_simulated() {
            return Err(CtlError::NotSimulated);
        }
        self.advance(now);
        let i = self.index(axis)?;
        self.pins.slip(i, steps)?;
        self.persist(i);
        Ok(())
    }

    /// Writes down where the simulated mechanics of the moving axes are (see
    /// [`crate::store::SimMechanics`]); the service calls it often while axes move.
    pub fn save_sim(&mut self) {
        let m: BTreeMap<String, crate::store::SimMechanics> = self
            .axes
            .iter()
            .enumerate()
            .filter(|(_, a)| a.motion.is_some())
            .filter_map(|(i, a)| {
                let (from, target) = a.marker?;
                Some((
                    a.name.clone(),
                    crate::store::SimMechanics {
                        from,
                        target,
                        sim_position: self.pins.sim_position(i),
                    },
                ))
            })
            .collect();
        if let Err(e) = self.store.put_sim(&m) {
            if self.warnings.len() < 100 {
                self.warnings.push(e.to_string());
            }
        }
    }

    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// Whether the store's writes reach the disk (checked now, see [`Store::check`]).
    pub fn store_health(&self) -> crate::store::StoreHealth {
        self.store.check()
    }
}

/// The slack kept when the backlash changes from `old` to `new`: the same side (all or
/// none of the band), or, from no backlash, the side of the last move.
fn new_slack(slack: i64, old: i64, new: i64, last_dir: i64) -> i64 {
    if (old > 0 && slack == old) || (old == 0 && last_dir > 0) {
        new
    } else {
        slack.min(new)
    }
}

/// A sync group's phase times before stretching: as given, else a quarter accelerating,
/// half cruising, a quarter decelerating.
fn sync_phases(o: &MoveOpts) -> (f64, f64, f64) {
    if o.has_phase_times() {
        let p = &o.params;
        (
            p.accel_time.unwrap_or(0.0),
            p.cruise_time.unwrap_or(0.0),
            p.decel_time.unwrap_or(0.0),
        )
    } else {
        (0.25, 0.5, 0.25)
    }
}

/// A motor number: plain decimal digits (no sign, no leading zeros), as in `move 3 100`.
pub(crate) fn axis_number(word: &str) -> Option<usize> {
    let plain = word.bytes().all(|b| b.is_ascii_digit()) && (word == "0" || !word.starts_with('0'));
    if plain && word.len() <= 4 {
        word.parse().ok()
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::shortest;

    #[test]
    fn the_short_way_takes_a_half_turn_forward_never_backward() {
        // (-P/2, P/2]: the tie goes forward, so a rotator asked for half a turn
        // either way turns the same way
        assert_eq!(shortest(180, 360), 180);
        assert_eq!(shortest(-180, 360), 180);
        assert_eq!(shortest(540, 360), 180);
        assert_eq!(shortest(181, 360), -179);
        assert_eq!(shortest(-181, 360), 179);
        assert_eq!(shortest(179, 360), 179);
        assert_eq!(shortest(360, 360), 0);
        // an odd period has no tie
        assert_eq!((shortest(3, 7), shortest(4, 7)), (3, -3));
    }
}
