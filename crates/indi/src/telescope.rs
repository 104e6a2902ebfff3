//! Telescope: the board's mount through the line protocol's `mount` commands
//! (docs/PROTOCOL.md "Mount"), with the standard properties of INDI's telescopes.
//! EQUATORIAL_EOD_COORD set slews (ON_COORD_SET TRACK: tracking on there; SLEW: tracking
//! off once there) or syncs; the poll reads `mount` and follows slews, parks and pulses.
//! Manual motion is `mount move` at the selected slew rate; TRACK_CUSTOM is the sidereal
//! drive rate with `mount offset`; TIME_UTC is `mount utc`.

use crate::device::{number_of, Props, Values};
use crate::link::{Link, LinkError};
use crate::props::{Element, Perm, Range, Rule, State, Vector};
use crate::xml::Out;
use multistep_controller::mount::line::drive_rate;
use multistep_controller::mount::rates::{ARCSEC_PER_RA_SECOND, SIDEREAL, SI_PER_SIDEREAL_SECOND};
use multistep_controller::mount::{MountConfig, PierSide};
use std::collections::HashMap;

const EOD: &str = "EQUATORIAL_EOD_COORD";
const COORD_SET: &str = "ON_COORD_SET";
const ABORT: &str = "TELESCOPE_ABORT_MOTION";
const TRACK_STATE: &str = "TELESCOPE_TRACK_STATE";
const TRACK_MODE: &str = "TELESCOPE_TRACK_MODE";
const PARK: &str = "TELESCOPE_PARK";
const GUIDE_NS: &str = "TELESCOPE_TIMED_GUIDE_NS";
const GUIDE_WE: &str = "TELESCOPE_TIMED_GUIDE_WE";
const GEO: &str = "GEOGRAPHIC_COORD";
const HORIZONTAL: &str = "HORIZONTAL_COORD";
const PIER: &str = "TELESCOPE_PIER_SIDE";
const TIME: &str = "TIME_UTC";
const SLEW_RATE: &str = "TELESCOPE_SLEW_RATE";
const MOTION_NS: &str = "TELESCOPE_MOTION_NS";
const MOTION_WE: &str = "TELESCOPE_MOTION_WE";
const TRACK_RATE: &str = "TELESCOPE_TRACK_RATE";

/// INDI's track modes and the mount's drive rates (custom: sidereal plus `mount offset`).
const MODES: [(&str, &str); 5] = [
    ("TRACK_SIDEREAL", "sidereal"),
    ("TRACK_SOLAR", "solar"),
    ("TRACK_LUNAR", "lunar"),
    ("TRACK_KING", "king"),
    ("TRACK_CUSTOM", "sidereal"),
];
const CUSTOM: &str = "TRACK_CUSTOM";

/// Slew rates as multiples of sidereal; None: the config's guide rate, or the axis's most.
const SLEW_RATES: [(&str, &str, Option<f64>); 4] = [
    ("SLEW_GUIDE", "Guide", None),
    ("SLEW_CENTERING", "Centering", Some(8.0)),
    ("SLEW_FIND", "Find", Some(64.0)),
    ("SLEW_MAX", "Max", None),
];

/// The longest pulse, ms (the `mount pulse` limit).
const MAX_PULSE_MS: f64 = 600_000.0;

pub struct Telescope {
    /// The line that starts its commands: `mount`, or `mount K` for the K-th of several
    /// telescopes.
    mount: String,
    /// Tracking off once the slew under way ends (ON_COORD_SET SLEW).
    stop_after: bool,
    /// A park under way (TELESCOPE_PARK Busy until `parked=1`).
    parking: bool,
    /// The telescope's entry of the board config: geometry, guide rates, axes.
    cfg: MountConfig,
    /// The most `mount move` rate of each axis (degrees/s), read at connect.
    max_rate: [f64; 2],
}

/// The status line of `mount` (a `mount` line) as key → value.
pub fn mount_status(link: &mut Link, mount: &str) -> Result<HashMap<String, String>, LinkError> {
    let data = link.request(mount)?;
    let line = data.first().map(String::as_str).unwrap_or("");
    let rest = line
        .strip_prefix("mount ")
        .ok_or_else(|| LinkError::Refused {
            code: 0,
            message: format!("unexpected mount status '{line}'"),
        })?;
    Ok(rest
        .split(' ')
        .filter_map(|kv| kv.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect())
}

fn num(s: &HashMap<String, String>, k: &str) -> f64 {
    s.get(k).and_then(|v| v.parse().ok()).unwrap_or(0.0)
}

fn flag(s: &HashMap<String, String>, k: &str) -> bool {
    s.get(k).is_some_and(|v| v == "1")
}

fn range(min: f64, max: f64, format: &'static str) -> Range {
    Range {
        min,
        max,
        step: 0.0,
        format,
    }
}

fn switches(
    dev: &str,
    name: &'static str,
    label: &'static str,
    els: &[(&str, &str, bool)],
) -> Vector {
    Vector::new(
        dev,
        name,
        label,
        "Main Control",
        Perm::Rw,
        els.iter()
            .map(|(n, l, on)| Element::switch(n, l, *on))
            .collect(),
    )
}

/// A number vector in state Ok: (name, label, group, perm) and its elements.
fn numbers(
    dev: &str,
    (name, label, group, perm): (&'static str, &'static str, &'static str, Perm),
    els: Vec<(&str, &str, f64, Range)>,
) -> Vector {
    let mut v = Vector::new(
        dev,
        name,
        label,
        group,
        perm,
        els.into_iter()
            .map(|(n, l, x, r)| Element::number(n, l, x, r))
            .collect(),
    );
    v.state = State::Ok;
    v
}

/// Turns on the switches a client set On (OneOfMany turns the others off).
fn set_switches(p: &mut Props, name: &str, values: &Values) {
    if let Some(v) = p.get_mut(name) {
        for (e, t) in values {
            if t.trim() == "On" && v.element(e).is_some() {
                v.set_switch(e, true);
            }
        }
    }
}

/// The manual motion properties that are Busy, Idle with their switches Off.
fn end_motion(p: &mut Props, why: Option<&str>) -> Vec<Out> {
    let mut out = Vec::new();
    for n in [MOTION_NS, MOTION_WE] {
        if let Some(v) = p.get_mut(n).filter(|v| v.state == State::Busy) {
            for e in &mut v.elements {
                e.value = crate::props::Value::Switch(false);
            }
            v.state = State::Idle;
            out.push(v.set(why));
        }
    }
    out
}

/// The mount's clock as INDI writes UTC: `YYYY-MM-DDTHH:MM:SS`, no fraction or zone.
fn indi_utc(s: &HashMap<String, String>) -> String {
    let t = s.get("utc").map_or("", String::as_str);
    t.split(['.', 'Z']).next().unwrap_or(t).to_string()
}

impl Telescope {
    /// The telescope that `mount` lines starting with `mount` drive.
    pub fn new(mount: String, cfg: MountConfig) -> Telescope {
        Telescope {
            mount,
            stop_after: false,
            parking: false,
            cfg,
            max_rate: [0.0; 2],
        }
    }

    /// `mount[ K] words`.
    fn line(&self, words: &str) -> String {
        format!("{} {words}", self.mount)
    }

    pub fn build(&mut self, dev: &str, link: &mut Link) -> Result<Vec<Vector>, LinkError> {
        let s = mount_status(link, &self.mount)?;
        // As the mount's MoveAxis limit: the axis's vmax over its steps per turn.
        let spr = [Some(self.cfg.ra_steps_per_rev), self.cfg.dec_steps_per_rev];
        for (k, axis) in self.cfg.axes().into_iter().enumerate() {
            let vmax = link.setting(axis, "vmax")?.unwrap_or(0.0);
            let spr = spr[k].unwrap_or(0) as f64;
            self.max_rate[k] = if spr > 0.0 { vmax / spr * 360.0 } else { 0.0 };
        }
        let g = "Main Control";
        let dms = |min, max| range(min, max, "%010.6m");
        let mut eod = numbers(
            dev,
            (EOD, "Eq. Coordinates", g, Perm::Rw),
            vec![
                ("RA", "RA (hh:mm:ss)", num(&s, "ra"), dms(0.0, 24.0)),
                ("DEC", "DEC (dd:mm:ss)", num(&s, "dec"), dms(-90.0, 90.0)),
            ],
        );
        if flag(&s, "slewing") {
            eod.state = State::Busy;
        }
        let tracking = flag(&s, "tracking");
        let parked = flag(&s, "parked");
        let rate = s.get("rate").map_or("sidereal", String::as_str);
        let (ra_off, dec_off) = (num(&s, "raoffset"), num(&s, "decoffset"));
        let custom = ra_off != 0.0 || dec_off != 0.0;
        // INDI's custom rate is the sky's: the drive rate less the RA offset.
        let drive = drive_rate(rate).map_or(SIDEREAL, |r| r.micro_arcsec() as f64 / 1e6);
        let mut track_rate = numbers(
            dev,
            (TRACK_RATE, "Track Rates", g, Perm::Rw),
            vec![
                (
                    "TRACK_RATE_RA",
                    "RA (arcsecs/s)",
                    drive - ra_off * ARCSEC_PER_RA_SECOND / SI_PER_SIDEREAL_SECOND,
                    range(0.0, 2.0 * SIDEREAL, "%.6f"),
                ),
                (
                    "TRACK_RATE_DE",
                    "DE (arcsecs/s)",
                    dec_off,
                    range(-SIDEREAL, SIDEREAL, "%.6f"),
                ),
            ],
        );
        track_rate.state = State::Idle;
        let mut time = Vector::new(
            dev,
            TIME,
            "UTC",
            "Site Management",
            Perm::Rw,
            vec![
                Element::text("UTC", "UTC Time", &indi_utc(&s)),
                Element::text("OFFSET", "UTC Offset", "0.00"),
            ],
        );
        time.state = State::Ok;
        let motion = |name: &'static str, label: &'static str, a: (&str, &str), b: (&str, &str)| {
            Vector::new(
                dev,
                name,
                label,
                "Motion Control",
                Perm::Rw,
                vec![
                    Element::switch(a.0, a.1, false),
                    Element::switch(b.0, b.1, false),
                ],
            )
            .rule(Rule::AtMostOne)
        };
        let geo = numbers(
            dev,
            (GEO, "Scope Location", "Site Management", Perm::Ro),
            vec![
                ("LAT", "Lat (dd:mm:ss)", num(&s, "lat"), dms(-90.0, 90.0)),
                // INDI's longitude runs 0 to 360 east.
                (
                    "LONG",
                    "Lon (dd:mm:ss)",
                    num(&s, "lon").rem_euclid(360.0),
                    dms(0.0, 360.0),
                ),
                (
                    "ELEV",
                    "Elevation (m)",
                    num(&s, "elevation"),
                    range(-500.0, 10000.0, "%g"),
                ),
            ],
        );
        let horizontal = numbers(
            dev,
            (HORIZONTAL, "Horizontal Coordinates", g, Perm::Ro),
            vec![
                ("ALT", "Alt (dd:mm:ss)", num(&s, "alt"), dms(-90.0, 90.0)),
                ("AZ", "Az (dd:mm:ss)", num(&s, "az"), dms(0.0, 360.0)),
            ],
        );
        let side = s.get("side").map_or("unknown", String::as_str);
        let mut pier = Vector::new(
            dev,
            PIER,
            "Pier Side",
            g,
            Perm::Ro,
            vec![
                Element::switch("PIER_WEST", "West (pointing east)", side == "west"),
                Element::switch("PIER_EAST", "East (pointing west)", side == "east"),
            ],
        );
        pier.state = State::Ok;
        let guide = |name: &'static str,
                     a: (&'static str, &'static str),
                     b: (&'static str, &'static str)| {
            let ms = range(0.0, MAX_PULSE_MS, "%.0f");
            let mut v = numbers(
                dev,
                (name, "Guide", "Guide", Perm::Rw),
                vec![(a.0, a.1, 0.0, ms.clone()), (b.0, b.1, 0.0, ms)],
            );
            v.state = State::Idle;
            v
        };
        Ok(vec![
            eod,
            switches(
                dev,
                COORD_SET,
                "On Set",
                &[
                    ("TRACK", "Track", true),
                    ("SLEW", "Slew", false),
                    ("SYNC", "Sync", false),
                ],
            ),
            switches(dev, ABORT, "Abort Motion", &[("ABORT", "Abort", false)])
                .rule(Rule::AtMostOne),
            switches(
                dev,
                TRACK_STATE,
                "Tracking",
                &[
                    ("TRACK_ON", "On", tracking),
                    ("TRACK_OFF", "Off", !tracking),
                ],
            ),
            switches(
                dev,
                TRACK_MODE,
                "Track Mode",
                &MODES.map(|(n, r)| {
                    let on = if n == CUSTOM {
                        custom
                    } else {
                        !custom && r == rate
                    };
                    (n, &n[6..], on)
                }),
            ),
            track_rate,
            Vector::new(
                dev,
                SLEW_RATE,
                "Slew Rate",
                "Motion Control",
                Perm::Rw,
                SLEW_RATES
                    .iter()
                    .map(|(n, l, _)| Element::switch(n, l, *n == "SLEW_CENTERING"))
                    .collect(),
            ),
            motion(
                MOTION_NS,
                "Motion N/S",
                ("MOTION_NORTH", "North"),
                ("MOTION_SOUTH", "South"),
            ),
            motion(
                MOTION_WE,
                "Motion W/E",
                ("MOTION_WEST", "West"),
                ("MOTION_EAST", "East"),
            ),
            switches(
                dev,
                PARK,
                "Parking",
                &[("PARK", "Park", parked), ("UNPARK", "UnPark", !parked)],
            ),
            guide(
                GUIDE_NS,
                ("TIMED_GUIDE_N", "North (ms)"),
                ("TIMED_GUIDE_S", "South (ms)"),
            ),
            guide(
                GUIDE_WE,
                ("TIMED_GUIDE_W", "West (ms)"),
                ("TIMED_GUIDE_E", "East (ms)"),
            ),
            geo,
            time,
            horizontal,
            pier,
        ])
    }

    pub fn on_new(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        name: &str,
        values: &Values,
    ) -> Vec<Out> {
        match name {
            EOD => {
                let (ra, dec) = match (number_of(values, "RA"), number_of(values, "DEC")) {
                    (Ok(ra), Ok(dec)) => (ra, dec),
                    (Err(e), _) | (_, Err(e)) => return p.alert(EOD, &e),
                };
                let how = p.get(COORD_SET).map_or("TRACK", |v| {
                    ["SLEW", "SYNC"]
                        .into_iter()
                        .find(|e| v.switch(e))
                        .unwrap_or("TRACK")
                });
                self.goto(p, link, how, ra, dec)
            }
            COORD_SET => {
                set_switches(p, name, values);
                p.state(name, State::Ok, None)
            }
            ABORT => match link.request(&self.line("abort")) {
                Ok(_) => {
                    self.stop_after = false;
                    self.parking = false;
                    let mut out = p.state(ABORT, State::Ok, None);
                    for n in [EOD, PARK] {
                        if p.get(n).is_some_and(|v| v.state == State::Busy) {
                            out.extend(p.state(n, State::Idle, Some("aborted")));
                        }
                    }
                    // `mount abort` ends manual motion too.
                    out.extend(end_motion(p, Some("aborted")));
                    out
                }
                Err(e) => p.alert(ABORT, &e.to_string()),
            },
            TRACK_STATE => {
                let on = values.iter().any(|(e, t)| {
                    (e == "TRACK_ON" && t.trim() == "On") || (e == "TRACK_OFF" && t.trim() == "Off")
                });
                match link.request(&self.line(if on { "track on" } else { "track off" })) {
                    Ok(_) => {
                        if let Some(v) = p.get_mut(name) {
                            v.set_switch(if on { "TRACK_ON" } else { "TRACK_OFF" }, true);
                        }
                        p.state(name, State::Ok, None)
                    }
                    Err(e) => p.alert(name, &e.to_string()),
                }
            }
            TRACK_MODE => {
                let Some((mode, rate)) = MODES
                    .into_iter()
                    .find(|(m, _)| values.iter().any(|(e, t)| e == m && t.trim() == "On"))
                else {
                    return p.alert(name, "no track mode set On");
                };
                let on = p.get(TRACK_STATE).is_some_and(|v| v.switch("TRACK_ON"));
                let (ra, de) = if mode == CUSTOM {
                    match self.custom_offset(p) {
                        Ok(o) => o,
                        Err(e) => return p.alert(name, &e),
                    }
                } else {
                    (0.0, 0.0)
                };
                let lines = [
                    self.line(&format!("track {} {rate}", if on { "on" } else { "off" })),
                    self.line(&format!("offset {ra} {de}")),
                ];
                match lines.iter().try_for_each(|l| link.request(l).map(drop)) {
                    Ok(_) => {
                        if let Some(v) = p.get_mut(name) {
                            v.set_switch(mode, true);
                        }
                        p.state(name, State::Ok, None)
                    }
                    Err(e) => p.alert(name, &e.to_string()),
                }
            }
            PARK => {
                let park = values.iter().any(|(e, t)| e == "PARK" && t.trim() == "On");
                match link.request(&self.line(if park { "park" } else { "unpark" })) {
                    Ok(_) => {
                        self.parking = park;
                        self.stop_after = false;
                        if !park {
                            if let Some(v) = p.get_mut(name) {
                                v.set_switch("UNPARK", true);
                            }
                        }
                        p.state(name, if park { State::Busy } else { State::Ok }, None)
                    }
                    Err(e) => p.alert(name, &e.to_string()),
                }
            }
            GUIDE_NS | GUIDE_WE => self.pulse(p, link, name, values),
            TIME => self.time(p, link, values),
            SLEW_RATE => {
                set_switches(p, name, values);
                p.state(name, State::Ok, None)
            }
            MOTION_NS | MOTION_WE => self.motion(p, link, name, values),
            TRACK_RATE => self.track_rate(p, link, values),
            _ => vec![],
        }
    }

    /// A slew (tracking on first: the mount slews only while tracking) or a sync.
    fn goto(&mut self, p: &mut Props, link: &mut Link, how: &str, ra: f64, dec: f64) -> Vec<Out> {
        let tracking = p.get(TRACK_STATE).is_some_and(|v| v.switch("TRACK_ON"));
        let mut lines = Vec::new();
        if !tracking {
            lines.push(self.line("track on"));
        }
        let verb = if how == "SYNC" { "sync" } else { "slew" };
        lines.push(self.line(&format!("{verb} {ra} {dec}")));
        // A sync leaves tracking as it was.
        if how == "SYNC" && !tracking {
            lines.push(self.line("track off"));
        }
        for l in &lines {
            if let Err(e) = link.request(l) {
                return p.alert(EOD, &e.to_string());
            }
        }
        let mut out = Vec::new();
        if !tracking && how != "SYNC" {
            if let Some(v) = p.get_mut(TRACK_STATE) {
                v.set_switch("TRACK_ON", true);
                v.state = State::Ok;
                out.push(v.set(None));
            }
        }
        self.stop_after = how == "SLEW";
        if how == "SYNC" {
            if let Some(v) = p.get_mut(EOD) {
                v.set_number("RA", ra);
                v.set_number("DEC", dec);
                v.state = State::Ok;
                out.push(v.set(None));
            }
        } else {
            out.extend(p.state(EOD, State::Busy, None));
        }
        out
    }

    /// `mount offset` for TRACK_RATE's values: the RA offset in seconds of RA per sidereal
    /// second from the sidereal drive rate, the Dec one in ″/s.
    fn custom_offset(&self, p: &Props) -> Result<(f64, f64), String> {
        let v = p.get(TRACK_RATE).ok_or("no TELESCOPE_TRACK_RATE")?;
        let (ra, de) = (v.number("TRACK_RATE_RA"), v.number("TRACK_RATE_DE"));
        if de != 0.0 && self.cfg.dec_axis.is_none() {
            return Err("a coelostat has no declination axis: TRACK_RATE_DE must be 0".into());
        }
        Ok((
            (SIDEREAL - ra) * SI_PER_SIDEREAL_SECOND / ARCSEC_PER_RA_SECOND,
            de,
        ))
    }

    /// TELESCOPE_TRACK_RATE: kept, and sent at once while TRACK_CUSTOM is the mode.
    fn track_rate(&mut self, p: &mut Props, link: &mut Link, values: &Values) -> Vec<Out> {
        let limits = [
            ("TRACK_RATE_RA", 0.0, 2.0 * SIDEREAL),
            ("TRACK_RATE_DE", -SIDEREAL, SIDEREAL),
        ];
        let mut new = Vec::new();
        for (e, min, max) in limits {
            if values.iter().all(|(n, _)| n != e) {
                continue;
            }
            match number_of(values, e) {
                Ok(x) if (min..=max).contains(&x) => new.push((e, x)),
                Ok(x) => {
                    return p.alert(
                        TRACK_RATE,
                        &format!("{e}: {x} ″/s is outside {min} to {max}"),
                    )
                }
                Err(m) => return p.alert(TRACK_RATE, &m),
            }
        }
        let old = p.get(TRACK_RATE).cloned();
        if let Some(v) = p.get_mut(TRACK_RATE) {
            for (e, x) in &new {
                v.set_number(e, *x);
            }
        }
        if !p.get(TRACK_MODE).is_some_and(|v| v.switch(CUSTOM)) {
            return p.state(TRACK_RATE, State::Ok, None);
        }
        let sent = self.custom_offset(p).and_then(|(ra, de)| {
            link.request(&self.line(&format!("offset {ra} {de}")))
                .map_err(|e| e.to_string())
        });
        match sent {
            Ok(_) => p.state(TRACK_RATE, State::Ok, None),
            Err(e) => {
                // Refused: the rates the mount has stay shown.
                if let (Some(v), Some(old)) = (p.get_mut(TRACK_RATE), old) {
                    *v = old;
                }
                p.alert(TRACK_RATE, &e)
            }
        }
    }

    /// TIME_UTC: UTC set on the mount's clock (`mount utc`); OFFSET is the client's
    /// local time zone, kept by the driver.
    fn time(&mut self, p: &mut Props, link: &mut Link, values: &Values) -> Vec<Out> {
        let offset = match values.iter().find(|(n, _)| n == "OFFSET") {
            None => None,
            Some((_, t)) => match t.trim().parse::<f64>() {
                Ok(h) if (-14.0..=14.0).contains(&h) => Some(format!("{h:.2}")),
                _ => {
                    return p.alert(
                        TIME,
                        &format!("OFFSET: '{}' is not hours from -14 to 14", t.trim()),
                    )
                }
            },
        };
        if let Some((_, t)) = values.iter().find(|(n, _)| n == "UTC") {
            let t = t.trim();
            // One word on the line protocol: no spaces or control characters.
            if t.is_empty() || t.chars().any(|c| c.is_whitespace() || c.is_control()) {
                return p.alert(TIME, &format!("UTC: '{t}' is not an ISO 8601 time"));
            }
            // INDI writes UTC without a zone.
            let zoned = t
                .split_once(['T', 't'])
                .is_some_and(|(_, c)| c.ends_with(['Z', 'z']) || c.contains(['+', '-']));
            let iso = if zoned {
                t.to_string()
            } else {
                format!("{t}Z")
            };
            let read = link
                .request(&self.line(&format!("utc {iso}")))
                .and_then(|_| mount_status(link, &self.mount));
            match read {
                Ok(s) => {
                    if let Some(v) = p.get_mut(TIME) {
                        v.set_text("UTC", &indi_utc(&s));
                    }
                }
                Err(e) => return p.alert(TIME, &e.to_string()),
            }
        }
        if let (Some(o), Some(v)) = (offset, p.get_mut(TIME)) {
            v.set_text("OFFSET", &o);
        }
        p.state(TIME, State::Ok, None)
    }

    /// TELESCOPE_MOTION_NS/WE: `mount move` of the axis at the slew rate while a switch is
    /// On, 0 when both are Off.
    fn motion(&mut self, p: &mut Props, link: &mut Link, name: &str, values: &Values) -> Vec<Out> {
        let (k, ids) = if name == MOTION_NS {
            (1, ["MOTION_NORTH", "MOTION_SOUTH"])
        } else {
            (0, ["MOTION_WEST", "MOTION_EAST"])
        };
        let Some(cur) = p.get(name) else {
            return vec![];
        };
        // The switches as they will be: the values given, the others as they are.
        let now = ids.map(|e| match values.iter().find(|(n, _)| n == e) {
            Some((_, t)) => t.trim() == "On",
            None => cur.switch(e),
        });
        // The one just turned On wins (AtMostOne).
        let now = match now {
            [true, true] if values.iter().any(|(n, t)| n == ids[1] && t.trim() == "On") => {
                [false, true]
            }
            [true, true] => [true, false],
            x => x,
        };
        let sign = if now[0] {
            1.0
        } else if now[1] {
            -1.0
        } else {
            0.0
        };
        let rate = if sign == 0.0 {
            0.0
        } else {
            let s = match mount_status(link, &self.mount) {
                Ok(s) => s,
                Err(e) => return p.alert(name, &e.to_string()),
            };
            let side = match s.get("side").map(String::as_str) {
                Some("east") => PierSide::East,
                Some("west") => PierSide::West,
                _ => PierSide::Unknown,
            };
            // North: Dec up; west: hour angle up. The axis turns as the mount's sense says.
            let sense = self.cfg.mount.sense(side, num(&s, "lat"));
            let sense = if k == 0 { sense.0 } else { sense.1 };
            if sense == 0.0 {
                return p.alert(name, "this mount has no declination axis");
            }
            sign * sense.signum() * self.slew_rate(p, k)
        };
        let axis = if k == 0 { "ra" } else { "dec" };
        if let Err(e) = link.request(&self.line(&format!("move {axis} {rate}"))) {
            return p.alert(name, &e.to_string());
        }
        if let Some(v) = p.get_mut(name) {
            v.set_switch(ids[0], now[0]);
            v.set_switch(ids[1], now[1]);
        }
        p.state(
            name,
            if sign == 0.0 {
                State::Idle
            } else {
                State::Busy
            },
            None,
        )
    }

    /// The selected slew rate of axis `k`, degrees/s, within the axis's most.
    fn slew_rate(&self, p: &Props, k: usize) -> f64 {
        let sel = p
            .get(SLEW_RATE)
            .and_then(|v| SLEW_RATES.iter().find(|(n, _, _)| v.switch(n)))
            .map_or("SLEW_CENTERING", |(n, _, _)| *n);
        let guide = [self.cfg.guide_rate_ra, self.cfg.guide_rate_dec][k];
        // A hair under the most, so rounding never takes it past the mount's limit.
        let max = self.max_rate[k] * (1.0 - 1e-9);
        let times = match SLEW_RATES.iter().find(|(n, _, _)| *n == sel) {
            Some((_, _, Some(x))) => *x,
            _ if sel == "SLEW_GUIDE" => guide,
            _ => return max,
        };
        (times * SIDEREAL / 3600.0).min(max)
    }

    fn pulse(&mut self, p: &mut Props, link: &mut Link, name: &str, values: &Values) -> Vec<Out> {
        let dirs: &[(&str, &str)] = if name == GUIDE_NS {
            &[("TIMED_GUIDE_N", "n"), ("TIMED_GUIDE_S", "s")]
        } else {
            &[("TIMED_GUIDE_W", "w"), ("TIMED_GUIDE_E", "e")]
        };
        // The first element given a duration above 0.
        let mut pulse = None;
        for (e, d) in dirs {
            match number_of(values, e) {
                Ok(ms) if ms > 0.0 => {
                    if ms.fract() != 0.0 || ms > MAX_PULSE_MS {
                        return p.alert(
                            name,
                            &format!("{e}: {ms} is not a whole number of ms up to {MAX_PULSE_MS}"),
                        );
                    }
                    pulse = Some((*e, *d, ms));
                    break;
                }
                Ok(ms) if ms < 0.0 => return p.alert(name, &format!("{e}: {ms} ms is negative")),
                Ok(_) => {}
                // An element left out is 0.
                Err(_) if values.iter().all(|(n, _)| n != e) => {}
                Err(m) => return p.alert(name, &m),
            }
        }
        let Some((e, d, ms)) = pulse else {
            return p.state(name, State::Ok, None);
        };
        match link.request(&self.line(&format!("pulse {d} {}", ms as i64))) {
            Ok(_) => {
                if let Some(v) = p.get_mut(name) {
                    v.set_number(e, ms);
                }
                p.state(name, State::Busy, None)
            }
            Err(err) => p.alert(name, &err.to_string()),
        }
    }

    /// Reads `mount` and reports what changed: coordinates, the end of slews, parks and
    /// pulses, tracking, pier side.
    pub fn poll(&mut self, p: &mut Props, link: &mut Link) -> Vec<Out> {
        let s = match mount_status(link, &self.mount) {
            Ok(s) => s,
            Err(e) => return p.alert(EOD, &e.to_string()),
        };
        let mut out = Vec::new();
        let slewing = flag(&s, "slewing");
        let tracking = flag(&s, "tracking");
        let parked = flag(&s, "parked");
        if !slewing && self.stop_after {
            self.stop_after = false;
            if let Err(e) = link.request(&self.line("track off")) {
                out.extend(p.alert(TRACK_STATE, &e.to_string()));
            }
        }
        if let Some(v) = p.get_mut(EOD) {
            let (ra, dec) = (num(&s, "ra"), num(&s, "dec"));
            let was = v.state;
            let state = match (was, slewing) {
                (_, true) if was != State::Idle => State::Busy,
                (State::Busy, false) => State::Ok,
                _ => was,
            };
            if v.number("RA") != ra || v.number("DEC") != dec || state != was {
                v.set_number("RA", ra);
                v.set_number("DEC", dec);
                v.state = state;
                out.push(v.set(None));
            }
        }
        if let Some(v) = p.get_mut(HORIZONTAL) {
            let (alt, az) = (num(&s, "alt"), num(&s, "az"));
            if v.number("ALT") != alt || v.number("AZ") != az {
                v.set_number("ALT", alt);
                v.set_number("AZ", az);
                out.push(v.set(None));
            }
        }
        if let Some(v) = p.get_mut(TRACK_STATE) {
            if v.switch("TRACK_ON") != tracking && v.state != State::Alert {
                v.set_switch(if tracking { "TRACK_ON" } else { "TRACK_OFF" }, true);
                out.push(v.set(None));
            }
        }
        if let Some(v) = p.get_mut(PARK) {
            let done = self.parking && parked;
            if done || (!self.parking && v.switch("PARK") != parked) {
                self.parking = false;
                v.set_switch(if parked { "PARK" } else { "UNPARK" }, true);
                v.state = State::Ok;
                out.push(v.set(None));
            } else if self.parking && !slewing && !parked {
                // Stopped on the way (an abort from another client, a fault).
                self.parking = false;
                v.state = State::Alert;
                out.push(v.set(Some("the park stopped before the park position")));
            }
        }
        if !flag(&s, "guiding") {
            for name in [GUIDE_NS, GUIDE_WE] {
                if let Some(v) = p.get_mut(name) {
                    if v.state == State::Busy {
                        for e in [
                            "TIMED_GUIDE_N",
                            "TIMED_GUIDE_S",
                            "TIMED_GUIDE_W",
                            "TIMED_GUIDE_E",
                        ] {
                            if v.element(e).is_some() {
                                v.set_number(e, 0.0);
                            }
                        }
                        v.state = State::Ok;
                        out.push(v.set(None));
                    }
                }
            }
        }
        if !slewing {
            // Stopped elsewhere (an abort from another client, a fault).
            out.extend(end_motion(p, None));
        }
        if let Some(v) = p.get_mut(PIER) {
            let side = s.get("side").map_or("unknown", String::as_str);
            let (w, e) = (side == "west", side == "east");
            if v.switch("PIER_WEST") != w || v.switch("PIER_EAST") != e {
                v.set_switch("PIER_WEST", w);
                v.set_switch("PIER_EAST", e);
                out.push(v.set(None));
            }
        }
        out
    }
}
