//! One controller board: its axes, their simulated motion and sensors, homing, and the
//! store. Time is explicit — every method takes the board tick `now` — so the same code runs
//! in real time under [`crate::Controller`] and in virtual time in tests.

use crate::axis::{AxisSettings, AxisState, AxisStatus, MAX_POSITION};
use crate::config::BoardConfig;
use crate::error::CtlError;
use crate::hall::{FilteredEdge, HallSim};
use crate::motion::{start_move, start_timed, stop_profile, StepSource};
use crate::protocol::{Amount, MoveOpts};
use crate::store::{AxisRecord, MovingMarker, NamedPosition, Store};
use multistep_core::tdm::TdmConfig;
use multistep_core::{Family, MoveParams, MoveSpec, Profile};
use std::collections::BTreeMap;

mod driver;
mod preview;
mod tracking;
pub use preview::PlannedAxis;

/// Most steps (summed over its axes) of one move or group: the TDM engine times every
/// edge before the move starts (about 40 ns each), so this bounds the time a move takes
/// to start (about 4 s at most, outside the board lock).
pub const MAX_TIMED_STEPS: u64 = 100_000_000;

/// A group move planned and waiting for its TDM timing and start.
pub struct PendingGroup {
    plan: Vec<(usize, i64)>,
    profiles: Vec<Option<Profile>>,
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

/// Phases of homing (seed 002 §2.3, with the usual back-off and slow re-approach).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum HomePhase {
    /// Started on the sensor: leave it against the homing direction.
    Clear,
    /// Fast search towards the sensor.
    Seek,
    /// Back off past the edge found by the seek.
    Backoff,
    /// Slow re-approach: this edge becomes the home position.
    Approach,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Purpose {
    Move,
    Home(HomePhase),
}

struct Motion {
    src: Box<dyn StepSource>,
    dir: i64,
    target: i64,
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
    count: i64,
    sim_pos: i64,
    homed: bool,
    trusted: bool,
    state: AxisState,
    fault: Option<String>,
    motion: Option<Motion>,
    hall: HallSim,
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
    fn record(&self, moving: Option<MovingMarker>) -> AxisRecord {
        AxisRecord {
            position: self.count,
            homed: self.homed,
            trusted: self.trusted,
            moving,
            sim_position: self.sim_pos,
        }
    }

    fn make_hall(s: &AxisSettings, clock_hz: f64) -> HallSim {
        HallSim::new(&s.sim, s.home_dir, s.period, s.debounce, clock_hz)
    }

    fn period(&self) -> Option<i64> {
        self.settings.period.map(|p| p as i64)
    }
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
    store: Store,
    estopped: bool,
    now: u64,
    /// Problems met while advancing (store failures), reported by `info`.
    warnings: Vec<String>,
    work_budget: Option<u64>,
    work: u64,
    max_advance_work: u64,
    /// Simulated mechanics and sensors stand behind the axes (always, in this build).
    simulated: bool,
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
    pub fn open(config: &BoardConfig, store: Store) -> Result<Board, CtlError> {
        config.validate()?;
        let clock_hz = config.board.clock_hz;
        let mut axes = Vec::new();
        let mut warnings = Vec::new();
        let sim = store.sim();
        for ac in &config.axes {
            let settings = match stored_settings(&store, &ac.name, &mut warnings) {
                Some(s) => s,
                None => ac.settings.clone(),
            };
            let rec = store.axis(&ac.name)?.unwrap_or_default();
            let mut axis = Axis {
                name: ac.name.clone(),
                hall: Axis::make_hall(&settings, clock_hz),
                settings,
                count: rec.position,
                sim_pos: rec.sim_position,
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
            if let Some(m) = rec.moving {
                // Died mid-move: the count says `from`; the mechanics stayed where they were
                // (last written down while moving, else where the move began). Untrusted
                // until homed.
                axis.count = m.from;
                if let Some(sm) = sim.get(&ac.name) {
                    if (sm.from, sm.target) == (m.from, m.target) {
                        axis.sim_pos = sm.sim_position;
                    }
                }
                axis.homed = false;
                axis.trusted = false;
                store.put_axis(&axis.name, &axis.record(None))?;
            }
            axes.push(axis);
        }
        Ok(Board {
            name: config.board.name.clone(),
            clock_hz,
            tdm: config.board.tdm(),
            axes,
            store,
            estopped: false,
            now: 0,
            warnings,
            work_budget: None,
            work: 0,
            max_advance_work: 0,
            simulated: true,
        })
    }

    /// Limits the work of one `advance` (steps plus sensor events): past it the board's
    /// clock falls behind the wall clock instead of holding every command up. `None`
    /// (the default, for virtual time) advances all the way.
    pub fn set_work_budget(&mut self, budget: Option<u64>) {
        self.work_budget = budget;
    }

    /// Work done so far (steps plus sensor events), and the most any one advance did.
    pub fn work(&self) -> (u64, u64) {
        (self.work, self.max_advance_work)
    }

    /// This board as a hardware backend will be: no simulated mechanics behind it, so the
    /// simulation's own commands (`sim …`) are refused.
    pub fn without_simulation(mut self) -> Board {
        self.simulated = false;
        self
    }

    pub fn is_simulated(&self) -> bool {
        self.simulated
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

    /// True while time must be advanced: an axis moves, or waits to release its driver.
    pub fn needs_ticks(&self) -> bool {
        self.busy() || self.release_pending()
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
    /// With a work budget the run goes in slices short enough that one slice costs at most
    /// an eighth of the budget, and stops after the slice that uses it up.
    pub fn advance(&mut self, now: u64) {
        let now = now.max(self.now);
        let Some(budget) = self.work_budget else {
            let w0 = self.work_done();
            for i in 0..self.axes.len() {
                self.track_lease(i, now);
                self.advance_axis(i, now);
            }
            self.now = now;
            self.release_idle();
            self.note_work(w0);
            return;
        };
        let w0 = self.work_done();
        let slice = self.slice_ticks(budget / 8);
        while self.now < now && self.work_done() - w0 < budget {
            let until = now.min(self.now.saturating_add(slice));
            for i in 0..self.axes.len() {
                if self.axes[i].motion.is_some() {
                    // Looking at an axis is work too, even in a slice without events.
                    self.work += 1;
                    self.track_lease(i, until);
                    self.advance_axis(i, until);
                }
            }
            self.now = until;
        }
        self.release_idle();
        self.note_work(w0);
    }

    /// Steps taken plus sensor events handled, over the board's life.
    fn work_done(&self) -> u64 {
        self.work + self.axes.iter().map(|a| a.hall.work).sum::<u64>()
    }

    fn note_work(&mut self, w0: u64) {
        let total = self.work_done();
        self.max_advance_work = self.max_advance_work.max(total - w0);
    }

    /// Ticks in which the moving axes do at most `work` steps and sensor events: an axis
    /// steps at most vmax per second (every move is checked against it), each step makes at
    /// most one sensor edge with up to 2·bounce_count toggles (two events each), and glitches come at
    /// glitch_rate (two events each; 10× for the randomness of a Poisson process).
    fn slice_ticks(&self, work: u64) -> u64 {
        let rate: f64 = self
            .axes
            .iter()
            .filter(|a| a.motion.is_some())
            .map(|a| {
                let s = &a.settings;
                s.vmax.max(s.home_speed) * (2.0 + 4.0 * s.sim.bounce_count as f64)
                    + 20.0 * s.sim.glitch_rate
            })
            .sum();
        if rate <= 0.0 {
            return u64::MAX;
        }
        ((work.max(1) as f64 / rate) * self.clock_hz).clamp(1.0, 1e18) as u64
    }

    fn advance_axis(&mut self, i: usize, now: u64) {
        while let Some(mut m) = self.axes[i].motion.take() {
            let ax = &mut self.axes[i];
            let next = m.src.peek();
            let until = next.unwrap_or_else(|| m.src.end_tick()).min(now);
            // Sensor events due before the next edge come first, at their own tick.
            if let Some(ev) = ax.hall.advance(until, ax.count, ax.sim_pos) {
                ax.motion = Some(m);
                self.on_sensor(i, ev);
                continue;
            }
            match next {
                Some(e) if e <= now => {
                    m.src.take();
                    self.work += 1;
                    let tracking = m.track.is_some();
                    let ax = &mut self.axes[i];
                    ax.count += m.dir;
                    ax.sim_pos += m.dir;
                    let ev = ax.hall.step(e, ax.count, ax.sim_pos);
                    ax.motion = Some(m);
                    if let Some(ev) = ev {
                        self.on_sensor(i, ev);
                    }
                    if tracking {
                        self.track_step(i);
                    }
                }
                Some(_) => {
                    ax.motion = Some(m);
                    return;
                }
                None => {
                    let end = m.src.end_tick().max(ax.move_start.unwrap_or(0));
                    self.on_motion_end(i, m, end);
                }
            }
        }
    }

    fn on_sensor(&mut self, i: usize, ev: FilteredEdge) {
        let ax = &mut self.axes[i];
        let Some(m) = ax.motion.as_mut() else { return };
        let h = ax.settings.home_dir as i64;
        let trigger = match m.purpose {
            Purpose::Home(HomePhase::Clear) => !ev.active,
            Purpose::Home(HomePhase::Seek) | Purpose::Home(HomePhase::Approach) => ev.active,
            Purpose::Home(HomePhase::Backoff) => false,
            Purpose::Move => {
                // Closed-loop check (seed 002 §2.3): entering the sensor in the homing
                // direction, the count must read home_offset at the edge.
                if ev.active && m.dir == h && !m.stopping {
                    let speed = m.src.speed_at(ev.tick);
                    let mut d = ev.count_at_start - ax.settings.home_offset;
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
                false
            }
        };
        if trigger && !m.stopping {
            m.edge = Some(ev);
            self.stop_at(i, ev.tick);
        }
    }

    /// Replaces the motion of axis `i` by a controlled stop starting at `tick`.
    fn stop_at(&mut self, i: usize, tick: u64) {
        let clock = self.clock_hz;
        let ax = &mut self.axes[i];
        let amax = ax.settings.amax;
        let Some(m) = ax.motion.as_mut() else { return };
        let v = m.src.speed_at(tick);
        m.stopping = true;
        m.src = match stop_profile(v, amax).and_then(|p| start_move(p, clock, tick).ok()) {
            Some(src) => {
                m.target = ax.count + m.dir * src.steps_left() as i64;
                src
            }
            None => {
                m.target = ax.count;
                Box::new(Stopped(tick))
            }
        };
    }

    fn on_motion_end(&mut self, i: usize, m: Motion, end: u64) {
        let ax = &mut self.axes[i];
        ax.move_end = Some(end);
        ax.driver.idle_since = end;
        if let Some(p) = ax.period() {
            let shift = ax.count.rem_euclid(p) - ax.count;
            ax.count += shift;
            ax.sim_pos += shift;
        }
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
        });
        ax.marked = marker.is_some();
        ax.marker = marker.as_ref().map(|m| (m.from, m.target));
        if let Err(e) = self.store.put_axis(&ax.name, &ax.record(marker)) {
            self.warnings.push(format!("axis {}: {e}", ax.name));
        }
    }

    // ---- homing --------------------------------------------------------------------------

    fn home_profile(&self, i: usize, steps: u64, speed: f64) -> Result<Profile, CtlError> {
        let s = &self.axes[i].settings;
        Ok(MoveSpec {
            steps: Some(steps),
            params: MoveParams {
                vmax: Some(speed.min(s.vmax)),
                amax: Some(s.amax),
                ..MoveParams::default()
            },
            ..MoveSpec::default()
        }
        .plan_on_clock(self.clock_hz)?)
    }

    fn home_move(
        &mut self,
        i: usize,
        phase: HomePhase,
        dir: i64,
        steps: u64,
        speed: f64,
        start: u64,
    ) -> Result<(), CtlError> {
        let p = self.home_profile(i, steps.max(1), speed)?;
        self.launch(i, p, dir, Purpose::Home(phase), start)?;
        self.axes[i].state = AxisState::Homing;
        Ok(())
    }

    fn next_home_phase(
        &mut self,
        i: usize,
        phase: HomePhase,
        m: &Motion,
        end: u64,
    ) -> Result<(), CtlError> {
        let ax = &self.axes[i];
        let s = ax.settings.clone();
        let h = s.home_dir as i64;
        let fail = |why: &str| CtlError::Homing {
            axis: ax.name.clone(),
            why: why.to_string(),
        };
        match phase {
            HomePhase::Clear => {
                if m.edge.is_none() || ax.hall.filtered() {
                    return Err(fail("could not leave the sensor"));
                }
                self.home_move(i, HomePhase::Seek, h, s.home_search, s.home_speed, end)
            }
            HomePhase::Seek => {
                let Some(edge) = m.edge else {
                    return Err(fail("sensor not found within home_search steps"));
                };
                let over = (ax.count - edge.count_at_start).unsigned_abs();
                self.home_move(
                    i,
                    HomePhase::Backoff,
                    -h,
                    over + s.home_backoff,
                    s.home_speed,
                    end,
                )
            }
            HomePhase::Backoff => {
                if ax.hall.filtered() {
                    return Err(fail("sensor still active after backing off"));
                }
                let reach = 2 * s.home_backoff + 16;
                self.home_move(
                    i,
                    HomePhase::Approach,
                    h,
                    reach,
                    s.effective_slow_speed(),
                    end,
                )
            }
            HomePhase::Approach => {
                let Some(edge) = m.edge else {
                    return Err(fail("sensor lost on the slow re-approach"));
                };
                // The edge is home: re-reference the count, then park on it.
                let ax = &mut self.axes[i];
                ax.count += s.home_offset - edge.count_at_start;
                ax.homed = true;
                ax.trusted = true;
                ax.drift = None;
                let back = s.home_offset - ax.count;
                if back != 0 {
                    let p = self.home_profile(i, back.unsigned_abs(), s.home_speed)?;
                    self.launch(i, p, back.signum(), Purpose::Move, end)?;
                }
                Ok(())
            }
        }
    }

    // ---- starting motion -----------------------------------------------------------------

    /// Starts a planned move on axis `i` at tick `start`, marker first.
    fn launch(
        &mut self,
        i: usize,
        p: Profile,
        dir: i64,
        purpose: Purpose,
        start: u64,
    ) -> Result<(), CtlError> {
        let src = start_move(p, self.clock_hz, start)?;
        self.launch_source(i, src, dir, purpose, start)
    }

    fn launch_source(
        &mut self,
        i: usize,
        src: Box<dyn StepSource>,
        dir: i64,
        purpose: Purpose,
        start: u64,
    ) -> Result<(), CtlError> {
        let ax = &mut self.axes[i];
        let target = ax.count + dir * src.steps_left() as i64;
        if purpose == Purpose::Move {
            // From rest: the filter has long settled on the present level. (Homing phases
            // follow each other without a resync, so the sensor's history carries over.)
            ax.hall.resync(start, ax.count, ax.sim_pos);
        }
        ax.motion = Some(Motion {
            src,
            dir,
            target,
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
        // The marker is durable before the first step (once per sequence of moves).
        if ax.marked {
            return Ok(());
        }
        let rec = ax.record(Some(MovingMarker {
            from: ax.count,
            target,
        }));
        ax.marked = true;
        ax.marker = Some((ax.count, target));
        if let Err(e) = self.store.put_axis(&ax.name, &rec) {
            ax.marked = false;
            ax.motion = None;
            ax.state = AxisState::Idle;
            return Err(e);
        }
        Ok(())
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
        let before = plan
            .iter()
            .map(|&(i, _)| (self.axes[i].count, self.axes[i].settings.clone()))
            .collect();
        Ok(PendingGroup {
            plan,
            profiles,
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
        // One TDM run times the whole group: one start tick for every axis, once every
        // driver is energized and settled.
        let moving: Vec<Profile> = profiles.iter().flatten().cloned().collect();
        let moving_axes: Vec<usize> = plan
            .iter()
            .zip(&profiles)
            .filter(|(_, p)| p.is_some())
            .map(|(x, _)| x.0)
            .collect();
        let ready = self.energize_for_motion(moving_axes);
        let (start, mut sources) = match report {
            Some(r) if !moving.is_empty() => start_timed(&moving, r, &self.tdm, ready)?,
            _ => (ready, Vec::new()),
        };
        sources.reverse();
        let mut out = Vec::new();
        for (&(i, d), p) in plan.iter().zip(profiles) {
            match p {
                Some(_) => {
                    let src = sources.pop().expect("one source per moving axis");
                    self.launch_source(i, src, d.signum(), Purpose::Move, start)?
                }
                None => {
                    let ax = &mut self.axes[i];
                    ax.move_start = Some(start);
                    ax.move_end = Some(start);
                }
            }
            let t = self.axes[i].count + d;
            out.push(self.axes[i].period().map_or(t, |p| t.rem_euclid(p)));
        }
        Ok(out)
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
        let (ta, tb, tc) = if opts.has_phase_times() {
            let p = &opts.params;
            (
                p.accel_time.unwrap_or(0.0),
                p.cruise_time.unwrap_or(0.0),
                p.decel_time.unwrap_or(0.0),
            )
        } else {
            (0.25, 0.5, 0.25)
        };
        let phase = |i: usize, d: i64, s: f64| -> Result<Profile, CtlError> {
            let mut o = opts.clone();
            o.profile = Some(self.family_name(i, &opts).to_string());
            let p = &mut o.params;
            (p.accel_time, p.cruise_time, p.decel_time) =
                (Some(ta * s), Some(tb * s), Some(tc * s));
            (p.start_speed, p.end_speed) = (None, None);
            Ok(self
                .spec(i, d.unsigned_abs(), &o)
                .plan_on_clock(self.clock_hz)?)
        };
        let mut scale: f64 = if opts.has_phase_times() { 1.0 } else { 0.0 };
        for &(i, d) in plan.iter().filter(|p| p.1 != 0) {
            let (v, a) = phase(i, d, 1.0)?.peaks();
            let s = &self.axes[i].settings;
            scale = scale.max(v / s.vmax).max((a / s.amax).sqrt());
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

    /// Starts homing axis `i` at `now`.
    pub fn home(&mut self, axis: &str, now: u64) -> Result<(), CtlError> {
        self.advance(now);
        let i = self.index(axis)?;
        self.check_can_move(i)?;
        let s = self.axes[i].settings.clone();
        let h = s.home_dir as i64;
        {
            let ax = &mut self.axes[i];
            ax.homed = false;
            ax.hall.resync(self.now, ax.count, ax.sim_pos);
        }
        let start = self.energize_for_motion([i]);
        let (phase, dir) = if self.axes[i].hall.filtered() {
            (HomePhase::Clear, -h)
        } else {
            (HomePhase::Seek, h)
        };
        self.home_move(i, phase, dir, s.home_search, s.home_speed, start)
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
            if let Some(m) = self.axes[i].motion.as_mut() {
                m.purpose = Purpose::Move;
                if !m.stopping {
                    self.stop_at(i, self.now);
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
        self.estopped = true;
        for i in 0..self.axes.len() {
            let ax = &mut self.axes[i];
            if ax.motion.take().is_some() {
                ax.state = AxisState::Fault;
                ax.fault = Some("emergency stop".into());
                ax.trusted = false;
                ax.move_end = Some(self.now);
                self.persist(i);
            }
        }
    }

    /// Clears an emergency stop and axis faults.
    pub fn reset(&mut self, now: u64) {
        self.advance(now);
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
        let idx = self.indices(axes)?;
        Ok(idx
            .into_iter()
            .map(|i| {
                let ax = &self.axes[i];
                let speed = ax
                    .motion
                    .as_ref()
                    .map_or(0.0, |m| m.dir as f64 * m.src.speed_at(self.now));
                let track = ax.motion.as_ref().and_then(|m| m.track.as_ref());
                AxisStatus {
                    axis: ax.name.clone(),
                    number: i,
                    position: ax.count,
                    units: ax.count as f64 / ax.settings.steps_per_unit,
                    state: ax.state,
                    homed: ax.homed,
                    trusted: ax.trusted,
                    target: ax
                        .motion
                        .as_ref()
                        .filter(|_| track.is_none())
                        .map(|m| m.target),
                    speed,
                    sensor: ax.hall.filtered(),
                    drift: ax.drift,
                    drift_checks: ax.drift_checks,
                    move_start: ax.move_start,
                    move_end: match (&ax.motion, track) {
                        (Some(_), Some(_)) => None,
                        (Some(m), None) => Some(m.src.end_tick()),
                        (None, _) => ax.move_end,
                    },
                    fault: ax.fault.clone(),
                    sim_position: ax.sim_pos,
                    dir_level: (ax.last_dir > 0) != ax.settings.invert_dir,
                    rate: track.map(|t| t.signed_rate()),
                    enabled: ax.driver.enabled,
                    enable_level: ax.driver.enabled == ax.settings.enable_active_high,
                }
            })
            .collect())
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
        let clock = self.clock_hz;
        let ax = &mut self.axes[i];
        ax.hall = Axis::make_hall(&s, clock);
        ax.settings = s;
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
        let pos = self
            .store
            .named_position(name)?
            .ok_or_else(|| CtlError::UnknownName {
                what: "position",
                name: name.to_string(),
            })?;
        let targets: Vec<(String, Amount)> = pos
            .into_iter()
            .map(|(a, p)| (a, Amount::Steps(p)))
            .collect();
        self.group_move(&targets, true, false, opts, now)
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

    /// Stores a speed preset; its family and values are checked on a sample move.
    pub fn set_preset(&mut self, name: &str, opts: &MoveOpts) -> Result<(), CtlError> {
        let fam = opts.profile.as_deref().unwrap_or("trapezoid");
        let p = &opts.params;
        Family::parse(fam, p.rho, p.phi, p.psi)?;
        self.store.put_preset(name, opts)
    }

    pub fn presets(&self) -> Result<BTreeMap<String, MoveOpts>, CtlError> {
        self.store.presets()
    }

    /// Simulation: the mechanics lose `steps` steps that the count does not see.
    pub fn sim_slip(&mut self, axis: &str, steps: i64, now: u64) -> Result<(), CtlError> {
        if !self.simulated {
            return Err(CtlError::NotSimulated);
        }
        self.advance(now);
        let i = self.index(axis)?;
        let to = self.axes[i].sim_pos as i128 + steps as i128;
        if to.abs() > 2 * MAX_POSITION as i128 {
            return Err(CtlError::Setting(format!(
                "the simulated mechanics stay within ±{}",
                2 * MAX_POSITION
            )));
        }
        self.axes[i].sim_pos = to as i64;
        self.persist(i);
        Ok(())
    }

    /// Writes down where the simulated mechanics of the moving axes are (see
    /// [`crate::store::SimMechanics`]); the service calls it often while axes move.
    pub fn save_sim(&mut self) {
        let m: BTreeMap<String, crate::store::SimMechanics> = self
            .axes
            .iter()
            .filter(|a| a.motion.is_some())
            .filter_map(|a| {
                let (from, target) = a.marker?;
                Some((
                    a.name.clone(),
                    crate::store::SimMechanics {
                        from,
                        target,
                        sim_position: a.sim_pos,
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
}

/// The source of a stop that needs no steps: ends on its tick.
struct Stopped(u64);

impl StepSource for Stopped {
    fn peek(&mut self) -> Option<u64> {
        None
    }
    fn take(&mut self) {}
    fn speed_at(&self, _: u64) -> f64 {
        0.0
    }
    fn end_tick(&self) -> u64 {
        self.0
    }
    fn steps_left(&self) -> u64 {
        0
    }
}

/// A motor number: plain decimal digits (no sign, no leading zeros), as in `move 3 100`.
fn axis_number(word: &str) -> Option<usize> {
    let plain = word.bytes().all(|b| b.is_ascii_digit()) && (word == "0" || !word.starts_with('0'));
    if plain && word.len() <= 4 {
        word.parse().ok()
    } else {
        None
    }
}
