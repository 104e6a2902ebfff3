//! Focuser: an absolute focuser on a soft-limited axis. The position is the counted
//! position (the `pos` of `status`), FOCUS_MAX the axis's soft_max, as the Alpaca Focuser.
//! FOCUS_SYNC renames the idle axis's position without moving (the controller's `setpos`).
//! FOCUS_BACKLASH is the axis's `backlash` setting in the controller, which takes the
//! play up inside every move that reverses (docs/PROTOCOL.md, "Backlash"): the toggle
//! off sets it to 0, on to FOCUS_BACKLASH_VALUE.

use crate::device::{abort, fault, moving, number_of, Props, Values};
use crate::link::{Link, LinkError};
use crate::props::{Element, Perm, Range, State, Vector};
use crate::xml::Out;
use multistep_controller::AxisStatus;

#[derive(Default)]
pub struct Focuser {
    max: i64,
    /// FOCUS_BACKLASH_VALUE: the controller's `backlash` while the toggle is on, kept by
    /// the driver while it is off.
    backlash: i64,
}

/// The controller's range of `backlash` (microsteps).
const MAX_BACKLASH: f64 = 1e6;

const ABS: &str = "ABS_FOCUS_POSITION";
const REL: &str = "REL_FOCUS_POSITION";
const SYNC: &str = "FOCUS_SYNC";
const BL_TOGGLE: &str = "FOCUS_BACKLASH_TOGGLE";
const BL_STEPS: &str = "FOCUS_BACKLASH_STEPS";

impl Focuser {
    pub fn build(
        &mut self,
        dev: &str,
        link: &mut Link,
        axis: &str,
        st: &AxisStatus,
    ) -> Result<Vec<Vector>, LinkError> {
        // The `[alpaca]` check at start-up makes soft_max at least 1.
        self.max = link.setting(axis, "soft_max")?.unwrap_or(0.0) as i64;
        let steps = |max: i64| Range {
            min: 0.0,
            max: max as f64,
            step: 1.0,
            format: "%.0f",
        };
        let g = "Main Control";
        let mut abs = Vector::new(
            dev,
            ABS,
            "Absolute Position",
            g,
            Perm::Rw,
            vec![Element::number(
                "FOCUS_ABSOLUTE_POSITION",
                "Steps",
                st.position as f64,
                steps(self.max),
            )],
        );
        abs.state = State::Ok;
        let set = link.setting(axis, "backlash")?.unwrap_or(0.0) as i64;
        let on = set > 0;
        if on {
            self.backlash = set;
        }
        let backlash_range = Range {
            max: MAX_BACKLASH,
            ..steps(0)
        };
        Ok(vec![
            abs,
            Vector::new(
                dev,
                REL,
                "Relative Position",
                g,
                Perm::Rw,
                vec![Element::number(
                    "FOCUS_RELATIVE_POSITION",
                    "Steps",
                    0.0,
                    steps(self.max),
                )],
            ),
            Vector::new(
                dev,
                "FOCUS_MOTION",
                "Direction",
                g,
                Perm::Rw,
                vec![
                    Element::switch("FOCUS_INWARD", "Focus In", true),
                    Element::switch("FOCUS_OUTWARD", "Focus Out", false),
                ],
            ),
            abort(dev, "FOCUS_ABORT_MOTION"),
            Vector::new(
                dev,
                SYNC,
                "Sync",
                g,
                Perm::Rw,
                vec![Element::number(
                    "FOCUS_SYNC_VALUE",
                    "Steps",
                    st.position as f64,
                    steps(self.max),
                )],
            ),
            Vector::new(
                dev,
                "FOCUS_MAX",
                "Max. Position",
                "Main Control",
                Perm::Ro,
                vec![Element::number(
                    "FOCUS_MAX_VALUE",
                    "Steps",
                    self.max as f64,
                    steps(self.max),
                )],
            ),
            Vector::new(
                dev,
                BL_TOGGLE,
                "Backlash",
                g,
                Perm::Rw,
                vec![
                    Element::switch("INDI_ENABLED", "Enabled", on),
                    Element::switch("INDI_DISABLED", "Disabled", !on),
                ],
            ),
            Vector::new(
                dev,
                BL_STEPS,
                "Backlash",
                g,
                Perm::Rw,
                vec![Element::number(
                    "FOCUS_BACKLASH_VALUE",
                    "Steps",
                    self.backlash as f64,
                    backlash_range,
                )],
            ),
        ])
    }

    pub fn on_new(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        axis: &str,
        name: &str,
        values: &Values,
    ) -> Vec<Out> {
        match name {
            ABS => match number_of(values, "FOCUS_ABSOLUTE_POSITION") {
                Ok(to) => self.move_to(p, link, axis, ABS, to),
                Err(e) => p.alert(ABS, &e),
            },
            REL => {
                let by = match number_of(values, "FOCUS_RELATIVE_POSITION") {
                    Ok(x) if x >= 0.0 && x.fract() == 0.0 => x,
                    Ok(x) => return p.alert(REL, &format!("{x} is not a whole number of steps")),
                    Err(e) => return p.alert(REL, &e),
                };
                let inward = p
                    .get("FOCUS_MOTION")
                    .is_some_and(|v| v.switch("FOCUS_INWARD"));
                let at = p
                    .get(ABS)
                    .map_or(0.0, |v| v.number("FOCUS_ABSOLUTE_POSITION"));
                if let Some(v) = p.get_mut(REL) {
                    v.set_number("FOCUS_RELATIVE_POSITION", by);
                }
                // Inward is toward smaller counts, as INDI's focusers have it.
                let to = if inward { at - by } else { at + by };
                self.move_to(p, link, axis, REL, to)
            }
            SYNC => match number_of(values, "FOCUS_SYNC_VALUE") {
                Ok(to) => self.sync(p, link, axis, to),
                Err(e) => p.alert(SYNC, &e),
            },
            "FOCUS_MOTION" => {
                let Some(v) = p.get_mut(name) else {
                    return vec![];
                };
                for (e, t) in values {
                    if t.trim() == "On" && v.element(e).is_some() {
                        v.set_switch(e, true);
                    }
                }
                v.state = State::Ok;
                vec![v.set(None)]
            }
            BL_TOGGLE => {
                let Some(on) = values
                    .iter()
                    .find(|(_, t)| t.trim() == "On")
                    .map(|(e, _)| e == "INDI_ENABLED")
                else {
                    return vec![];
                };
                let b = if on { self.backlash } else { 0 };
                if let Err(e) = link.request(&format!("set {axis} backlash {b}")) {
                    return p.alert(name, &e.to_string());
                }
                if let Some(v) = p.get_mut(name) {
                    let e = if on { "INDI_ENABLED" } else { "INDI_DISABLED" };
                    v.set_switch(e, true);
                }
                p.state(name, State::Ok, None)
            }
            BL_STEPS => match number_of(values, "FOCUS_BACKLASH_VALUE") {
                Ok(n) if n.fract() == 0.0 && (0.0..=MAX_BACKLASH).contains(&n) => {
                    let on = p.get(BL_TOGGLE).is_some_and(|v| v.switch("INDI_ENABLED"));
                    if on {
                        if let Err(e) = link.request(&format!("set {axis} backlash {n}")) {
                            return p.alert(name, &e.to_string());
                        }
                    }
                    self.backlash = n as i64;
                    if let Some(v) = p.get_mut(name) {
                        v.set_number("FOCUS_BACKLASH_VALUE", n);
                    }
                    p.state(name, State::Ok, None)
                }
                Ok(n) => p.alert(
                    name,
                    &format!("backlash {n} is not a whole number of steps in 0..=1000000"),
                ),
                Err(e) => p.alert(name, &e),
            },
            "FOCUS_ABORT_MOTION" => match link.request(&format!("stop {axis}")) {
                Ok(_) => {
                    let mut out = p.state(name, State::Ok, None);
                    for n in [ABS, REL] {
                        if p.get(n).is_some_and(|v| v.state == State::Busy) {
                            out.extend(p.state(n, State::Idle, Some("aborted")));
                        }
                    }
                    out
                }
                Err(e) => p.alert(name, &e.to_string()),
            },
            _ => vec![],
        }
    }

    /// An absolute move to `to` steps, reported on property `prop` (the controller takes
    /// up the backlash within the move).
    fn move_to(&self, p: &mut Props, link: &mut Link, axis: &str, prop: &str, to: f64) -> Vec<Out> {
        if to.fract() != 0.0 || !(0.0..=self.max as f64).contains(&to) {
            return p.alert(
                prop,
                &format!("position {to} is outside 0..={} (FOCUS_MAX)", self.max),
            );
        }
        match link.request(&format!("moveto {axis} {}", to as i64)) {
            Ok(_) => {
                let mut out = Vec::new();
                if prop == REL {
                    out.extend(p.state(REL, State::Busy, None));
                }
                out.extend(p.state(ABS, State::Busy, None));
                out
            }
            Err(e) => p.alert(prop, &e.to_string()),
        }
    }

    /// The idle axis's position becomes `to` steps; nothing moves.
    fn sync(&self, p: &mut Props, link: &mut Link, axis: &str, to: f64) -> Vec<Out> {
        if to.fract() != 0.0 || !(0.0..=self.max as f64).contains(&to) {
            return p.alert(
                SYNC,
                &format!("position {to} is outside 0..={} (FOCUS_MAX)", self.max),
            );
        }
        if let Err(e) = link.request(&format!("setpos {axis} {}", to as i64)) {
            return p.alert(SYNC, &e.to_string());
        }
        let mut out = Vec::new();
        for (name, element) in [(SYNC, "FOCUS_SYNC_VALUE"), (ABS, "FOCUS_ABSOLUTE_POSITION")] {
            if let Some(v) = p.get_mut(name) {
                v.set_number(element, to);
                v.state = State::Ok;
                out.push(v.set(None));
            }
        }
        out
    }

    pub fn poll(&mut self, p: &mut Props, st: &AxisStatus) -> Vec<Out> {
        let mut out = Vec::new();
        let busy = moving(st);
        let why = fault(st);
        for name in [ABS, REL] {
            let Some(v) = p.get_mut(name) else { continue };
            let was = v.state;
            let state = match (busy, &why) {
                (true, _) => State::Busy,
                (false, Some(_)) if was == State::Busy => State::Alert,
                (false, None) if was == State::Busy => State::Ok,
                _ => was,
            };
            let changed = name == ABS && v.number("FOCUS_ABSOLUTE_POSITION") != st.position as f64;
            // REL follows a move only while it is the one that started it.
            if name == REL && was != State::Busy {
                continue;
            }
            if changed || state != was {
                if name == ABS {
                    v.set_number("FOCUS_ABSOLUTE_POSITION", st.position as f64);
                }
                v.state = state;
                out.push(v.set(why.as_deref().filter(|_| state == State::Alert)));
            }
        }
        out
    }
}
