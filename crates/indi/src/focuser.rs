//! Focuser: an absolute focuser on a soft-limited axis. The position is the counted
//! position (the `pos` of `status`), FOCUS_MAX the axis's soft_max, as the Alpaca Focuser.
//! FOCUS_SYNC renames the idle axis's position without moving (the controller's `setpos`).
//! FOCUS_BACKLASH: the controller has no backlash of its own for an axis, so the driver
//! takes it up: with it on, a move inward (toward smaller counts) first goes the backlash
//! past its target, then out to it, so every move ends turning outward and the gears mesh
//! the same way at every position (the mount's slews end the same way).

use crate::device::{abort, fault, moving, number_of, Props, Values};
use crate::link::{Link, LinkError};
use crate::props::{Element, Perm, Range, State, Vector};
use crate::xml::Out;
use multistep_controller::AxisStatus;

#[derive(Default)]
pub struct Focuser {
    max: i64,
    /// Backlash steps taken up while FOCUS_BACKLASH_TOGGLE is on.
    backlash: Option<i64>,
    /// A move that goes past its target: (the first leg's end, the target), the target
    /// to be moved on to once the axis rests at the first leg's end.
    then: Option<(i64, i64)>,
}

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
        let on = self.backlash.is_some();
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
                    self.backlash.unwrap_or(0) as f64,
                    steps(self.max),
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
                let Some(v) = p.get_mut(name) else {
                    return vec![];
                };
                for (e, t) in values {
                    if t.trim() == "On" && v.element(e).is_some() {
                        v.set_switch(e, true);
                    }
                }
                let steps = p
                    .get(BL_STEPS)
                    .map_or(0.0, |v| v.number("FOCUS_BACKLASH_VALUE"));
                let on = p.get(name).is_some_and(|v| v.switch("INDI_ENABLED"));
                self.backlash = on.then_some(steps as i64);
                p.state(name, State::Ok, None)
            }
            BL_STEPS => match number_of(values, "FOCUS_BACKLASH_VALUE") {
                Ok(n) if n.fract() == 0.0 && (0.0..=self.max as f64).contains(&n) => {
                    if let Some(b) = &mut self.backlash {
                        *b = n as i64;
                    }
                    if let Some(v) = p.get_mut(name) {
                        v.set_number("FOCUS_BACKLASH_VALUE", n);
                    }
                    p.state(name, State::Ok, None)
                }
                Ok(n) => p.alert(
                    name,
                    &format!(
                        "backlash {n} is not a whole number of steps in 0..={}",
                        self.max
                    ),
                ),
                Err(e) => p.alert(name, &e),
            },
            "FOCUS_ABORT_MOTION" => match link.request(&format!("stop {axis}")) {
                Ok(_) => {
                    self.then = None;
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

    /// An absolute move to `to` steps, reported on property `prop`; with backlash on and
    /// `to` inward of where it is, first to `to` − backlash (at least 0).
    fn move_to(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        axis: &str,
        prop: &str,
        to: f64,
    ) -> Vec<Out> {
        if to.fract() != 0.0 || !(0.0..=self.max as f64).contains(&to) {
            return p.alert(
                prop,
                &format!("position {to} is outside 0..={} (FOCUS_MAX)", self.max),
            );
        }
        let to = to as i64;
        let at = p
            .get(ABS)
            .map_or(0, |v| v.number("FOCUS_ABSOLUTE_POSITION") as i64);
        let (first, then) = match self.backlash {
            Some(b) if b > 0 && to < at => ((to - b).max(0), Some(to)),
            _ => (to, None),
        };
        self.then = None;
        match link.request(&format!("moveto {axis} {first}")) {
            Ok(_) => {
                self.then = then.filter(|&t| t != first).map(|t| (first, t));
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

    pub fn poll(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        axis: &str,
        st: &AxisStatus,
    ) -> Vec<Out> {
        let mut out = Vec::new();
        let mut busy = moving(st);
        let why = fault(st);
        // The first leg of a backlash move ended: out to the target. Resting anywhere
        // else, it was stopped on the way (an abort, a fault): the move ends there.
        if let Some((first, to)) = self.then.filter(|_| !busy) {
            self.then = None;
            if why.is_none() && st.position == first {
                if let Err(e) = link.request(&format!("moveto {axis} {to}")) {
                    let mut out = p.alert(ABS, &e.to_string());
                    if p.get(REL).is_some_and(|v| v.state == State::Busy) {
                        out.extend(p.alert(REL, &e.to_string()));
                    }
                    return out;
                }
                busy = true;
            }
        }
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
