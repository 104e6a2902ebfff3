//! One controller board: its axes, their moves, homing, and the store. What happens at
//! the pins is a [`BoardBackend`] (simulated mechanics and sensors, or the FPGA board).
//! Time is explicit — every method takes the board tick `now` — so the same code runs in
//! real time under [`crate::Controller`] and in virtual time in tests.

use crate::axis::{AxisSettings, AxisState, AxisStatus, Link, MAX_POSITION};
use crate::backend::{mechanics, BoardBackend, Launch, PinEvent};
use crate::config::BoardConfig;
use crate::domain::{Amount, MoveOpts};
use crate::error::CtlError;
use crate::hall::FilteredEdge;
use crate::motion::StepSource;
use crate::store::{AxisRecord, MountRecord, MovingMarker, NamedPosition, Store};
use multistep_core::int::IntProfile;
use multistep_core::tdm::TdmConfig;
use multistep_core::{MoveSpec, Profile};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

mod adopt;
mod advance;
mod clock;
mod driver;
mod halts;
mod homing;
mod moves;
mod preview;
mod records;
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
                store.put_axis(&axis.name, &axis.record(None, mechanics(&*pins, i)))?;
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
                sim.attach(i, ax.count + ax.slack, mechanics(&*self.pins, i));
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

    /// A durable write to the store (an fsync); a backend that streams keeps its streams
    /// fed meanwhile ([`BoardBackend::during_write`]).
    pub(crate) fn durably<R: Send>(&mut self, write: impl FnOnce(&Store) -> R + Send) -> R {
        let store = &*self.store;
        let mut write = Some(write);
        let mut out = None;
        self.pins
            .during_write(&mut || out = write.take().map(|w| w(store)));
        out.unwrap_or_else(|| unreachable!("during_write runs the write exactly once"))
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

    /// A board of one axis whose clock the host has fitted `ppm` fast (80 readings a host
    /// second apart).
    fn fitted_board(ppm: f64) -> (tempfile::TempDir, super::Board) {
        use crate::clock_rate::Reading;
        use crate::config::{AxisConfig, BoardConfig, BoardSection};
        use crate::store::Store;
        let dir = tempfile::tempdir().unwrap();
        let c = BoardConfig {
            board: BoardSection {
                name: "b".into(),
                clock_hz: 50e6,
                fifo_depth: 4,
                link: None,
                sync_line: None,
            },
            axes: vec![AxisConfig {
                name: "x".into(),
                settings: crate::AxisSettings::default(),
            }],
            alpaca: None,
        };
        let mut b = super::Board::open(&c, Store::open(dir.path()).unwrap()).unwrap();
        for k in 0..80u64 {
            let ns = k * 1_000_000_000;
            let tick = (ns as f64 * 50e6 * (1.0 + ppm * 1e-6) / 1e9) as u64;
            let r = Reading {
                sent_ns: ns,
                recv_ns: ns + 1_000,
                tick,
            };
            b.clock_reading(r).unwrap();
        }
        assert!(b.clock_state().correcting, "{:?}", b.clock_state());
        (dir, b)
    }

    /// On a board fitted 37 ppm fast, a move with phase times (not whole ticks) is
    /// planned in the board's seconds and whole ticks, so the board's integer planner
    /// takes it, and its last edge is the host time's on that crystal, to a tick.
    #[test]
    fn phase_times_on_a_fitted_board_are_whole_board_ticks() {
        use crate::domain::MoveOpts;
        let (_dir, b) = fitted_board(37.0);
        let mut o = MoveOpts::default();
        (
            o.params.accel_time,
            o.params.cruise_time,
            o.params.decel_time,
        ) = (Some(0.123_456_789), Some(0.5), Some(0.2));
        o.profile = Some("trapezoid".into());
        let spec = b.spec(0, 3_000, &o);
        let ip = multistep_link::writes::int_profile(&spec.resolve().unwrap(), 50_000_000)
            .expect("whole ticks for the integer planner");
        let f = 1.0 + b.clock_state().applied_ppm * 1e-6;
        let host_s = 0.123_456_789 + 0.5 + 0.2;
        let want = host_s * 50e6 * f;
        let last = ip.end_tick() as f64;
        assert!((last - want).abs() <= 2.0, "{last} ticks, want {want}");
        // and the float plan is the same move
        let p = spec.plan_on_clock(50e6).unwrap();
        assert!(
            (p.duration() * 50e6 - last).abs() < 1e-6,
            "{}",
            p.duration()
        );
    }

    /// On the same board a limits-mode move is played on the board's ticks per host
    /// second (to the whole Hz): its limits stay whole numbers, so the board's integer
    /// planner takes them as they are, and the move lasts its host time on that crystal,
    /// the float and integer plans to the same tick. Uncorrected, it plays on the
    /// nominal clock.
    #[test]
    fn a_limits_move_on_a_fitted_board_plays_on_its_ticks_per_host_second() {
        use crate::domain::MoveOpts;
        let (_dir, mut b) = fitted_board(37.0);
        let mut o = MoveOpts::default();
        (o.params.vmax, o.params.amax) = (Some(4_000.0), Some(10_000.0));
        o.profile = Some("trapezoid".into());
        let f = 1.0 + b.clock_state().applied_ppm * 1e-6;
        let clock = b.play_clock(&o);
        assert_eq!(clock, (50e6 * f).round());
        assert!((clock - 50e6 * 1.000_037).abs() < 50.0, "{clock}");
        let spec = b.spec(0, 30_000, &o);
        let ip = multistep_link::writes::int_profile(&spec.resolve().unwrap(), clock as u64)
            .expect("whole limits for the integer planner");
        let host = spec.plan_on_clock(50e6).unwrap().duration();
        let want = host * 50e6 * f;
        let last = ip.end_tick() as f64;
        assert!((last - want).abs() <= 2.0, "{last} ticks, want {want}");
        let p = b.plan(0, 30_000, &o).unwrap();
        assert_eq!((p.duration() * clock).round(), last);
        // phase times are stretched instead, on the board's clock
        o.params.accel_time = Some(1.0);
        assert_eq!(b.play_clock(&o), 50e6);
        b.set_clock_correction(false);
        o.params.accel_time = None;
        assert_eq!(b.play_clock(&o), 50e6);
    }
}
