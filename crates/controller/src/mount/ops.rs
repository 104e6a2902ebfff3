//! What a client asks of the mount: tracking, rates, slews, sync, park, homing, MoveAxis
//! and pulses; and the tick that ends pulses and slews.

use super::coords::{alt_az, ha_dec, wrap180, Axes, Geometry, PierSide};
use super::rates::{
    micro_arcsec, step_rate, DriveRate, ARCSEC_PER_RA_SECOND, SI_PER_SIDEREAL_SECOND,
};
use super::{Mount, MountError, Slew, State, MAX_PULSE_MS};
use crate::axis::AxisState;
use crate::domain::{Amount, MoveOpts, RateArg, TrackOpts};
use crate::error::CtlError;
use crate::Controller;
use std::time::{Duration, Instant};

/// How long a tracking axis may take to come to rest before a slew (board seconds are
/// wall seconds at time scale 1; the stop from tracking rates takes milliseconds).
const REST_DEADLINE: Duration = Duration::from_secs(30);

fn invalid<T>(m: String) -> Result<T, MountError> {
    Err(MountError::Invalid(m))
}

fn check_ra_dec(ra: f64, dec: f64) -> Result<(), MountError> {
    if !(0.0..24.0).contains(&ra) {
        return invalid(format!("right ascension {ra} h is outside [0, 24)"));
    }
    if !(-90.0..=90.0).contains(&dec) {
        return invalid(format!("declination {dec}° is outside [−90, 90]"));
    }
    Ok(())
}

/// SlewToAltAz's and SyncToAltAz's ranges (ASCOM ITelescopeV4).
fn check_alt_az(alt: f64, az: f64) -> Result<(), MountError> {
    if !(-90.0..=90.0).contains(&alt) {
        return invalid(format!("altitude {alt}° is outside [−90, 90]"));
    }
    if !(0.0..360.0).contains(&az) {
        return invalid(format!("azimuth {az}° is outside [0, 360)"));
    }
    Ok(())
}

impl Mount {
    fn unparked(st: &State) -> Result<(), MountError> {
        if st.parked {
            Err(MountError::Parked)
        } else {
            Ok(())
        }
    }

    pub fn set_tracking(&self, ctl: &Controller, on: bool) -> Result<(), MountError> {
        let mut st = self.lock();
        if on {
            Self::unparked(&st)?;
        }
        st.tracking = on;
        self.apply(ctl, &st)
    }

    pub fn set_drive_rate(&self, ctl: &Controller, r: DriveRate) -> Result<(), MountError> {
        let mut st = self.lock();
        st.drive = r;
        self.apply(ctl, &st)
    }

    /// RightAscensionRate (seconds of RA per sidereal second) and DeclinationRate (″/s):
    /// offsets from the drive rate, each at most the sidereal rate.
    pub fn set_rate_offset(&self, ctl: &Controller, dec: bool, v: f64) -> Result<(), MountError> {
        self.check_rate_offset(dec, v)?;
        let mut st = self.lock();
        if dec {
            st.dec_rate = v;
        } else {
            st.ra_rate = v;
        }
        self.apply(ctl, &st)
    }

    /// Whether [`Mount::set_rate_offset`] takes `v`.
    pub fn check_rate_offset(&self, dec: bool, v: f64) -> Result<(), MountError> {
        let arcsec = if dec { v } else { v * ARCSEC_PER_RA_SECOND };
        if !(v.is_finite() && arcsec.abs() <= super::rates::SIDEREAL) {
            return invalid(format!("rate offset {v} is beyond the sidereal rate"));
        }
        if dec && self.cfg.dec_axis.is_none() {
            return Err(MountError::NotNow(
                "a coelostat has no declination axis".into(),
            ));
        }
        Ok(())
    }

    /// Guide rate (degrees/s) of RA (`k` 0) or Dec (1): above 0, at most sidereal.
    pub fn set_guide_rate(&self, k: usize, deg_per_s: f64) -> Result<(), MountError> {
        let max = super::rates::SIDEREAL / 3600.0;
        if !(deg_per_s > 0.0 && deg_per_s <= max * (1.0 + 1e-9)) {
            return invalid(format!("guide rate {deg_per_s}°/s is outside (0, {max}]"));
        }
        self.lock().guide[k] = deg_per_s;
        Ok(())
    }

    pub fn set_site(
        &self,
        lat: Option<f64>,
        lon: Option<f64>,
        elev: Option<f64>,
    ) -> Result<(), MountError> {
        let mut st = self.lock();
        for (v, lo, hi, what) in [
            (lat, -90.0, 90.0, "latitude"),
            (lon, -180.0, 180.0, "longitude"),
            (elev, -500.0, 10_000.0, "elevation"),
        ] {
            if let Some(v) = v {
                if !(lo..=hi).contains(&v) {
                    return invalid(format!("site {what} {v} is outside {lo} to {hi}"));
                }
            }
        }
        st.lat = lat.unwrap_or(st.lat);
        st.lon = lon.unwrap_or(st.lon);
        st.elevation = elev.unwrap_or(st.elevation);
        Ok(())
    }

    pub fn set_target(&self, ra: Option<f64>, dec: Option<f64>) -> Result<(), MountError> {
        check_ra_dec(ra.unwrap_or(0.0), dec.unwrap_or(0.0))?;
        let mut st = self.lock();
        st.target = (ra.or(st.target.0), dec.or(st.target.1));
        Ok(())
    }

    pub fn set_settle_time(&self, s: i32) -> Result<(), MountError> {
        if s < 0 {
            return invalid(format!("settle time {s} s is negative"));
        }
        self.lock().settle = s;
        Ok(())
    }

    /// Hour angle (degrees) of right ascension `ra` (hours) now, by the mount's clock.
    fn ha_of(st: &State, ra: f64) -> f64 {
        wrap180(Self::lst(st) - ra * 15.0)
    }

    /// The side a slew to (`ra` hours, `dec`) would end on: the side [`Mount::slew`]
    /// takes (the limits are not checked here: a slew beyond them is refused).
    pub fn destination_side(&self, ra: f64, dec: f64) -> Result<PierSide, MountError> {
        check_ra_dec(ra, dec)?;
        let st = self.lock();
        Ok(self.cfg.mount.side_for(Self::ha_of(&st, ra), st.lat))
    }

    /// The axis angles for (`ra`, `dec`) now from `side` (None: the side a slew takes),
    /// refused beyond the limits.
    fn aim(
        &self,
        st: &State,
        ra: f64,
        dec: f64,
        side: Option<PierSide>,
    ) -> Result<Axes, MountError> {
        check_ra_dec(ra, dec)?;
        self.aim_ha(st, Self::ha_of(st, ra), dec, side)
    }

    /// The axis angles for hour angle `ha` and `dec` from `side` (None: the side a slew
    /// takes), refused beyond ha_limit or below the horizon limit.
    fn aim_ha(
        &self,
        st: &State,
        ha: f64,
        dec: f64,
        side: Option<PierSide>,
    ) -> Result<Axes, MountError> {
        let g = self.cfg.mount;
        if g == Geometry::Coelostat && (dec - self.cfg.coelostat_dec).abs() > 1e-6 {
            return invalid(format!(
                "a coelostat's declination is set by hand ({}°); {dec}° cannot be reached",
                self.cfg.coelostat_dec
            ));
        }
        let side = side.unwrap_or_else(|| g.side_for(ha, st.lat));
        let a = g.to_axes(ha, dec, side, st.lat);
        let swing = if g == Geometry::German { a.polar } else { ha };
        if swing.abs() > self.cfg.ha_limit {
            return invalid(format!(
                "slew refused: the polar axis would be {:.2}° from its centre, beyond ha_limit {}°",
                swing.abs(),
                self.cfg.ha_limit
            ));
        }
        let (alt, _) = alt_az(ha, dec, st.lat);
        if alt < self.cfg.horizon {
            return invalid(format!(
                "slew refused: altitude {alt:.2}° is below the horizon limit {}°",
                self.cfg.horizon
            ));
        }
        Ok(a)
    }

    /// SlewToCoordinatesAsync: needs tracking on (ASCOM ITelescopeV4).
    pub fn slew(&self, ctl: &Controller, ra: f64, dec: f64) -> Result<(), MountError> {
        let mut st = self.lock();
        Self::unparked(&st)?;
        if !st.tracking {
            return Err(MountError::NotNow(
                "equatorial slews need Tracking = True".into(),
            ));
        }
        let a = self.aim(&st, ra, dec, None)?;
        st.target = (Some(ra), Some(dec));
        // The catch-up move (see `tick`) makes the last stretch, backlash included.
        let steps = self.approach(&st, self.steps_of(&st, a));
        self.move_axes(ctl, &mut st, steps)?;
        st.slew = Some(Slew {
            target: Some((ra, dec)),
            side: None,
            park: false,
            then: None,
        });
        Ok(())
    }

    /// SlewToAltAzAsync: needs tracking off (ASCOM ITelescopeV4), so the point stays put
    /// in altitude and azimuth; the same limits as an equatorial slew.
    pub fn slew_alt_az(&self, ctl: &Controller, alt: f64, az: f64) -> Result<(), MountError> {
        check_alt_az(alt, az)?;
        let mut st = self.lock();
        Self::unparked(&st)?;
        if st.tracking {
            return Err(MountError::NotNow(
                "altitude-azimuth slews need Tracking = False".into(),
            ));
        }
        let (ha, dec) = ha_dec(alt, az, st.lat);
        let a = self.aim_ha(&st, ha, dec, None)?;
        let at = self.steps_of(&st, a);
        let first = self.approach(&st, at);
        self.move_axes(ctl, &mut st, first)?;
        st.slew = Some(Slew {
            target: None,
            side: None,
            park: false,
            then: (first != at).then_some(at),
        });
        Ok(())
    }

    /// Waits until the slew under way ends (a synchronous slew); false if it is still
    /// under way after `limit`.
    pub fn wait_slew(&self, limit: Duration) -> bool {
        let end = Instant::now() + limit;
        while self.slewing() {
            if Instant::now() > end {
                return false;
            }
            // The supervising thread ends the slew; look as often as it ticks.
            std::thread::sleep(super::TICK);
        }
        true
    }

    /// SyncToAltAz: needs tracking off (ASCOM ITelescopeV4).
    pub fn sync_alt_az(&self, ctl: &Controller, alt: f64, az: f64) -> Result<(), MountError> {
        check_alt_az(alt, az)?;
        if self.cfg.mount == Geometry::Coelostat {
            return invalid(format!(
                "a coelostat's declination is set by hand ({}°): sync it in right ascension",
                self.cfg.coelostat_dec
            ));
        }
        let s = self.axes_status(ctl)?;
        let mut st = self.lock();
        Self::unparked(&st)?;
        if st.tracking {
            return Err(MountError::NotNow(
                "altitude-azimuth syncs need Tracking = False".into(),
            ));
        }
        let (ha, dec) = ha_dec(alt, az, st.lat);
        self.sync_to(ctl, &mut st, &s, ha, dec)
    }

    /// SideOfPier set, a German mount's pier flip: the same coordinates from `side`,
    /// refused beyond ha_limit (the counterweight rises on the other side). Nothing moves
    /// when the mount is on `side` already.
    pub fn set_pier_side(&self, ctl: &Controller, side: PierSide) -> Result<(), MountError> {
        if self.cfg.mount != Geometry::German {
            return Err(MountError::NotNow(
                "only a German equatorial mount has two pier sides".into(),
            ));
        }
        if side == PierSide::Unknown {
            return invalid("SideOfPier is set to east (0) or west (1)".into());
        }
        let s = self.axes_status(ctl)?;
        let mut st = self.lock();
        Self::unparked(&st)?;
        if st.slew.is_some() || st.moving != [0.0; 2] {
            return Err(MountError::NotNow("a slew is under way".into()));
        }
        let p = self.pointing_of(&st, &s);
        if p.side == side {
            return Ok(());
        }
        let a = self.aim_ha(&st, p.ha, p.dec, Some(side))?;
        let at = self.steps_of(&st, a);
        // Tracking: a catch-up aims at the same sky coordinates again from that side.
        let target = st.tracking.then_some((p.ra, p.dec));
        let first = if target.is_some() {
            self.approach(&st, at)
        } else {
            at
        };
        self.move_axes(ctl, &mut st, first)?;
        st.slew = Some(Slew {
            target,
            side: Some(side),
            park: false,
            then: None,
        });
        Ok(())
    }

    pub fn sync(&self, ctl: &Controller, ra: f64, dec: f64) -> Result<(), MountError> {
        check_ra_dec(ra, dec)?;
        let s = self.axes_status(ctl)?;
        let mut st = self.lock();
        Self::unparked(&st)?;
        if !st.tracking {
            return Err(MountError::NotNow("sync needs Tracking = True".into()));
        }
        if st.slew.is_some() {
            return Err(MountError::NotNow("cannot sync while slewing".into()));
        }
        let ha = Self::ha_of(&st, ra);
        self.sync_to(ctl, &mut st, &s, ha, dec)?;
        st.target = (Some(ra), Some(dec));
        Ok(())
    }

    /// Sync offsets that make the axes read (`ha`, `dec`) on their present pier side;
    /// stored, so a restart keeps them.
    fn sync_to(
        &self,
        ctl: &Controller,
        st: &mut State,
        s: &[crate::axis::AxisStatus],
        ha: f64,
        dec: f64,
    ) -> Result<(), MountError> {
        let now = self.angles(st, s);
        let side = self.pointing_of(st, s).side;
        let want = self.cfg.mount.to_axes(ha, dec, side, st.lat);
        let mut sync = st.sync;
        sync.polar += want.polar - now.polar;
        if self.cfg.dec_axis.is_some() {
            sync.dec += want.dec - now.dec;
        }
        let rec = crate::store::MountRecord {
            sync: [sync.polar, sync.dec],
        };
        // Kept first: a sync the store refused is not taken.
        ctl.with_board(|b, _| b.put_mount_record(&self.cfg.ra_axis, &rec))?;
        st.sync = sync;
        Ok(())
    }

    /// Park: to the stored park position (or home), tracking off; AtPark once there.
    pub fn park(&self, ctl: &Controller) -> Result<(), MountError> {
        let mut st = self.lock();
        if st.parked {
            return Ok(());
        }
        st.tracking = false;
        st.moving = [0.0; 2];
        let stored = ctl.with_board(|b, _| b.named_positions())?;
        let park = stored.get(&self.cfg.park_name());
        let axes = self.cfg.axes();
        let at = |k: usize| park.and_then(|p| p.get(axes[k]).copied()).unwrap_or(0);
        let park = [at(0), at(1)];
        let first = self.approach(&st, park);
        self.move_axes(ctl, &mut st, first)?;
        st.slew = Some(Slew {
            target: None,
            side: None,
            park: true,
            then: (first != park).then_some(park),
        });
        Ok(())
    }

    pub fn unpark(&self, ctl: &Controller) -> Result<(), MountError> {
        let mut st = self.lock();
        match ctl.with_board(|b, _| b.forget(&self.cfg.parked_name())) {
            Ok(()) | Err(CtlError::UnknownName { .. }) => {}
            Err(e) => return Err(e.into()),
        }
        st.parked = false;
        Ok(())
    }

    /// SetPark: the axes' counted positions now become the park position (stored).
    pub fn set_park(&self, ctl: &Controller) -> Result<(), MountError> {
        let _st = self.lock();
        let axes: Vec<String> = self.cfg.axes().iter().map(|s| s.to_string()).collect();
        ctl.with_board(|b, now| b.save_position(&self.cfg.park_name(), &axes, now))
            .map_err(|e| match e {
                CtlError::Busy { .. } => MountError::NotNow(format!(
                    "the park position is set with the axes at rest (tracking off): {e}"
                )),
                e => e.into(),
            })?;
        Ok(())
    }

    /// FindHome: Hall homing of each axis; tracking off.
    pub fn find_home(&self, ctl: &Controller) -> Result<(), MountError> {
        let mut st = self.lock();
        Self::unparked(&st)?;
        st.tracking = false;
        st.moving = [0.0; 2];
        self.rest(ctl)?;
        for a in self.cfg.axes() {
            ctl.home(a)?;
        }
        st.slew = Some(Slew {
            target: None,
            side: None,
            park: false,
            then: None,
        });
        Ok(())
    }

    pub fn abort(&self, ctl: &Controller) -> Result<(), MountError> {
        let mut st = self.lock();
        Self::unparked(&st)?;
        st.moving = [0.0; 2];
        for a in self.cfg.axes() {
            ctl.stop(Some(a))?;
        }
        // The tick resumes tracking once the axes are at rest.
        st.slew = st.slew.map(|_| Slew {
            target: None,
            side: None,
            park: false,
            then: None,
        });
        Ok(())
    }

    /// Most MoveAxis rate of axis `k` (degrees/s): the axis's vmax.
    pub fn max_axis_rate(&self, ctl: &Controller, k: usize) -> Result<f64, MountError> {
        let axes = self.cfg.axes();
        let Some(name) = axes.get(k) else {
            return invalid(format!("the mount has no axis {k}"));
        };
        let vmax = ctl.with_board(|b, _| b.settings(name).map(|s| s.vmax))?;
        Ok(vmax / self.steps_per_rev()[k] as f64 * 360.0)
    }

    /// MoveAxis: axis `k` at `rate` degrees/s (0 ends it; tracking then resumes).
    pub fn move_axis(&self, ctl: &Controller, k: usize, rate: f64) -> Result<(), MountError> {
        let max = self.max_axis_rate(ctl, k)?;
        if rate.is_nan() || rate.abs() > max {
            return invalid(format!("MoveAxis rate {rate}°/s is beyond ±{max}°/s"));
        }
        let mut st = self.lock();
        Self::unparked(&st)?;
        if st.slew.is_some() {
            return Err(MountError::NotNow("a slew is under way".into()));
        }
        st.moving[k] = rate;
        self.apply(ctl, &st)
    }

    /// PulseGuide: direction 0 north, 1 south, 2 east, 3 west; `ms` milliseconds at the
    /// guide rate on top of tracking.
    pub fn pulse(&self, ctl: &Controller, dir: i64, ms: i64) -> Result<(), MountError> {
        let (k, sign) = match dir {
            0 => (1, 1.0),
            1 => (1, -1.0),
            // East: RA grows, hour angle falls.
            2 => (0, -1.0),
            3 => (0, 1.0),
            _ => return invalid(format!("guide direction {dir} is not 0 to 3")),
        };
        if !(0..=MAX_PULSE_MS).contains(&ms) {
            return invalid(format!("pulse of {ms} ms is outside 0 to {MAX_PULSE_MS}"));
        }
        if k == 1 && self.cfg.dec_axis.is_none() {
            return invalid("a coelostat has no declination axis to guide".into());
        }
        let mut st = self.lock();
        Self::unparked(&st)?;
        if st.slew.is_some() {
            return Err(MountError::NotNow("cannot guide while slewing".into()));
        }
        if ms == 0 {
            return Ok(());
        }
        st.pulse[k] = Some((sign, Instant::now() + Duration::from_millis(ms as u64)));
        self.apply(ctl, &st)
    }

    /// Ends pulses that are due, and a slew whose axes came to rest (aiming once more
    /// at an equatorial target, then resuming tracking).
    pub fn tick(&self, ctl: &Controller) -> Result<(), MountError> {
        let mut st = self.lock();
        let mut changed = false;
        let now = Instant::now();
        for p in &mut st.pulse {
            if p.is_some_and(|(_, end)| end <= now) {
                *p = None;
                changed = true;
            }
        }
        let busy = st.slew.is_some() || st.tracking || st.moving != [0.0; 2];
        if busy {
            // An axis stopped by the board (a soft limit, a fault): the mount stops too.
            let s = self.axes_status(ctl)?;
            if s.iter().any(|a| a.state == AxisState::Fault) {
                st.slew = None;
                st.tracking = false;
                st.moving = [0.0; 2];
                return self.apply(ctl, &st);
            }
        }
        if let Some(slew) = st.slew {
            let s = self.axes_status(ctl)?;
            if s.iter().all(|a| a.state == AxisState::Idle) {
                st.slew = None;
                changed = true;
                // The sky turned during the slew: one short move to catch up (unless the
                // target has meanwhile crossed a limit; tracking then resumes where it is).
                let aim = slew
                    .target
                    .map(|(ra, dec)| self.aim(&st, ra, dec, slew.side));
                if let Some(Ok(a)) = aim {
                    let steps = self.steps_of(&st, a);
                    self.move_axes(ctl, &mut st, steps)?;
                    st.slew = Some(Slew {
                        target: None,
                        ..slew
                    });
                    return Ok(());
                }
                if let Some(steps) = slew.then {
                    self.move_axes(ctl, &mut st, steps)?;
                    st.slew = Some(Slew { then: None, ..slew });
                    return Ok(());
                }
                if slew.park {
                    let axes: Vec<String> = self.cfg.axes().iter().map(|s| s.to_string()).collect();
                    ctl.with_board(|b, now| b.save_position(&self.cfg.parked_name(), &axes, now))?;
                    st.parked = true;
                }
            }
        }
        if changed {
            self.apply(ctl, &st)?;
        }
        Ok(())
    }

    /// Brings tracking axes to rest (a slew cannot start on a moving axis).
    fn rest(&self, ctl: &Controller) -> Result<(), MountError> {
        let deadline = Instant::now() + REST_DEADLINE;
        for a in self.cfg.axes() {
            ctl.stop(Some(a))?;
        }
        loop {
            let s = self.axes_status(ctl)?;
            if s.iter()
                .all(|a| a.state != AxisState::Moving && a.state != AxisState::Tracking)
            {
                return Ok(());
            }
            if Instant::now() > deadline {
                return Err(MountError::NotNow("the axes did not come to rest".into()));
            }
            std::thread::sleep(Duration::from_millis(2));
        }
    }

    /// A slew: both axes to `steps` as one group move (the board's planner).
    fn move_axes(
        &self,
        ctl: &Controller,
        st: &mut State,
        steps: [i64; 2],
    ) -> Result<(), MountError> {
        st.pulse = [None, None];
        self.rest(ctl)?;
        let targets: Vec<(String, Amount)> = self
            .cfg
            .axes()
            .iter()
            .zip(steps)
            .map(|(a, n)| (a.to_string(), Amount::Steps(n)))
            .collect();
        ctl.group_move(&targets, true, false, &MoveOpts::default())?;
        Ok(())
    }

    /// Sets each axis's tracking rate from the mount's state: drive rate less the RA
    /// offset, Dec offset, pulses, MoveAxis. Axes in a slew are left alone.
    fn apply(&self, ctl: &Controller, st: &State) -> Result<(), MountError> {
        if st.slew.is_some() {
            return Ok(());
        }
        let s = self.axes_status(ctl)?;
        let side = self.pointing_of(st, &s).side;
        let (sp, sd) = self.cfg.mount.sense(side, st.lat);
        let pulse = |k: usize| st.pulse[k].map_or(0.0, |(sign, _)| sign * st.guide[k] * 3600.0);
        // Sky rates, arcseconds per second: hour angle and declination.
        let (mut dha, mut ddec) = (0.0, 0.0);
        if st.tracking {
            dha = st.drive.micro_arcsec() as f64 / 1e6
                - st.ra_rate * ARCSEC_PER_RA_SECOND / SI_PER_SIDEREAL_SECOND;
            ddec = st.dec_rate;
        }
        let sky = [(dha + pulse(0), sp), (ddec + pulse(1), sd)];
        let spr = self.steps_per_rev();
        for (k, name) in self.cfg.axes().into_iter().enumerate() {
            let (rate, sense) = sky[k];
            let r = if st.moving[k] != 0.0 {
                step_rate(micro_arcsec(st.moving[k] * 3600.0), spr[k], 1, 1)?
            } else {
                // sense is ±1, or ±1/2 for a coelostat's mirror: kept exact.
                let den = if sense.abs() == 0.5 { 2 } else { 1 };
                let uas = micro_arcsec(rate) * sense.signum() as i64;
                step_rate(if sense == 0.0 { 0 } else { uas }, spr[k], 1, den)?
            };
            let moving = s.get(k).is_some_and(|a| a.state == AxisState::Tracking);
            if r.rate.is_zero() {
                if moving {
                    ctl.stop(Some(name))?;
                }
                continue;
            }
            let arg = RateArg::Value(r);
            ctl.with_board(|b, now| b.track(name, &arg, &TrackOpts::default(), None, now))?;
        }
        Ok(())
    }
}
