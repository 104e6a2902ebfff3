//! A telescope mount over two axes of the board (one for a coelostat): pointing in hour
//! angle and declination, sidereal tracking through the exact tracker, slews planned by
//! the board's move path, sync, park, Hall homing, limits and pulse guiding.
//!
//! [`Mount`] holds what is the mount's (tracking wanted, rate offsets, sync offsets,
//! pulses under way); the axes' motion is the board's. [`Mount::tick`] runs beside it,
//! ending pulses and resuming tracking when a slew ends.

pub mod config;
pub mod coords;
pub mod line;
mod ops;
pub mod rates;
pub mod time;

pub use config::MountConfig;
pub use coords::{Axes, Geometry, PierSide};
pub use rates::DriveRate;

use crate::axis::{AxisState, AxisStatus};
use crate::error::CtlError;
use crate::Controller;
use std::io::Write;
use std::sync::{Arc, Mutex, MutexGuard, Weak};
use std::time::{Duration, Instant};

/// Why the mount refused.
#[derive(Debug, thiserror::Error)]
pub enum MountError {
    /// A value out of range or a slew beyond the limits (ASCOM InvalidValue).
    #[error("{0}")]
    Invalid(String),
    /// Not possible in the mount's present state (ASCOM InvalidOperation).
    #[error("{0}")]
    NotNow(String),
    #[error("the mount is parked: unpark it first")]
    Parked,
    #[error(transparent)]
    Ctl(#[from] CtlError),
}

/// Where the mount points now.
#[derive(Clone, Copy, Debug)]
pub struct Pointing {
    /// Hours in [0, 24).
    pub ra: f64,
    pub dec: f64,
    /// Degrees in [−180, 180).
    pub ha: f64,
    /// Local sidereal time, hours.
    pub lst: f64,
    pub alt: f64,
    pub az: f64,
    pub side: PierSide,
}

/// A slew, park or homing under way.
#[derive(Clone, Copy, Debug)]
struct Slew {
    /// The equatorial target, aimed at again once when the first move ends (the sky
    /// turned while it ran).
    target: Option<(f64, f64)>,
    /// The pier side the target is reached from (a pier flip); else the side a slew
    /// there takes.
    side: Option<PierSide>,
    park: bool,
    /// Counts to move on to once the first move ends: the last stretch of a park,
    /// approached from the side that takes up the backlash.
    then: Option<[i64; 2]>,
}

#[derive(Clone, Debug)]
struct State {
    lat: f64,
    lon: f64,
    elevation: f64,
    tracking: bool,
    drive: DriveRate,
    /// RightAscensionRate (seconds of RA per sidereal second) and DeclinationRate (″/s).
    ra_rate: f64,
    dec_rate: f64,
    /// Guide rates, degrees per second.
    guide: [f64; 2],
    /// Added to the axes' counted angles (degrees): set by sync, kept in the store.
    sync: Axes,
    /// The mount's clock less the host's UTC, seconds: set through UTCDate, not stored
    /// (a restart reads the host's clock again).
    utc_offset: f64,
    target: (Option<f64>, Option<f64>),
    slew: Option<Slew>,
    parked: bool,
    /// Pulses under way: sky-rate sign and end, [RA, Dec].
    pulse: [Option<(f64, Instant)>; 2],
    /// MoveAxis rates (degrees/s of the axis), [primary, secondary].
    moving: [f64; 2],
    settle: i32,
}

pub struct Mount {
    pub cfg: MountConfig,
    state: Mutex<State>,
}

/// How often the mount looks at its axes (pulse ends, slew ends).
const TICK: Duration = Duration::from_millis(5);
/// Longest PulseGuide, milliseconds.
pub const MAX_PULSE_MS: i64 = 600_000;

impl Mount {
    /// The mount of `cfg` (checked), parked if it was parked when the board last ran,
    /// with the sync offsets it last had.
    pub fn open(cfg: MountConfig, ctl: &Controller) -> Result<Mount, MountError> {
        let parked = ctl
            .with_board(|b, _| b.named_positions())?
            .contains_key(&cfg.parked_name());
        let kept = ctl
            .with_board(|b, _| b.mount_record(&cfg.ra_axis))?
            .unwrap_or_default();
        // A record from a mount configured otherwise (no dec axis now) keeps only its
        // polar offset; a value that is not finite is not used.
        let finite = |x: f64| if x.is_finite() { x } else { 0.0 };
        let dec_sync = if cfg.dec_axis.is_some() {
            finite(kept.sync[1])
        } else {
            0.0
        };
        let sidereal_deg = rates::SIDEREAL / 3600.0;
        let state = State {
            lat: cfg.latitude,
            lon: cfg.longitude,
            elevation: cfg.elevation,
            tracking: false,
            drive: DriveRate::Sidereal,
            ra_rate: 0.0,
            dec_rate: 0.0,
            guide: [
                cfg.guide_rate_ra * sidereal_deg,
                cfg.guide_rate_dec * sidereal_deg,
            ],
            sync: Axes {
                polar: finite(kept.sync[0]),
                dec: dec_sync,
            },
            utc_offset: 0.0,
            target: (None, None),
            slew: None,
            parked,
            pulse: [None, None],
            moving: [0.0; 2],
            settle: 0,
        };
        Ok(Mount {
            cfg,
            state: Mutex::new(state),
        })
    }

    /// Runs [`Mount::tick`] every few milliseconds until the mount or the controller is
    /// dropped (the controller may hold the mount: neither is kept alive from here).
    pub fn supervise(mount: &Arc<Mount>, ctl: Arc<Controller>) -> std::io::Result<()> {
        let weak: Weak<Mount> = Arc::downgrade(mount);
        let ctl_weak = Arc::downgrade(&ctl);
        drop(ctl);
        std::thread::Builder::new()
            .name("mount".into())
            .spawn(move || {
                let mut said = None;
                while let (Some(m), Some(ctl)) = (weak.upgrade(), ctl_weak.upgrade()) {
                    // A refusal here (e-stop, a limit) is the board's to report; say each once.
                    if let Err(e) = m.tick(&ctl) {
                        let e = e.to_string();
                        if said.as_ref() != Some(&e) {
                            // stderr may be closed: nothing to do about that here.
                            let _ = writeln!(std::io::stderr(), "warning: mount: {e}");
                            said = Some(e);
                        }
                    }
                    drop((m, ctl));
                    std::thread::sleep(TICK);
                }
            })
            .map(|_| ())
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    pub fn geometry(&self) -> Geometry {
        self.cfg.mount
    }

    /// The axes' status, [polar, dec].
    fn axes_status(&self, ctl: &Controller) -> Result<Vec<AxisStatus>, MountError> {
        let names: Vec<String> = self.cfg.axes().iter().map(|s| s.to_string()).collect();
        Ok(ctl.status(&names)?)
    }

    fn steps_per_rev(&self) -> [u64; 2] {
        [
            self.cfg.ra_steps_per_rev,
            self.cfg.dec_steps_per_rev.unwrap_or(1),
        ]
    }

    /// Axis angles (degrees, sync offsets added) of counted positions.
    fn angles(&self, st: &State, s: &[AxisStatus]) -> Axes {
        let spr = self.steps_per_rev();
        let deg = |k: usize| {
            s.get(k)
                .map_or(0.0, |a| a.position as f64 / spr[k] as f64 * 360.0)
        };
        Axes {
            polar: deg(0) + st.sync.polar,
            dec: deg(1) + st.sync.dec,
        }
    }

    /// Each axis's backlash (microsteps) and the direction every slew ends moving in:
    /// the polar axis's tracking direction, + for the declination axis. A slew stops
    /// short of its target by the backlash on the other side, then approaches it, so the
    /// gears mesh as they do when tracking.
    fn approach(&self, st: &State, steps: [i64; 2]) -> [i64; 2] {
        let (polar, _) = self.cfg.mount.sense(PierSide::Unknown, st.lat);
        let b = [self.cfg.ra_backlash, self.cfg.dec_backlash];
        let dir = [polar.signum() as i64, 1];
        [0, 1].map(|k| steps[k] - b[k] as i64 * dir[k])
    }

    /// Counted positions that put the axes at `a` (sync offsets taken off).
    fn steps_of(&self, st: &State, a: Axes) -> [i64; 2] {
        let spr = self.steps_per_rev();
        [
            ((a.polar - st.sync.polar) / 360.0 * spr[0] as f64).round() as i64,
            ((a.dec - st.sync.dec) / 360.0 * spr[1] as f64).round() as i64,
        ]
    }

    pub fn pointing(&self, ctl: &Controller) -> Result<Pointing, MountError> {
        let s = self.axes_status(ctl)?;
        let st = self.lock();
        Ok(self.pointing_of(&st, &s))
    }

    /// The mount's UTC now: the host's plus the offset UTCDate set (seconds since 1970).
    fn now(st: &State) -> f64 {
        time::unix_now() + st.utc_offset
    }

    /// Local sidereal time (degrees) by the mount's clock.
    fn lst(st: &State) -> f64 {
        time::lst_deg(Self::now(st), st.lon)
    }

    /// UTCDate: the mount's UTC as ISO 8601 text.
    pub fn utc_date(&self) -> String {
        time::iso8601(Self::now(&self.lock()))
    }

    /// Sets UTCDate (ISO 8601, see [`time::parse_iso8601`]): the mount's clock keeps the
    /// difference from the host's UTC and reads sidereal time from it.
    pub fn set_utc_date(&self, text: &str) -> Result<(), MountError> {
        let t = time::parse_iso8601(text).map_err(MountError::Invalid)?;
        // The axes' rates do not depend on the time: nothing to redo.
        self.lock().utc_offset = t - time::unix_now();
        Ok(())
    }

    fn pointing_of(&self, st: &State, s: &[AxisStatus]) -> Pointing {
        let lst = Self::lst(st);
        let (ha, dec, side) =
            self.cfg
                .mount
                .from_axes(self.angles(st, s), st.lat, self.cfg.coelostat_dec);
        let (alt, az) = coords::alt_az(ha, dec, st.lat);
        Pointing {
            ra: (lst - ha).rem_euclid(360.0) / 15.0 % 24.0,
            dec,
            ha,
            lst: lst / 15.0,
            alt,
            az,
            side,
        }
    }

    /// Local sidereal time now, hours.
    pub fn sidereal_time(&self) -> f64 {
        Self::lst(&self.lock()) / 15.0
    }

    /// A slew, park or homing under way, or an axis moved by MoveAxis.
    pub fn slewing(&self) -> bool {
        let st = self.lock();
        st.slew.is_some() || st.moving != [0.0; 2]
    }

    /// Both axes homed, at the home count, and still.
    pub fn at_home(&self, ctl: &Controller) -> Result<bool, MountError> {
        let s = self.axes_status(ctl)?;
        let st = self.lock();
        Ok(st.slew.is_none()
            && s.iter()
                .all(|a| a.homed && a.position == 0 && a.state == AxisState::Idle))
    }

    pub fn at_park(&self) -> bool {
        self.lock().parked
    }
    pub fn tracking(&self) -> bool {
        self.lock().tracking
    }
    pub fn drive_rate(&self) -> DriveRate {
        self.lock().drive
    }
    pub fn is_pulse_guiding(&self) -> bool {
        self.lock().pulse.iter().any(Option::is_some)
    }
    /// (RightAscensionRate, DeclinationRate).
    pub fn rate_offsets(&self) -> (f64, f64) {
        let st = self.lock();
        (st.ra_rate, st.dec_rate)
    }
    /// Guide rates (degrees/s), [RA, Dec].
    pub fn guide_rates(&self) -> [f64; 2] {
        self.lock().guide
    }
    /// (latitude, longitude, elevation).
    pub fn site(&self) -> (f64, f64, f64) {
        let st = self.lock();
        (st.lat, st.lon, st.elevation)
    }
    /// TargetRightAscension (hours), TargetDeclination.
    pub fn target(&self) -> (Option<f64>, Option<f64>) {
        self.lock().target
    }
    pub fn settle_time(&self) -> i32 {
        self.lock().settle
    }
}

#[cfg(all(test, feature = "sim"))]
mod tests;
