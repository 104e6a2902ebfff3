//! The simulated board: each axis's edges come from a [`StepSource`], the count and the
//! mechanics move one step per edge, and a [`HallSim`] watches the mechanics.

use super::sim_sync::SimSyncLine;
use super::{no_sync, BoardBackend, Launch, PinEvent, Simulation, SyncLine, SyncState, Tracking};
use crate::axis::AxisSettings;
use crate::error::CtlError;
use crate::hall::{FilteredEdge, HallSim};
use crate::motion::{start_move, start_timed, stop_profile, StepSource, Stopped};
use crate::tracking::TrackSource;

struct Motion {
    src: Box<dyn StepSource>,
    dir: i64,
    stop_on_sensor: Option<bool>,
    /// The plan was replaced by a stop ramp.
    stopping: bool,
    /// Every step is reported ([`PinEvent::Step`]).
    watch: bool,
}

struct SimAxis {
    count: i64,
    sim_pos: i64,
    hall: HallSim,
    motion: Option<Motion>,
    settings: AxisSettings,
}

pub struct SimBackend {
    clock_hz: f64,
    axes: Vec<SimAxis>,
    now: u64,
    work_budget: Option<u64>,
    work: u64,
    max_advance_work: u64,
    /// Work done when the current advance began.
    w0: u64,
    simulated: bool,
    /// The simulated SYNC line, when the board has one.
    sync: Option<SimSyncLine<Launch>>,
}

impl SimBackend {
    pub fn new(clock_hz: f64, axes: usize) -> SimBackend {
        let s = AxisSettings::default();
        SimBackend {
            clock_hz,
            axes: (0..axes)
                .map(|_| SimAxis {
                    count: 0,
                    sim_pos: 0,
                    hall: make_hall(&s, clock_hz),
                    motion: None,
                    settings: s.clone(),
                })
                .collect(),
            now: 0,
            work_budget: None,
            work: 0,
            max_advance_work: 0,
            w0: 0,
            simulated: true,
            sync: None,
        }
    }

    /// The board on the simulated SYNC line `path` (shared by the simulated boards of a
    /// cross-board group), its ticks `ticks_per_second` of the wall clock.
    pub fn with_sync_line(mut self, path: &std::path::Path, ticks_per_second: f64) -> SimBackend {
        self.sync = Some(SimSyncLine::new(path, ticks_per_second));
        self
    }

    /// The same pins with the simulation's own commands refused (as on hardware).
    pub fn without_simulation(mut self) -> SimBackend {
        self.simulated = false;
        self
    }

    /// Steps taken plus sensor events handled, over the board's life.
    fn work_done(&self) -> u64 {
        self.work + self.axes.iter().map(|a| a.hall.work).sum::<u64>()
    }

    fn note_work(&mut self) {
        let total = self.work_done();
        self.max_advance_work = self.max_advance_work.max(total - self.w0);
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

    /// Runs axis `i` up to `now`, stopping at its first event.
    fn advance_axis(&mut self, i: usize, now: u64) -> Option<PinEvent> {
        loop {
            let ax = &mut self.axes[i];
            let m = ax.motion.as_mut()?;
            let next = m.src.peek();
            let until = next.unwrap_or_else(|| m.src.end_tick()).min(now);
            // Sensor events due before the next edge come first, at their own tick.
            if let Some(ev) = ax.hall.advance(until, ax.count, ax.sim_pos) {
                return Some(self.on_sensor(i, ev));
            }
            match next {
                Some(e) if e <= now => {
                    m.src.take();
                    self.work += 1;
                    ax.count += m.dir;
                    ax.sim_pos += m.dir;
                    if let Some(ev) = ax.hall.step(e, ax.count, ax.sim_pos) {
                        return Some(self.on_sensor(i, ev));
                    }
                    if m.watch {
                        return Some(PinEvent::Step);
                    }
                }
                Some(_) => return None,
                None => {
                    let end = m.src.end_tick();
                    ax.motion = None;
                    return Some(PinEvent::End { end });
                }
            }
        }
    }

    fn on_sensor(&mut self, i: usize, edge: FilteredEdge) -> PinEvent {
        let m = self.axes[i]
            .motion
            .as_ref()
            .expect("sensor events come while moving");
        let speed = m.src.speed_at(edge.tick);
        let trigger = !m.stopping && m.stop_on_sensor == Some(edge.active);
        let triggered = trigger.then(|| self.stop_at(i, edge.tick));
        PinEvent::Sensor {
            edge,
            speed,
            triggered,
        }
    }

    /// Replaces the motion of axis `i` by a controlled stop (at amax) starting at `tick`;
    /// returns the new target.
    fn stop_at(&mut self, i: usize, tick: u64) -> i64 {
        let clock = self.clock_hz;
        let ax = &mut self.axes[i];
        let amax = ax.settings.amax;
        let Some(m) = ax.motion.as_mut() else {
            return ax.count;
        };
        let v = m.src.speed_at(tick);
        m.stopping = true;
        match stop_profile(v, amax).and_then(|p| start_move(p, clock, tick).ok()) {
            Some(src) => {
                m.src = src;
                ax.count + m.dir * m.src.steps_left() as i64
            }
            None => {
                m.src = Box::new(Stopped(tick));
                ax.count
            }
        }
    }

    /// Starts the armed group when the SYNC line has fallen: each member's move from the
    /// fall's tick, in place of its wait.
    fn start_fired(&mut self, now: u64) {
        let Some((tick, moves)) = self.sync.as_mut().and_then(|s| s.take_fired(now)) else {
            return;
        };
        for (i, l) in moves {
            // planned when armed, so it plans again
            if let (Ok(src), Some(m)) = (
                start_move(l.profile, l.clock_hz, tick),
                self.axes[i].motion.as_mut(),
            ) {
                m.src = src;
            }
        }
    }

    fn install(&mut self, l: Installed, src: Box<dyn StepSource>, start: u64) {
        let ax = &mut self.axes[l.axis];
        if l.resync_sensor {
            // From rest: the filter has long settled on the present level. (Homing phases
            // follow each other without a resync, so the sensor's history carries over.)
            ax.hall.resync(start, ax.count, ax.sim_pos);
        }
        ax.motion = Some(Motion {
            src,
            dir: l.dir,
            stop_on_sensor: l.stop_on_sensor,
            stopping: false,
            watch: false,
        });
    }
}

/// What [`SimBackend::install`] needs of a [`Launch`].
struct Installed {
    axis: usize,
    dir: i64,
    stop_on_sensor: Option<bool>,
    resync_sensor: bool,
}

impl Installed {
    fn of(l: &Launch) -> Installed {
        Installed {
            axis: l.axis,
            dir: l.dir,
            stop_on_sensor: l.stop_on_sensor,
            resync_sensor: l.resync_sensor,
        }
    }
}

fn make_hall(s: &AxisSettings, clock_hz: f64) -> HallSim {
    HallSim::new(&s.sim, s.home_dir, s.period, s.debounce, clock_hz)
}

impl BoardBackend for SimBackend {
    fn describe(&self) -> String {
        "simulated".into()
    }
    fn is_simulated(&self) -> bool {
        self.simulated
    }
    fn attach(&mut self, axis: usize, count: i64, sim_position: i64) {
        let ax = &mut self.axes[axis];
        ax.count = count;
        ax.sim_pos = sim_position;
    }
    fn configure(&mut self, axis: usize, settings: &AxisSettings) {
        let ax = &mut self.axes[axis];
        ax.hall = make_hall(settings, self.clock_hz);
        ax.settings = settings.clone();
    }

    fn start(
        &mut self,
        moves: Vec<Launch>,
        report: Option<&multistep_core::tdm::Report>,
        tdm: &multistep_core::tdm::TdmConfig,
        now: u64,
    ) -> Result<(u64, Vec<u64>), CtlError> {
        // One TDM run times the whole group: one start tick for every axis.
        let (start, sources) = match report {
            Some(r) => {
                let profiles: Vec<_> = moves.iter().map(|l| l.profile.clone()).collect();
                start_timed(&profiles, r, tdm, now)?
            }
            None => {
                let s = moves
                    .iter()
                    .map(|l| start_move(l.profile.clone(), l.clock_hz, now))
                    .collect::<Result<Vec<_>, _>>()?;
                (now, s)
            }
        };
        let mut steps = Vec::new();
        for (l, src) in moves.iter().zip(sources) {
            steps.push(src.steps_left());
            self.install(Installed::of(l), src, start);
        }
        Ok((start, steps))
    }

    fn start_source(
        &mut self,
        axis: usize,
        src: Box<dyn StepSource>,
        dir: i64,
        start: u64,
    ) -> Result<u64, CtlError> {
        let steps = src.steps_left();
        let l = Installed {
            axis,
            dir,
            stop_on_sensor: None,
            resync_sensor: true,
        };
        self.install(l, src, start);
        Ok(steps)
    }

    fn tracking(&mut self) -> Result<&mut dyn Tracking, CtlError> {
        Ok(self)
    }

    /// The simulated driver holds the mechanics either way (no load turns them).
    fn set_enabled(&mut self, _axis: usize, _on: bool) -> Result<(), CtlError> {
        Ok(())
    }

    fn begin_advance(&mut self) {
        self.w0 = self.work_done();
    }

    fn poll(&mut self, now: u64) -> Option<(usize, PinEvent)> {
        let now = now.max(self.now);
        self.start_fired(now);
        let Some(budget) = self.work_budget else {
            for i in 0..self.axes.len() {
                if let Some(ev) = self.advance_axis(i, now) {
                    return Some((i, ev));
                }
            }
            self.now = now;
            self.note_work();
            return None;
        };
        // In slices short enough that one costs at most an eighth of the budget; stops
        // after the slice that uses it up.
        let slice = self.slice_ticks(budget / 8);
        while self.now < now && self.work_done() - self.w0 < budget {
            let until = now.min(self.now.saturating_add(slice));
            for i in 0..self.axes.len() {
                if self.axes[i].motion.is_some() {
                    // Looking at an axis is work too, even in a slice without events.
                    self.work += 1;
                    if let Some(ev) = self.advance_axis(i, until) {
                        self.note_work();
                        return Some((i, ev));
                    }
                }
            }
            self.now = until;
        }
        self.note_work();
        None
    }

    fn now(&self) -> u64 {
        self.now
    }

    fn stop(&mut self, axis: usize, now: u64) -> Result<i64, CtlError> {
        if let Some(s) = self.sync.as_mut() {
            s.disarm(Some(axis));
        }
        Ok(self.stop_at(axis, now))
    }

    fn estop(&mut self, _now: u64) {
        if let Some(s) = self.sync.as_mut() {
            s.disarm(None);
        }
        for ax in &mut self.axes {
            ax.motion = None;
        }
    }

    fn clear_estop(&mut self) -> Result<(), CtlError> {
        Ok(())
    }

    fn count(&self, axis: usize) -> i64 {
        self.axes[axis].count
    }

    fn rebase(&mut self, axis: usize, delta: i64, mechanics: bool) -> Result<(), CtlError> {
        let ax = &mut self.axes[axis];
        ax.count += delta;
        if mechanics {
            ax.sim_pos += delta;
        }
        Ok(())
    }

    fn sensor(&self, axis: usize) -> bool {
        self.axes[axis].hall.filtered()
    }

    fn resync_sensor(&mut self, axis: usize, now: u64) {
        let ax = &mut self.axes[axis];
        ax.hall.resync(now, ax.count, ax.sim_pos);
    }

    fn speed(&self, axis: usize, now: u64) -> f64 {
        self.axes[axis]
            .motion
            .as_ref()
            .map_or(0.0, |m| m.src.speed_at(now))
    }

    fn end_tick(&self, axis: usize) -> Option<u64> {
        self.axes[axis].motion.as_ref().map(|m| m.src.end_tick())
    }

    fn simulation(&self) -> Option<&dyn Simulation> {
        Some(self)
    }

    fn simulation_mut(&mut self) -> Result<&mut dyn Simulation, CtlError> {
        if self.simulated {
            Ok(self)
        } else {
            Err(CtlError::NotSimulated)
        }
    }

    fn sync_line(&mut self) -> Result<&mut dyn SyncLine, CtlError> {
        if self.sync.is_some() {
            Ok(self)
        } else {
            Err(no_sync(&self.describe()))
        }
    }

    fn set_work_budget(&mut self, budget: Option<u64>) {
        self.work_budget = budget;
    }

    fn work(&self) -> (u64, u64) {
        (self.work, self.max_advance_work)
    }
}

/// An armed member before the SYNC fall: moving, no step due.
struct Waiting;

impl StepSource for Waiting {
    fn peek(&mut self) -> Option<u64> {
        Some(u64::MAX)
    }
    fn take(&mut self) {}
    fn speed_at(&self, _: u64) -> f64 {
        0.0
    }
    fn end_tick(&self) -> u64 {
        u64::MAX
    }
    fn steps_left(&self) -> u64 {
        0
    }
}

impl SyncLine for SimBackend {
    /// Each member waits (moving, no step) until the line falls.
    fn arm(&mut self, moves: Vec<Launch>, now: u64) -> Result<(u64, Vec<u64>), CtlError> {
        match &self.sync {
            None => return Err(no_sync(&self.describe())),
            Some(s) if s.is_armed() => {
                return Err(CtlError::Setting(
                    "a group is armed already: fire it, or stop its axes".into(),
                ))
            }
            Some(_) => {}
        }
        let mut steps = Vec::new();
        for l in &moves {
            steps.push(start_move(l.profile.clone(), l.clock_hz, now)?.steps_left());
        }
        for l in &moves {
            self.install(Installed::of(l), Box::new(Waiting), now);
        }
        let members = moves.into_iter().map(|l| (l.axis, l)).collect();
        if let Some(s) = self.sync.as_mut() {
            s.arm(members, now);
        }
        Ok((now, steps))
    }

    fn fire(&mut self) -> Result<(), CtlError> {
        match &self.sync {
            Some(s) => s.fire(),
            None => Err(no_sync(&self.describe())),
        }
    }

    fn sync_state(&mut self) -> Result<SyncState, CtlError> {
        let s = self.sync.as_ref().ok_or_else(|| no_sync("simulated"))?;
        Ok(SyncState {
            armed: s.is_armed(),
            ready: s.is_armed(),
            late: false,
            line: true,
            tick: s.last_fall(),
        })
    }
}

impl Tracking for SimBackend {
    fn tracker(&mut self, axis: usize) -> Option<&mut TrackSource> {
        self.axes[axis].motion.as_mut()?.src.as_track()
    }

    fn watch_steps(&mut self, axis: usize, on: bool) {
        if let Some(m) = self.axes[axis].motion.as_mut() {
            m.watch = on;
        }
    }
}

impl Simulation for SimBackend {
    fn sim_position(&self, axis: usize) -> i64 {
        self.axes[axis].sim_pos
    }

    fn slip(&mut self, axis: usize, steps: i64) -> Result<(), CtlError> {
        let to = self.axes[axis].sim_pos as i128 + steps as i128;
        let max = 2 * crate::axis::MAX_POSITION as i128;
        if to.abs() > max {
            return Err(CtlError::Setting(format!(
                "the simulated mechanics stay within ±{max}"
            )));
        }
        self.axes[axis].sim_pos = to as i64;
        Ok(())
    }
}
