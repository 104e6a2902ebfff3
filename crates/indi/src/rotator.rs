//! Rotator: a periodic axis whose turn is 360 units (degrees). Angles, sync and reverse are
//! the Alpaca Rotator's (`multistep_alpaca::mapping::Turn`); the board config's travel
//! limits keep a cabled rotator off its cable wrap (`mapping::rotator_path`, shared with
//! the Alpaca Rotator).

use crate::device::{abort, fault, moving, number_of, Props, Values};
use crate::link::{Link, LinkError};
use crate::props::{Element, Perm, Range, State, Vector};
use crate::xml::Out;
use multistep_alpaca::mapping::{rotator_path, Travel, Turn};
use multistep_controller::AxisStatus;
use std::collections::VecDeque;

pub struct Rotator {
    turn: Turn,
    /// Sky angle minus mechanical angle, set by SYNC_ROTATOR_ANGLE (microsteps).
    sync_offset: i64,
    reverse: bool,
    /// Allowed travel of the axis's own angle (the board config's; None: free).
    travel: Option<Travel>,
    /// Relative moves still to make, each under half a turn so the controller's
    /// shortest-way rule keeps its sense.
    legs: VecDeque<i64>,
}

const ABS: &str = "ABS_ROTATOR_ANGLE";
const TRAVEL: &str = "ROTATOR_TRAVEL";

impl Rotator {
    pub fn new(travel: Option<Travel>) -> Rotator {
        Rotator {
            turn: Turn::new(Some(360), 1.0),
            sync_offset: 0,
            reverse: false,
            travel,
            legs: VecDeque::new(),
        }
    }

    pub fn build(
        &mut self,
        dev: &str,
        link: &mut Link,
        axis: &str,
        st: &AxisStatus,
    ) -> Result<Vec<Vector>, LinkError> {
        let period = link.setting(axis, "period")?.map(|p| p as u64);
        let spu = link.setting(axis, "steps_per_unit")?.unwrap_or(1.0);
        self.turn = Turn::new(period, spu);
        let deg = |min: f64, max: f64| Range {
            min,
            max,
            step: 0.01,
            format: "%.2f",
        };
        let g = "Main Control";
        let (lo, hi) = self.travel.map_or((0.0, 360.0), |t| (t.min_deg, t.max_deg));
        let mut abs = Vector::new(
            dev,
            ABS,
            "Goto",
            g,
            Perm::Rw,
            vec![Element::number(
                "ANGLE",
                "Angle",
                self.angle(st),
                deg(0.0, 360.0),
            )],
        );
        abs.state = State::Ok;
        Ok(vec![
            abs,
            Vector::new(
                dev,
                "SYNC_ROTATOR_ANGLE",
                "Sync",
                g,
                Perm::Rw,
                vec![Element::number(
                    "ANGLE",
                    "Angle",
                    self.angle(st),
                    deg(0.0, 360.0),
                )],
            ),
            Vector::new(
                dev,
                "ROTATOR_REVERSE",
                "Reverse",
                g,
                Perm::Rw,
                vec![
                    Element::switch("INDI_ENABLED", "Enabled", self.reverse),
                    Element::switch("INDI_DISABLED", "Disabled", !self.reverse),
                ],
            ),
            abort(dev, "ROTATOR_ABORT_MOTION"),
            Vector::new(
                dev,
                TRAVEL,
                "Travel (cable wrap)",
                "Limits",
                Perm::Ro,
                vec![
                    Element::number("MIN", "From (axis degrees)", lo, deg(-360.0, 360.0)),
                    Element::number("MAX", "To (axis degrees)", hi, deg(-360.0, 720.0)),
                ],
            ),
        ])
    }

    /// The sky angle at axis position `st`, degrees in [0, 360).
    fn angle(&self, st: &AxisStatus) -> f64 {
        let t = &self.turn;
        t.deg(t.sky(st.position, self.reverse, self.sync_offset))
    }

    /// Moves left over are dropped (the controller went away).
    pub fn abandon(&mut self) {
        self.legs.clear();
    }

    pub fn on_new(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        axis: &str,
        name: &str,
        values: &Values,
    ) -> Vec<Out> {
        let st = match crate::device::axis_status(link, axis) {
            Ok(st) => st,
            Err(e) => return p.alert(name, &e.to_string()),
        };
        match name {
            ABS => match number_of(values, "ANGLE") {
                Ok(a) if (0.0..=360.0).contains(&a) => self.goto(p, link, axis, &st, a),
                Ok(a) => p.alert(ABS, &format!("angle {a} is outside [0, 360]")),
                Err(e) => p.alert(ABS, &e),
            },
            "SYNC_ROTATOR_ANGLE" => match number_of(values, "ANGLE") {
                Ok(a) if (0.0..=360.0).contains(&a) => {
                    let t = &self.turn;
                    self.sync_offset = t.steps(a) - t.mechanical(st.position, self.reverse);
                    let now = self.angle(&st);
                    let mut out = Vec::new();
                    for n in [name, ABS] {
                        if let Some(v) = p.get_mut(n) {
                            v.set_number("ANGLE", now);
                            v.state = State::Ok;
                            out.push(v.set(None));
                        }
                    }
                    out
                }
                Ok(a) => p.alert(name, &format!("angle {a} is outside [0, 360]")),
                Err(e) => p.alert(name, &e),
            },
            "ROTATOR_REVERSE" => {
                let said = |e: &str| values.iter().find(|v| v.0 == e).map(|v| v.1.trim() == "On");
                let on = said("INDI_ENABLED").or(said("INDI_DISABLED").map(|d| !d));
                let Some(on) = on else {
                    return p.alert(name, "neither INDI_ENABLED nor INDI_DISABLED given");
                };
                self.reverse = on;
                let now = self.angle(&st);
                let mut out = Vec::new();
                if let Some(v) = p.get_mut(name) {
                    v.set_switch(if on { "INDI_ENABLED" } else { "INDI_DISABLED" }, true);
                    v.state = State::Ok;
                    out.push(v.set(None));
                }
                if let Some(v) = p.get_mut(ABS) {
                    v.set_number("ANGLE", now);
                    out.push(v.set(None));
                }
                out
            }
            "ROTATOR_ABORT_MOTION" => {
                self.legs.clear();
                match link.request(&format!("stop {axis}")) {
                    Ok(_) => {
                        let mut out = p.state(name, State::Ok, None);
                        out.extend(p.state(ABS, State::Idle, Some("aborted")));
                        out
                    }
                    Err(e) => p.alert(name, &e.to_string()),
                }
            }
            TRAVEL => p.alert(
                TRAVEL,
                "the travel is the board config's (min_deg, max_deg of its [[alpaca.rotator]])",
            ),
            _ => vec![],
        }
    }

    /// Turns to sky angle `a`: the short way when travel is free, else the way that stays
    /// inside the travel.
    fn goto(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        axis: &str,
        st: &AxisStatus,
        a: f64,
    ) -> Vec<Out> {
        let t = self.turn;
        let mech = t.steps(a) - self.sync_offset;
        let target = t.axis_target(mech, self.reverse);
        self.legs = match rotator_path(&t, self.travel, st.position, target) {
            Ok(l) => l.into(),
            Err(e) => return p.alert(ABS, &format!("angle {a}: {e}")),
        };
        let first = format!("move {axis} {}", self.legs.pop_front().unwrap_or(0));
        match link.request(&first) {
            Ok(_) => {
                if let Some(v) = p.get_mut(ABS) {
                    v.state = State::Busy;
                    return vec![v.set(None)];
                }
                vec![]
            }
            Err(e) => {
                self.legs.clear();
                p.alert(ABS, &e.to_string())
            }
        }
    }

    pub fn poll(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        axis: &str,
        st: &AxisStatus,
    ) -> Vec<Out> {
        let mut out = Vec::new();
        let busy = moving(st);
        if !busy && st.state != multistep_controller::AxisState::Fault {
            if let Some(d) = self.legs.pop_front() {
                if let Err(e) = link.request(&format!("move {axis} {d}")) {
                    self.legs.clear();
                    out.extend(p.alert(ABS, &e.to_string()));
                }
                return out;
            }
        }
        let why = fault(st);
        if why.is_some() {
            self.legs.clear();
        }
        let now = self.angle(st);
        let Some(v) = p.get_mut(ABS) else { return out };
        let was = v.state;
        let state = match (busy, &why) {
            (true, _) => State::Busy,
            (false, Some(_)) if was == State::Busy => State::Alert,
            (false, None) if was == State::Busy => State::Ok,
            _ => was,
        };
        if v.number("ANGLE") != now || state != was {
            v.set_number("ANGLE", now);
            v.state = state;
            out.push(v.set(why.as_deref().filter(|_| state == State::Alert)));
        }
        out
    }
}
