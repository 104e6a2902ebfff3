//! What is read and kept: status, settings, named positions, presets, the mount's
//! records, the simulation's state and the store's health.

use super::*;

impl Board {
    pub fn status(&mut self, axes: &[String], now: u64) -> Result<Vec<AxisStatus>, CtlError> {
        self.advance(now);
        self.status_now(axes)
    }

    /// [`Board::status`] as last advanced, without advancing (no link exchange).
    pub fn status_now(&self, axes: &[String]) -> Result<Vec<AxisStatus>, CtlError> {
        let idx = self.indices(axes)?;
        let store = self.store.check().word();
        let link_state = self.pins.link_state();
        let (clock_ppm, clock_fix) = (self.clock_state().ppm, self.clock_fix());
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
                    sim_position: mechanics(&*self.pins, i),
                    dir_level: (ax.last_dir > 0) != ax.settings.invert_dir,
                    rate: track.map(|t| t.signed_rate()),
                    clock_ppm,
                    clock_fix,
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
        self.durably(|st| st.put_settings(&name, &s))?;
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
        self.durably(|st| st.put_named(name, &pos))?;
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
        self.durably(|st| st.put_mount(key, r))
    }

    pub fn named_positions(&self) -> Result<BTreeMap<String, NamedPosition>, CtlError> {
        self.store.named()
    }

    pub fn forget(&mut self, name: &str) -> Result<(), CtlError> {
        if self.durably(|st| st.forget_named(name))? {
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
        self.durably(|st| st.put_preset(name, opts))
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
        self.pins.simulation_mut()?.slip(i, steps)?;
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
                        sim_position: mechanics(&*self.pins, i),
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
