//! Starting motion: moves and groups planned through the core, timed, and launched on
//! the backend (`move`, `moveto`, `group`, `goto`, homing's phases).

use super::*;

impl Board {
    /// Starts a planned move on axis `i` at tick `start`, marker first.
    pub(super) fn launch(
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
            // homing's speeds are the board's
            clock_hz: self.clock_hz,
        };
        self.launch_group(vec![(l, purpose)], None, start)
            .map(|_| ())
    }

    /// Starts moves together through the backend (TDM-timed with a `report`), each
    /// axis's moving marker durable first. Returns the start tick.
    pub(super) fn launch_group(
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
            // the group's clock: its moves play on one ([`Board::play_clock`])
            let tdm = TdmConfig {
                clock_hz: launches.first().map_or(self.clock_hz, |l| l.clock_hz),
                ..self.tdm
            };
            self.pins.start(launches, report, &tdm, now)
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
    pub(super) fn unlaunch(&mut self, axes: &[usize]) {
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
    pub(super) fn launch_source(
        &mut self,
        i: usize,
        steps: u64,
        dir: i64,
        purpose: Purpose,
        start: u64,
    ) -> Result<(), CtlError> {
        let sim_pos = mechanics(&*self.pins, i);
        let ax = &self.axes[i];
        let moved = dir * steps as i64;
        let target = ax.count + ax.slack + moved - slack_after(ax.slack, moved, ax.backlash());
        if !ax.marked {
            let from = ax.count;
            let rec = ax.record(
                Some(MovingMarker {
                    from,
                    target,
                    homing: matches!(purpose, Purpose::Home(_)),
                }),
                sim_pos,
            );
            let name = ax.name.clone();
            self.durably(|st| st.put_axis(&name, &rec))?;
            let ax = &mut self.axes[i];
            ax.marked = true;
            ax.marker = Some((from, target));
        }
        let ax = &mut self.axes[i];
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

    /// The backend's own plan of the move `spec` played on `clock_hz` ([`Board::play_clock`];
    /// see [`BoardBackend::plan_datapath`]); the host's profile stays the reference for
    /// speeds and timing.
    pub(super) fn datapath(
        &self,
        spec: &MoveSpec,
        clock_hz: f64,
    ) -> Result<Option<IntProfile>, CtlError> {
        self.pins.plan_datapath(spec, clock_hz)
    }

    pub(super) fn check_can_move(&self, i: usize) -> Result<(), CtlError> {
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

    pub(super) fn amount_steps(&self, i: usize, a: Amount) -> Result<i64, CtlError> {
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
    pub(super) fn delta(&self, i: usize, amount: Amount, absolute: bool) -> Result<i64, CtlError> {
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

    pub(super) fn resolve_opts(&self, opts: &MoveOpts) -> Result<MoveOpts, CtlError> {
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
    pub(super) fn spec<'a>(&self, i: usize, steps: u64, o: &'a MoveOpts) -> MoveSpec<'a> {
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
        // On a board whose crystal is corrected, phase times are host seconds: stretched
        // to the board's, in whole ticks (a sync group's already are, so the float plan
        // and the board's integer plan agree). Speeds and limits stay as given: they hold
        // in board seconds, within the crystal's error of host seconds.
        if let Some(f) = self.move_time_scale() {
            let whole = |t: Option<f64>| t.map(|t| (t * self.clock_hz).round() / self.clock_hz);
            for t in [&mut p.accel_time, &mut p.cruise_time, &mut p.decel_time] {
                *t = whole(whole(*t).map(|t| t * f));
            }
        }
        spec
    }

    pub(super) fn check_peaks(&self, i: usize, p: &Profile) -> Result<(), CtlError> {
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

    pub(super) fn family_name<'a>(&'a self, i: usize, o: &'a MoveOpts) -> &'a str {
        o.profile
            .as_deref()
            .unwrap_or(&self.axes[i].settings.profile)
    }

    pub(super) fn plan(&self, i: usize, steps: u64, opts: &MoveOpts) -> Result<Profile, CtlError> {
        let mut o = self.resolve_opts(opts)?;
        o.profile = Some(self.family_name(i, &o).to_string());
        let p = self.spec(i, steps, &o).plan_on_clock(self.play_clock(&o))?;
        self.check_peaks(i, &p)?;
        Ok(p)
    }

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
        let (plan, profiles, clock_hz) = self.plan_group(targets, absolute, sync, opts)?;
        let datapaths = self.plan_datapaths(&plan, &profiles, sync, opts, clock_hz)?;
        let before = plan
            .iter()
            .map(|&(i, _)| (self.axes[i].count, self.axes[i].settings.clone()))
            .collect();
        Ok(PendingGroup {
            plan,
            profiles,
            datapaths,
            before,
            tdm: TdmConfig {
                clock_hz,
                ..self.tdm
            },
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
            tdm,
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
                    clock_hz: tdm.clock_hz,
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
    pub(super) fn plan_datapaths(
        &self,
        plan: &[(usize, i64)],
        profiles: &[Option<Profile>],
        sync: bool,
        opts: &MoveOpts,
        clock_hz: f64,
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
                self.datapath(&self.spec(i, self.axes[i].motor_steps(d), &o), clock_hz)
            })
            .collect()
    }

    /// Same start and finish: every axis gets the same phase times (a quarter accelerating,
    /// half cruising, a quarter decelerating unless given), stretched until every axis is
    /// within its vmax and amax. Peaks scale as 1/s and 1/s² with the time scale s.
    pub(super) fn plan_sync(
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
        let given = if opts.has_phase_times() { 1.0 } else { 0.0 };
        let mut scale: f64 = given;
        for &(i, d) in plan.iter().filter(|p| p.1 != 0) {
            let (v, a) = phase(i, d, 1.0)?.peaks();
            let s = &self.axes[i].settings;
            scale = scale.max(multistep_core::time_scale(v, a, s.vmax, s.amax));
        }
        // A scale set by a limit puts a peak on it; a corrected board's phases are then
        // rounded to whole ticks (spec), so they are made a few ticks of the shortest
        // longer first, and the rounding never lifts that peak above its limit.
        let shortest = [ta, tb, tc]
            .into_iter()
            .filter(|&t| t > 0.0)
            .fold(f64::INFINITY, f64::min);
        let margin = match self.move_time_scale() {
            Some(_) if scale > given => 1.0 + 4.0 / (self.clock_hz * shortest * scale),
            _ => 1.0 + 1e-12,
        };
        plan.iter()
            .map(|&(i, d)| {
                if d == 0 {
                    return Ok(None);
                }
                let p = phase(i, d, scale * margin)?;
                self.check_peaks(i, &p)?;
                Ok(Some(p))
            })
            .collect()
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
