//! Telescope: the board's mount through the line protocol's `mount` commands
//! (docs/PROTOCOL.md "Mount"), with the standard properties of INDI's telescopes.
//! EQUATORIAL_EOD_COORD set slews (ON_COORD_SET TRACK: tracking on there; SLEW: tracking
//! off once there) or syncs; the poll reads `mount` and follows slews, parks and pulses.

use crate::device::{number_of, Props, Values};
use crate::link::{Link, LinkError};
use crate::props::{Element, Perm, Range, Rule, State, Vector};
use crate::xml::Out;
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

/// INDI's track modes and the mount's drive rates.
const MODES: [(&str, &str); 4] = [
    ("TRACK_SIDEREAL", "sidereal"),
    ("TRACK_SOLAR", "solar"),
    ("TRACK_LUNAR", "lunar"),
    ("TRACK_KING", "king"),
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

impl Telescope {
    /// The telescope that `mount` lines starting with `mount` drive.
    pub fn new(mount: String) -> Telescope {
        Telescope {
            mount,
            stop_after: false,
            parking: false,
        }
    }

    /// `mount[ K] words`.
    fn line(&self, words: &str) -> String {
        format!("{} {words}", self.mount)
    }

    pub fn build(&mut self, dev: &str, link: &mut Link) -> Result<Vec<Vector>, LinkError> {
        let s = mount_status(link, &self.mount)?;
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
                &MODES.map(|(n, r)| (n, &n[6..], r == rate)),
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
                let line = self.line(&format!("track {} {rate}", if on { "on" } else { "off" }));
                match link.request(&line) {
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
