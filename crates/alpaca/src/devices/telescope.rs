//! Telescope (ITelescopeV4) over the controller's mount model. Equatorial system:
//! topocentric, of the date (JNow): coordinates are the mount's axes read through the
//! local sidereal time, with no precession, nutation or refraction applied.

use super::{val, Answer, Device};
use crate::errors::{code, Fault};
use crate::params::Params;
use multistep_controller::mount::{
    rates::DRIVE_RATES, DriveRate, Geometry, Mount, MountError, PierSide,
};
use multistep_controller::Controller;
use serde_json::{json, Value};
use std::time::Duration;

/// Longest a synchronous SlewToAltAz waits for its slew to end.
const SYNC_SLEW_LIMIT: Duration = Duration::from_secs(600);

/// ASCOM InvalidWhileParked.
const INVALID_WHILE_PARKED: u16 = 0x408;
/// ASCOM EquatorialCoordinateType equTopocentric (JNow).
const EQU_TOPOCENTRIC: u8 = 1;

impl From<MountError> for Fault {
    fn from(e: MountError) -> Fault {
        match e {
            MountError::Invalid(m) => Fault::invalid_value(m),
            MountError::NotNow(m) => Fault::invalid_operation(m),
            MountError::Parked => Fault::device(INVALID_WHILE_PARKED, e.to_string()),
            MountError::Ctl(c) => c.into(),
        }
    }
}

/// The ITelescopeV4 members beyond the common ones: (name, is PUT).
pub(super) const METHODS: &[(&str, bool)] = &[
    ("alignmentmode", false),
    ("altitude", false),
    ("aperturearea", false),
    ("aperturediameter", false),
    ("athome", false),
    ("atpark", false),
    ("azimuth", false),
    ("canfindhome", false),
    ("canpark", false),
    ("canpulseguide", false),
    ("cansetdeclinationrate", false),
    ("cansetguiderates", false),
    ("cansetpark", false),
    ("cansetpierside", false),
    ("cansetrightascensionrate", false),
    ("cansettracking", false),
    ("canslew", false),
    ("canslewaltaz", false),
    ("canslewaltazasync", false),
    ("canslewasync", false),
    ("cansync", false),
    ("cansyncaltaz", false),
    ("canunpark", false),
    ("declination", false),
    ("declinationrate", false),
    ("declinationrate", true),
    ("doesrefraction", false),
    ("doesrefraction", true),
    ("equatorialsystem", false),
    ("focallength", false),
    ("guideratedeclination", false),
    ("guideratedeclination", true),
    ("guideraterightascension", false),
    ("guideraterightascension", true),
    ("ispulseguiding", false),
    ("rightascension", false),
    ("rightascensionrate", false),
    ("rightascensionrate", true),
    ("sideofpier", false),
    ("sideofpier", true),
    ("siderealtime", false),
    ("siteelevation", false),
    ("siteelevation", true),
    ("sitelatitude", false),
    ("sitelatitude", true),
    ("sitelongitude", false),
    ("sitelongitude", true),
    ("slewing", false),
    ("slewsettletime", false),
    ("slewsettletime", true),
    ("targetdeclination", false),
    ("targetdeclination", true),
    ("targetrightascension", false),
    ("targetrightascension", true),
    ("tracking", false),
    ("tracking", true),
    ("trackingrate", false),
    ("trackingrate", true),
    ("trackingrates", false),
    ("utcdate", false),
    ("utcdate", true),
    ("abortslew", true),
    ("axisrates", false),
    ("canmoveaxis", false),
    ("destinationsideofpier", false),
    ("findhome", true),
    ("moveaxis", true),
    ("park", true),
    ("pulseguide", true),
    ("setpark", true),
    ("slewtoaltaz", true),
    ("slewtoaltazasync", true),
    ("slewtocoordinates", true),
    ("slewtocoordinatesasync", true),
    ("slewtotarget", true),
    ("slewtotargetasync", true),
    ("synctoaltaz", true),
    ("synctocoordinates", true),
    ("synctotarget", true),
    ("unpark", true),
];

/// TelescopeAxes: 0 primary, 1 secondary, 2 tertiary; anything else is invalid.
fn axis_number(p: &Params, mount: &Mount) -> Result<Option<usize>, Fault> {
    match p.i32("Axis")? {
        k @ 0..=1 if (k as usize) < mount.cfg.axes().len() => Ok(Some(k as usize)),
        0..=2 => Ok(None),
        k => Err(Fault::invalid_value(format!("Axis {k} is not 0, 1 or 2"))),
    }
}

fn target(m: &Mount) -> Result<(f64, f64), Fault> {
    match m.target() {
        (Some(ra), Some(dec)) => Ok((ra, dec)),
        _ => Err(Fault::device(
            code::VALUE_NOT_SET,
            "TargetRightAscension and TargetDeclination are not both set",
        )),
    }
}

fn side(s: PierSide) -> i32 {
    s as i32
}

impl Device {
    pub(super) fn telescope(
        &self,
        ctl: &Controller,
        m: &Mount,
        method: &str,
        put: bool,
        p: &Params,
    ) -> Answer {
        let two_axes = m.cfg.dec_axis.is_some();
        let german = m.geometry() == Geometry::German;
        let ni = |what: &str| Err(Fault::not_implemented(what));
        match (method, put) {
            ("alignmentmode", _) => val(m.geometry().alignment_mode()),
            ("altitude", _) => val(m.pointing(ctl)?.alt),
            ("azimuth", _) => val(m.pointing(ctl)?.az),
            ("declination", _) => val(m.pointing(ctl)?.dec),
            ("rightascension", _) => val(m.pointing(ctl)?.ra),
            ("sideofpier", false) => val(side(m.pointing(ctl)?.side)),
            ("sideofpier", true) if !german => {
                ni("setting SideOfPier (only a German equatorial mount has two sides)")
            }
            ("sideofpier", true) => {
                let s = match p.i32("SideOfPier")? {
                    0 => PierSide::East,
                    1 => PierSide::West,
                    n => {
                        return Err(Fault::invalid_value(format!(
                            "SideOfPier {n} is not 0 (east) or 1 (west)"
                        )))
                    }
                };
                m.set_pier_side(ctl, s)?;
                Ok(None)
            }
            ("siderealtime", _) => val(m.sidereal_time()),
            ("aperturearea", _) | ("aperturediameter", _) | ("focallength", _) => {
                ni("reporting the optics' size")
            }
            ("athome", _) => val(m.at_home(ctl)?),
            ("atpark", _) => val(m.at_park()),
            ("canfindhome" | "canpark" | "canpulseguide" | "cansetguiderates", _) => val(true),
            ("cansetpark" | "cansettracking" | "canslewasync" | "cansync" | "canunpark", _) => {
                val(true)
            }
            ("cansetrightascensionrate", _) => val(true),
            ("cansetdeclinationrate", _) => val(two_axes),
            ("cansetpierside", _) => val(german),
            ("canslew", _) => val(false),
            // A coelostat reaches one declination only.
            ("canslewaltaz" | "canslewaltazasync" | "cansyncaltaz", _) => val(two_axes),
            ("declinationrate", false) => val(m.rate_offsets().1),
            ("declinationrate", true) => {
                m.set_rate_offset(ctl, true, p.f64("DeclinationRate")?)?;
                Ok(None)
            }
            ("rightascensionrate", false) => val(m.rate_offsets().0),
            ("rightascensionrate", true) => {
                m.set_rate_offset(ctl, false, p.f64("RightAscensionRate")?)?;
                Ok(None)
            }
            ("doesrefraction", false) => val(false),
            ("doesrefraction", true) => {
                if p.bool("DoesRefraction")? {
                    ni("refraction")
                } else {
                    Ok(None)
                }
            }
            ("equatorialsystem", _) => val(EQU_TOPOCENTRIC),
            ("guideratedeclination", false) => val(m.guide_rates()[1]),
            ("guideraterightascension", false) => val(m.guide_rates()[0]),
            ("guideratedeclination", true) => {
                m.set_guide_rate(1, p.f64("GuideRateDeclination")?)?;
                Ok(None)
            }
            ("guideraterightascension", true) => {
                m.set_guide_rate(0, p.f64("GuideRateRightAscension")?)?;
                Ok(None)
            }
            ("ispulseguiding", _) => val(m.is_pulse_guiding()),
            ("siteelevation", false) => val(m.site().2),
            ("sitelatitude", false) => val(m.site().0),
            ("sitelongitude", false) => val(m.site().1),
            ("siteelevation", true) => {
                m.set_site(None, None, Some(p.f64("SiteElevation")?))?;
                Ok(None)
            }
            ("sitelatitude", true) => {
                m.set_site(Some(p.f64("SiteLatitude")?), None, None)?;
                Ok(None)
            }
            ("sitelongitude", true) => {
                m.set_site(None, Some(p.f64("SiteLongitude")?), None)?;
                Ok(None)
            }
            ("slewing", _) => val(m.slewing()),
            ("slewsettletime", false) => val(m.settle_time()),
            ("slewsettletime", true) => {
                m.set_settle_time(p.i32("SlewSettleTime")?)?;
                Ok(None)
            }
            ("targetdeclination", false) => m.target().1.map_or_else(
                || {
                    Err(Fault::device(
                        code::VALUE_NOT_SET,
                        "TargetDeclination is not set",
                    ))
                },
                val,
            ),
            ("targetrightascension", false) => m.target().0.map_or_else(
                || {
                    Err(Fault::device(
                        code::VALUE_NOT_SET,
                        "TargetRightAscension is not set",
                    ))
                },
                val,
            ),
            ("targetdeclination", true) => {
                m.set_target(None, Some(p.f64("TargetDeclination")?))?;
                Ok(None)
            }
            ("targetrightascension", true) => {
                m.set_target(Some(p.f64("TargetRightAscension")?), None)?;
                Ok(None)
            }
            ("tracking", false) => val(m.tracking()),
            ("tracking", true) => {
                m.set_tracking(ctl, p.bool("Tracking")?)?;
                Ok(None)
            }
            ("trackingrate", false) => val(m.drive_rate() as i32),
            ("trackingrate", true) => {
                let n = p.i32("TrackingRate")?;
                let r = DriveRate::from_code(n as i64).ok_or_else(|| {
                    Fault::invalid_value(format!("TrackingRate {n} is not 0 to 3"))
                })?;
                m.set_drive_rate(ctl, r)?;
                Ok(None)
            }
            ("trackingrates", _) => val(DRIVE_RATES.map(|r| r as i32)),
            ("utcdate", false) => val(m.utc_date()),
            ("utcdate", true) => {
                let text = p
                    .get("UTCDate")
                    .ok_or_else(|| Fault::BadRequest("missing parameter UTCDate".into()))?;
                m.set_utc_date(text)?;
                Ok(None)
            }
            ("abortslew", _) => {
                m.abort(ctl)?;
                Ok(None)
            }
            ("axisrates", _) => match axis_number(p, m)? {
                Some(k) => {
                    let max = m.max_axis_rate(ctl, k)?;
                    val(json!([{ "Minimum": 0.0, "Maximum": max }]))
                }
                None => val(Vec::<Value>::new()),
            },
            ("canmoveaxis", _) => val(axis_number(p, m)?.is_some()),
            ("destinationsideofpier", _) => {
                let s = m.destination_side(p.f64("RightAscension")?, p.f64("Declination")?)?;
                val(side(s))
            }
            ("findhome", _) => {
                m.find_home(ctl)?;
                Ok(None)
            }
            ("moveaxis", _) => {
                let rate = p.f64("Rate")?;
                match axis_number(p, m)? {
                    Some(k) => m.move_axis(ctl, k, rate)?,
                    None => {
                        return Err(Fault::invalid_value(format!(
                            "Axis {} cannot be moved",
                            p.get("Axis").unwrap_or("")
                        )))
                    }
                }
                Ok(None)
            }
            ("park", _) => {
                m.park(ctl)?;
                Ok(None)
            }
            ("unpark", _) => {
                m.unpark(ctl)?;
                Ok(None)
            }
            ("setpark", _) => {
                m.set_park(ctl)?;
                Ok(None)
            }
            ("pulseguide", _) => {
                let dir = p.i32("Direction")?;
                let ms = p.i32("Duration")?;
                m.pulse(ctl, dir as i64, ms as i64)?;
                Ok(None)
            }
            (
                "slewtocoordinatesasync"
                | "slewtotargetasync"
                | "synctocoordinates"
                | "synctotarget",
                _,
            ) => {
                let (ra, dec) = if method.contains("coordinates") {
                    (p.f64("RightAscension")?, p.f64("Declination")?)
                } else {
                    target(m)?
                };
                if method.starts_with("slew") {
                    m.slew(ctl, ra, dec)?
                } else {
                    m.sync(ctl, ra, dec)?
                }
                Ok(None)
            }
            ("slewtocoordinates" | "slewtotarget", _) => {
                Err(Fault::device(
                    code::NOT_IMPLEMENTED,
                    "synchronous slews are not implemented; use SlewToCoordinatesAsync or SlewToTargetAsync",
                ))
            }
            ("slewtoaltaz" | "slewtoaltazasync" | "synctoaltaz", _) if !two_axes => {
                ni("slewing or syncing a coelostat in altitude and azimuth")
            }
            ("slewtoaltaz" | "slewtoaltazasync" | "synctoaltaz", _) => {
                let (alt, az) = (p.f64("Altitude")?, p.f64("Azimuth")?);
                match method {
                    "synctoaltaz" => m.sync_alt_az(ctl, alt, az)?,
                    _ => m.slew_alt_az(ctl, alt, az)?,
                }
                if method == "slewtoaltaz" && !m.wait_slew(SYNC_SLEW_LIMIT) {
                    return Err(Fault::invalid_operation(format!(
                        "the slew did not end within {} s; it goes on",
                        SYNC_SLEW_LIMIT.as_secs()
                    )));
                }
                Ok(None)
            }
            _ => Err(Fault::BadRequest(format!("unknown method {method}"))),
        }
    }

    /// ITelescopeV4 DeviceState's operational properties.
    pub(super) fn telescope_state(&self, ctl: &Controller, m: &Mount) -> Answer {
        let item = |name: &str, v: Value| json!({ "Name": name, "Value": v });
        let pt = m.pointing(ctl)?;
        val(vec![
            item("Altitude", json!(pt.alt)),
            item("AtHome", json!(m.at_home(ctl)?)),
            item("AtPark", json!(m.at_park())),
            item("Azimuth", json!(pt.az)),
            item("Declination", json!(pt.dec)),
            item("IsPulseGuiding", json!(m.is_pulse_guiding())),
            item("RightAscension", json!(pt.ra)),
            item("SideOfPier", json!(side(pt.side))),
            item("SiderealTime", json!(pt.lst)),
            item("Slewing", json!(m.slewing())),
            item("Tracking", json!(m.tracking())),
            item("UTCDate", json!(m.utc_date())),
        ])
    }
}
