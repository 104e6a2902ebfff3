//! Time on the board: `advance` runs every axis up to a tick and takes what the pins
//! report (steps, sensor edges, ends of motion, a lost count, an e-stop) in order.

use super::*;

impl Board {
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
    pub(super) fn sync_count(&mut self, i: usize) {
        let motor = self.pins.count(i);
        let ax = &mut self.axes[i];
        ax.slack = ax.slack_at(motor);
        ax.count = motor - ax.slack;
    }

    /// Shifts axis `i`'s count by `delta` (motor and load alike: the slack is kept).
    pub(super) fn rebase(&mut self, i: usize, delta: i64, mechanics: bool) -> Result<(), CtlError> {
        self.pins.rebase(i, delta, mechanics)?;
        self.shifted(i, delta);
        Ok(())
    }

    /// The motion's reference follows a shift of the backend's count by `delta`.
    fn shifted(&mut self, i: usize, delta: i64) {
        if let Some(m) = self.axes[i].motion.as_mut() {
            m.motor0 += delta;
        }
        self.sync_count(i);
    }

    pub(super) fn on_event(&mut self, i: usize, ev: PinEvent) {
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

    pub(super) fn on_sensor(
        &mut self,
        i: usize,
        ev: FilteredEdge,
        speed: f64,
        triggered: Option<i64>,
    ) {
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

    pub(super) fn on_motion_end(&mut self, i: usize, m: Motion, end: u64) {
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
        match self.pins.wrap(i, shift) {
            Ok(()) => self.shifted(i, shift),
            Err(e) => {
                let name = &self.axes[i].name;
                self.warnings.push(format!("axis {name}: {e}"));
            }
        }
    }

    /// Writes the axis record. While a sequence of moves runs (homing phases, the park
    /// after homing) the marker written at its start stays on disk, untouched.
    pub(super) fn persist(&mut self, i: usize) {
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
        let rec = ax.record(marker, mechanics(&*self.pins, i));
        let name = self.axes[i].name.clone();
        if let Err(e) = self.durably(|st| st.put_axis(&name, &rec)) {
            // The disk holds an older record (the store writes this one once it can).
            self.axis_fault(i, format!("position not stored: {e}"));
        }
    }

    /// A fault of axis `i`, said on stderr and in `info`. Reported after the motion's end,
    /// the axis shows it until its next motion.
    pub(super) fn axis_fault(&mut self, i: usize, why: String) {
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
}
