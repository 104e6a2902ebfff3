//! What happens at a board's pins. The controller's logic (planning, protocol, presets,
//! named positions, persistence, homing, periodic axes, groups, e-stop) lives in
//! [`crate::Board`] once; a [`BoardBackend`] runs its moves and reports what the axes did:
//! [`SimBackend`] simulates the mechanics and Hall sensors, [`FpgaBackend`] drives the FPGA
//! board (`ms_board`) over its serial host link.

use crate::axis::AxisSettings;
use crate::error::CtlError;
use crate::hall::FilteredEdge;
use crate::motion::StepSource;
use crate::tracking::TrackSource;
use multistep_core::int::IntProfile;
use multistep_core::{MoveSpec, Profile};

pub mod fpga;
#[cfg(feature = "sim")]
pub mod sim;
#[cfg(feature = "sim")]
mod sim_sync;

pub use fpga::{FpgaBackend, LinkSpec, SessionKeeper};
#[cfg(feature = "sim")]
pub use sim::SimBackend;
#[cfg(feature = "sim")]
pub(crate) use sim_sync::check_line_path;

/// One axis's move handed to a backend.
pub struct Launch {
    pub axis: usize,
    /// The move as planned on the host's clock (speeds, end tick).
    pub profile: Profile,
    /// The clock (Hz) `profile`'s edges are played on: the board's, or, for a limits-mode
    /// move on a board whose crystal the host corrects, its ticks in one host second
    /// ([`crate::board::Board::play_clock`]).
    pub clock_hz: f64,
    /// The backend's own plan of it, when its datapath is not the host's (see
    /// [`BoardBackend::plan_datapath`]).
    pub datapath: Option<IntProfile>,
    /// +1 or -1.
    pub dir: i64,
    /// Stop (with the backend's stop ramp) at the first accepted sensor edge to this
    /// level: `Some(true)` entering the sensor, `Some(false)` leaving it.
    pub stop_on_sensor: Option<bool>,
    /// The move starts from rest: the sensor filter restarts on the present level.
    pub resync_sensor: bool,
}

/// A backend's link to its board ([`BoardBackend::link_state`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkState {
    /// The board answers.
    pub up: bool,
    /// When the board's registers were last read in full.
    pub read_at: Option<std::time::Instant>,
}

/// What an axis did, reported by [`BoardBackend::poll`] in time order per axis.
#[derive(Clone, Debug, PartialEq)]
pub enum PinEvent {
    /// An accepted (filtered) sensor edge while moving.
    Sensor {
        edge: FilteredEdge,
        /// Commanded speed at the edge (steps/s, unsigned).
        speed: f64,
        /// The edge triggered the stop armed by [`Launch::stop_on_sensor`]; the axis now
        /// runs its stop ramp towards `target`.
        triggered: Option<i64>,
    },
    /// The axis's motion ended (it is idle) at tick `end`.
    End { end: u64 },
    /// The board lost this axis's count (it was reset or lost power while the axis moved,
    /// or its counter no longer reads what the host last saw). Any motion is gone.
    Lost { why: String },
    /// The axis's motion ended (or runs) late: some edges came later than planned (the
    /// board's underrun flag, e.g. a streamed move starved by its link); the count is exact.
    Late { why: String },
    /// The board latched its e-stop by itself (its e-stop input).
    Estop,
    /// The axis took a step (only while [`BoardBackend::watch_steps`] asks for it).
    Step,
}

/// The board's SYNC line (docs/HDL.md "Cross-board start") as its `Status` and `SyncTick`
/// registers report it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SyncState {
    /// A group is armed: it waits for the SYNC edge.
    pub armed: bool,
    /// The armed group is prefilled and past its DIR setup.
    pub ready: bool,
    /// The last SYNC edge came before the armed group was ready.
    pub late: bool,
    /// The line's level (true: idle, high).
    pub line: bool,
    /// The board's free-running count latched at the last SYNC fall.
    pub tick: u32,
}

/// The refusal of a board with no SYNC line.
pub fn no_sync(board: &str) -> CtlError {
    CtlError::Unsupported(format!(
        "board {board} has no SYNC line: arm, fire and synctick need an FPGA board built with the cross-board start"
    ))
}

/// A board on the SYNC line shared by boards (docs/HDL.md "Cross-board start").
pub trait SyncLine {
    /// Loads `moves` as [`BoardBackend::start`] does, but they start at the next SYNC fall
    /// (the board reports them pending until then).
    fn arm(&mut self, moves: Vec<Launch>, now: u64) -> Result<(u64, Vec<u64>), CtlError>;
    /// Pulls the SYNC line low: every board on it starts its armed group.
    fn fire(&mut self) -> Result<(), CtlError>;
    /// The SYNC line's state.
    fn sync_state(&mut self) -> Result<SyncState, CtlError>;
}

/// Open-ended motion: a tracker run as an axis's step source
/// ([`BoardBackend::start_source`]) whose rate changes while it runs.
pub trait Tracking {
    /// The tracker of an axis tracking (`track`).
    fn tracker(&mut self, axis: usize) -> Option<&mut TrackSource>;
    /// Steps of `axis` already committed beyond its count: a stop asked for now makes
    /// them before its ramp (a board fed a lead of its stream; none on a simulated board).
    fn steps_ahead(&self, _axis: usize) -> u64 {
        0
    }
    /// Reports every step of `axis` as [`PinEvent::Step`] while `on` (a tracking axis
    /// watching its soft limit).
    fn watch_steps(&mut self, axis: usize, on: bool);
}

/// Simulated mechanics behind the axes: where they are, and steps they lose that the
/// count does not see (`sim slip`).
pub trait Simulation {
    /// Where the simulated mechanics of `axis` are.
    fn sim_position(&self, axis: usize) -> i64;
    /// The mechanics lose `steps` the count does not see.
    fn slip(&mut self, axis: usize, steps: i64) -> Result<(), CtlError>;
}

/// Where the mechanics of `axis` are: the simulation's, else the count.
pub fn mechanics(b: &dyn BoardBackend, axis: usize) -> i64 {
    b.simulation()
        .map_or_else(|| b.count(axis), |s| s.sim_position(axis))
}

/// The pins of one board. Time is the board tick `now` the controller passes in.
/// What only some boards have is a capability behind an accessor: the SYNC line
/// ([`BoardBackend::sync_line`]), tracking ([`BoardBackend::tracking`]) and simulated
/// mechanics ([`BoardBackend::simulation`]).
pub trait BoardBackend: Send {
    /// "simulated" or the link, e.g. "serial:/dev/ttyUSB0@3000000".
    fn describe(&self) -> String;
    /// Simulated mechanics stand behind the axes (the `sim …` commands work).
    fn is_simulated(&self) -> bool;
    /// The board's own clock, when it reports one (the host plans on it).
    fn clock_hz(&self) -> Option<f64> {
        None
    }
    /// The axis count and mechanics position the controller restored from its store;
    /// an axis the backend reads back from hardware keeps the hardware's count.
    fn attach(&mut self, axis: usize, count: i64, sim_position: i64);
    /// The axis's settings (at start-up and after every change).
    fn configure(&mut self, axis: usize, settings: &AxisSettings);
    /// The backend's own plan of a move played on `clock_hz` (see [`Launch::clock_hz`];
    /// `None`: the host's profile is what runs).
    fn plan_datapath(
        &self,
        _spec: &MoveSpec,
        _clock_hz: f64,
    ) -> Result<Option<IntProfile>, CtlError> {
        Ok(None)
    }
    /// Starts `moves` together: with a TDM `report` they start on its start tick after
    /// `now`, else on `now`. Returns the start tick and each move's step count.
    fn start(
        &mut self,
        moves: Vec<Launch>,
        report: Option<&multistep_core::tdm::Report>,
        tdm: &multistep_core::tdm::TdmConfig,
        now: u64,
    ) -> Result<(u64, Vec<u64>), CtlError>;
    /// The board's SYNC line, or [`no_sync`] where it has none.
    fn sync_line(&mut self) -> Result<&mut dyn SyncLine, CtlError> {
        Err(no_sync(&self.describe()))
    }
    /// Starts a move given as its step source (a simulated board only).
    fn start_source(
        &mut self,
        _axis: usize,
        _src: Box<dyn StepSource>,
        _dir: i64,
        _start: u64,
    ) -> Result<u64, CtlError> {
        Err(CtlError::NotSimulated)
    }
    /// Open-ended motion, or why this backend cannot track (`error:19`).
    fn tracking(&mut self) -> Result<&mut dyn Tracking, CtlError> {
        Err(CtlError::Unsupported(format!(
            "tracking is not supported on {} (moves, homing and stops are)",
            self.describe()
        )))
    }
    /// Energizes (`on`) or releases the axis's driver: its ENABLE line.
    fn set_enabled(&mut self, axis: usize, on: bool) -> Result<(), CtlError>;
    /// Begins one advance of the controller up to some tick (work accounting).
    fn begin_advance(&mut self) {}
    /// The next event up to `now`, or `None` once every axis reached it (or the work
    /// budget of this advance is used up).
    fn poll(&mut self, now: u64) -> Option<(usize, PinEvent)>;
    /// The tick the backend has advanced to.
    fn now(&self) -> u64;
    /// Controlled stop of a moving axis from `now`; returns its new target.
    fn stop(&mut self, axis: usize, now: u64) -> Result<i64, CtlError>;
    /// Emergency stop: every axis halts at once.
    fn estop(&mut self, now: u64);
    /// Clears the e-stop (refused while the board's e-stop input is active).
    fn clear_estop(&mut self) -> Result<(), CtlError>;
    /// The board's e-stop input is active.
    fn estop_input(&self) -> bool {
        false
    }
    /// The axis's step count.
    fn count(&self, axis: usize) -> i64;
    /// Shifts the count by `delta` (homing's re-reference, a periodic axis's wrap);
    /// `mechanics`: the simulated mechanics shift with it (the same place, renamed).
    fn rebase(&mut self, axis: usize, delta: i64, mechanics: bool) -> Result<(), CtlError>;
    /// A periodic axis's wrap: the count shifted by whole periods, the same place renamed
    /// (mechanics too). A backend may keep it lazily while the axis moves: a host killed
    /// meanwhile reads the same place under its old name, which it wraps again.
    fn wrap(&mut self, axis: usize, delta: i64) -> Result<(), CtlError> {
        self.rebase(axis, delta, true)
    }
    /// Runs `write`, a durable write (an fsync), exactly once. A backend that streams to
    /// the board runs it on another thread and keeps its streams fed meanwhile: the
    /// caller holds the board, so nothing else feeds them.
    fn during_write(&mut self, write: &mut (dyn FnMut() + Send)) {
        write()
    }
    /// The sensor's accepted level.
    fn sensor(&self, axis: usize) -> bool;
    /// Restarts the sensor filter on the present level at `now`.
    fn resync_sensor(&mut self, axis: usize, now: u64);
    /// Commanded speed (steps/s, unsigned) of a moving axis.
    fn speed(&self, axis: usize, now: u64) -> f64;
    /// The tick of the last edge of a moving axis's motion.
    fn end_tick(&self, axis: usize) -> Option<u64>;
    /// The simulated mechanics, where the board has them ([`mechanics`] reads them).
    fn simulation(&self) -> Option<&dyn Simulation> {
        None
    }
    /// The simulated mechanics to change, or why there are none.
    fn simulation_mut(&mut self) -> Result<&mut dyn Simulation, CtlError> {
        Err(CtlError::NotSimulated)
    }
    /// Why the backend cannot reach this axis now (a link failure), if it cannot.
    fn fault(&self, _axis: usize) -> Option<String> {
        None
    }
    /// The state of the link to the board (`None`: the backend has none).
    fn link_state(&self) -> Option<LinkState> {
        None
    }
    /// Limits the work of one advance (see [`crate::Board::set_work_budget`]).
    fn set_work_budget(&mut self, _budget: Option<u64>) {}
    /// The flag set while a halt waits for the board: a backend sending a batch of link
    /// frames lets go between two of them (see `HostLink::urgent`).
    fn set_urgent_flag(&mut self, _flag: std::sync::Arc<std::sync::atomic::AtomicBool>) {}
    /// Work done so far and the most any one advance did.
    fn work(&self) -> (u64, u64) {
        (0, 0)
    }
    /// Needs polling while idle (hardware: resets, e-stop input, link state).
    fn polls_when_idle(&self) -> bool {
        false
    }
    /// Keeps the board's link session with `keep` (now and whenever it changes), so a
    /// restarted host can adopt the board it left running.
    fn keep_session(&mut self, _keep: SessionKeeper) {}
    /// The board still held the session kept before this start: its counts and motions
    /// are this host's.
    fn adopted(&self) -> bool {
        false
    }
    /// Reads the board's free-running tick counter stamped with host time before and
    /// after (`crate::clock_rate`), and whether the counter may have restarted since the
    /// last reading (the board lost its state). `None`: nothing to read (a simulated
    /// board's time is the controller's; a board built without the register) or the link
    /// failed.
    fn tick_reading(&mut self) -> Option<(crate::clock_rate::Reading, bool)> {
        None
    }
    /// The direction of a motion the adopted board was running at start-up.
    fn adopted_motion(&self, _axis: usize) -> Option<i64> {
        None
    }
}
