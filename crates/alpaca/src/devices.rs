//! The devices: each maps Alpaca calls onto the [`Controller`]'s methods for one axis.
//! Moves go through `Controller::move_axis`, so limits, homing, e-stop and the shortest
//! way round a periodic axis are the controller's, as for the line protocol.

use crate::config::{AlpacaSection, FilterWheelConfig, FocuserConfig};
use crate::errors::{code, Fault};
use crate::params::Params;
use multistep_controller::protocol::Amount;
use multistep_controller::{AxisSettings, AxisState, AxisStatus, Controller, CtlError, MoveOpts};
use serde_json::{json, Value};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

pub type Answer = Result<Option<Value>, Fault>;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceType {
    Focuser,
    Rotator,
    FilterWheel,
}

impl DeviceType {
    /// As in the URL (`/api/v1/filterwheel/0/…`).
    pub fn path(self) -> &'static str {
        match self {
            DeviceType::Focuser => "focuser",
            DeviceType::Rotator => "rotator",
            DeviceType::FilterWheel => "filterwheel",
        }
    }
    /// As in the management API (`DeviceType`).
    pub fn name(self) -> &'static str {
        match self {
            DeviceType::Focuser => "Focuser",
            DeviceType::Rotator => "Rotator",
            DeviceType::FilterWheel => "FilterWheel",
        }
    }
    /// IFocuserV4, IRotatorV4, IFilterWheelV3: the Platform 7 interfaces (Connect,
    /// Disconnect, Connecting, DeviceState).
    fn interface_version(self) -> u16 {
        match self {
            DeviceType::FilterWheel => 3,
            _ => 4,
        }
    }
    /// The methods of this type beyond the common ones: (name, is PUT).
    fn methods(self) -> &'static [(&'static str, bool)] {
        match self {
            DeviceType::Focuser => &[
                ("absolute", false),
                ("ismoving", false),
                ("maxincrement", false),
                ("maxstep", false),
                ("position", false),
                ("stepsize", false),
                ("tempcomp", false),
                ("tempcomp", true),
                ("tempcompavailable", false),
                ("temperature", false),
                ("halt", true),
                ("move", true),
            ],
            DeviceType::Rotator => &[
                ("canreverse", false),
                ("ismoving", false),
                ("mechanicalposition", false),
                ("position", false),
                ("reverse", false),
                ("reverse", true),
                ("stepsize", false),
                ("targetposition", false),
                ("halt", true),
                ("move", true),
                ("moveabsolute", true),
                ("movemechanical", true),
                ("sync", true),
            ],
            DeviceType::FilterWheel => &[
                ("focusoffsets", false),
                ("names", false),
                ("position", false),
                ("position", true),
            ],
        }
    }
}

/// Methods every device type has (Alpaca "common" API); the first five work unconnected.
const COMMON: &[(&str, bool)] = &[
    ("connected", false),
    ("connected", true),
    ("connect", true),
    ("disconnect", true),
    ("connecting", false),
    ("description", false),
    ("driverinfo", false),
    ("driverversion", false),
    ("interfaceversion", false),
    ("name", false),
    ("supportedactions", false),
    ("devicestate", false),
    ("action", true),
    ("commandblind", true),
    ("commandbool", true),
    ("commandstring", true),
];

/// What the device does beyond its axis.
enum Role {
    Focuser(FocuserConfig),
    Rotator(Mutex<RotatorState>),
    FilterWheel(FilterWheelConfig),
}

/// Rotator state that is the device's, not the axis's; kept while the server runs.
#[derive(Default)]
struct RotatorState {
    /// Sky angle minus mechanical angle, set by Sync (microsteps).
    sync_offset: i64,
    reverse: bool,
    /// Sky angle the last move was sent to.
    target: Option<f64>,
}

pub struct Device {
    pub ty: DeviceType,
    pub number: usize,
    pub name: String,
    pub axis: String,
    pub unique_id: String,
    board: String,
    role: Role,
    connected: AtomicBool,
}

/// Builds the devices of `section`; numbers count up per type in listed order.
pub fn build(section: &AlpacaSection, board: &str) -> Vec<Device> {
    let mut out = Vec::new();
    let mut add = |ty: DeviceType, number: usize, axis: &str, name: &Option<String>, role| {
        out.push(Device {
            ty,
            number,
            name: name
                .clone()
                .unwrap_or_else(|| format!("{board} {} {axis}", ty.path())),
            axis: axis.to_string(),
            unique_id: format!("multistep-{board}-{}-{axis}", ty.path()),
            board: board.to_string(),
            role,
            connected: AtomicBool::new(false),
        })
    };
    for (n, f) in section.focuser.iter().enumerate() {
        add(
            DeviceType::Focuser,
            n,
            &f.axis,
            &f.name,
            Role::Focuser(f.clone()),
        );
    }
    for (n, r) in section.rotator.iter().enumerate() {
        add(
            DeviceType::Rotator,
            n,
            &r.axis,
            &r.name,
            Role::Rotator(Mutex::default()),
        );
    }
    for (n, w) in section.filterwheel.iter().enumerate() {
        add(
            DeviceType::FilterWheel,
            n,
            &w.axis,
            &w.name,
            Role::FilterWheel(w.clone()),
        );
    }
    out
}

/// `x` in [0, 360) (and never −0).
fn norm_deg(x: f64) -> f64 {
    let r = x.rem_euclid(360.0) + 0.0;
    if r >= 360.0 {
        0.0
    } else {
        r
    }
}

fn angle(p: &Params, name: &str) -> Result<f64, Fault> {
    let x = p.f64(name)?;
    if (0.0..360.0).contains(&x) {
        Ok(x)
    } else {
        Err(Fault::invalid_value(format!(
            "{name} must be in [0, 360) degrees (got {x})"
        )))
    }
}

fn val(v: impl serde::Serialize) -> Answer {
    Ok(Some(json!(v)))
}

impl Device {
    /// Runs one call. `Err(BadRequest)` for a method this type does not have.
    pub fn call(&self, ctl: &Controller, method: &str, put: bool, p: &Params) -> Answer {
        let known = |list: &[(&str, bool)]| list.iter().any(|&(m, _)| m == method);
        let exact = |list: &[(&str, bool)]| list.contains(&(method, put));
        if !exact(COMMON) && !exact(self.ty.methods()) {
            let verb = if put { "PUT" } else { "GET" };
            return Err(Fault::BadRequest(
                if known(COMMON) || known(self.ty.methods()) {
                    format!("{method} does not take {verb}")
                } else {
                    format!("{} has no method '{method}'", self.ty.name())
                },
            ));
        }
        match (method, put) {
            ("connected", false) => return val(self.is_connected()),
            ("connected", true) => {
                let on = p.bool("Connected")?;
                self.connected.store(on, Ordering::SeqCst);
                return Ok(None);
            }
            // Connecting takes no time here, so Connecting is never true.
            ("connect", true) | ("disconnect", true) => {
                self.connected.store(method == "connect", Ordering::SeqCst);
                return Ok(None);
            }
            ("connecting", false) => return val(false),
            ("description", false) => {
                return val(format!(
                    "{} on axis {} of multistep board {}",
                    self.ty.name(),
                    self.axis,
                    self.board
                ))
            }
            ("driverinfo", false) => {
                return val(format!(
                    "multistep-alpaca {}: ASCOM Alpaca devices over the multistep controller",
                    env!("CARGO_PKG_VERSION")
                ))
            }
            ("driverversion", false) => return val(env!("CARGO_PKG_VERSION")),
            ("interfaceversion", false) => return val(self.ty.interface_version()),
            ("name", false) => return val(&self.name),
            ("supportedactions", false) => return val(Vec::<String>::new()),
            ("action", true) => {
                let a = p.get("Action").unwrap_or("");
                return Err(Fault::device(
                    code::ACTION_NOT_IMPLEMENTED,
                    format!("action '{a}' is not implemented"),
                ));
            }
            ("commandblind" | "commandbool" | "commandstring", true) => {
                return Err(Fault::not_implemented(method))
            }
            _ => {}
        }
        if !self.is_connected() {
            return Err(Fault::device(
                code::NOT_CONNECTED,
                format!("{} is not connected; set Connected=True first", self.name),
            ));
        }
        if method == "devicestate" {
            return self.device_state(ctl);
        }
        match &self.role {
            Role::Focuser(f) => self.focuser(ctl, f, method, put, p),
            Role::Rotator(r) => self.rotator(ctl, r, method, put, p),
            Role::FilterWheel(w) => self.filterwheel(ctl, w, method, put, p),
        }
    }

    pub fn is_connected(&self) -> bool {
        self.connected.load(Ordering::SeqCst)
    }

    fn status(&self, ctl: &Controller) -> Result<AxisStatus, Fault> {
        let mut s = ctl.status(std::slice::from_ref(&self.axis))?;
        s.pop()
            .ok_or_else(|| Fault::device(code::DRIVER, "axis status missing"))
    }

    fn settings(&self, ctl: &Controller) -> Result<AxisSettings, Fault> {
        Ok(ctl.with_board(|b, _| b.settings(&self.axis).cloned())?)
    }

    fn move_to(&self, ctl: &Controller, to: Amount) -> Result<(), Fault> {
        ctl.move_axis(&self.axis, to, true, &MoveOpts::default())?;
        Ok(())
    }

    fn halt(&self, ctl: &Controller) -> Answer {
        ctl.stop(Some(&self.axis))?;
        Ok(None)
    }

    fn device_state(&self, ctl: &Controller) -> Answer {
        let item = |name: &str, v: Value| json!({ "Name": name, "Value": v });
        let st = self.status(ctl)?;
        let items = match &self.role {
            Role::Focuser(_) => vec![
                item("IsMoving", json!(is_moving(&st))),
                item("Position", json!(focuser_position(&st)?)),
            ],
            Role::Rotator(r) => {
                let t = Turn::of(&self.settings(ctl)?);
                let r = lock(r);
                vec![
                    item("IsMoving", json!(is_moving(&st))),
                    item("MechanicalPosition", json!(t.deg(t.mechanical(&st, &r)))),
                    item("Position", json!(t.deg(t.sky(&st, &r)))),
                ]
            }
            Role::FilterWheel(w) => {
                vec![item("Position", json!(self.wheel_position(ctl, w, &st)?))]
            }
        };
        val(items)
    }

    // ---- Focuser ------------------------------------------------------------------------

    fn focuser(
        &self,
        ctl: &Controller,
        f: &FocuserConfig,
        m: &str,
        put: bool,
        p: &Params,
    ) -> Answer {
        match (m, put) {
            ("absolute", _) => val(true),
            ("ismoving", _) => val(is_moving(&self.status(ctl)?)),
            ("maxstep", _) | ("maxincrement", _) => val(self.max_step(ctl)?),
            ("position", _) => val(focuser_position(&self.status(ctl)?)?),
            ("stepsize", _) => val(f.microns_per_unit / self.settings(ctl)?.steps_per_unit),
            ("tempcomp", false) | ("tempcompavailable", _) => val(false),
            ("tempcomp", true) => {
                p.bool("TempComp")?;
                Err(Fault::not_implemented("temperature compensation"))
            }
            ("temperature", _) => Err(Fault::not_implemented("temperature")),
            ("halt", _) => self.halt(ctl),
            ("move", _) => {
                let to = p.i32("Position")?;
                let max = self.max_step(ctl)?;
                if !(0..=max).contains(&to) {
                    return Err(Fault::invalid_value(format!(
                        "Position {to} is outside 0..={max} (MaxStep)"
                    )));
                }
                self.move_to(ctl, Amount::Steps(to as i64))?;
                Ok(None)
            }
            _ => Err(Fault::BadRequest(format!("unknown method {m}"))),
        }
    }

    /// MaxStep: the axis's soft_max (checked at start; re-read since `set` may change it).
    fn max_step(&self, ctl: &Controller) -> Result<i32, Fault> {
        self.settings(ctl)?
            .soft_max
            .and_then(|m| i32::try_from(m).ok())
            .filter(|&m| m > 0)
            .ok_or_else(|| {
                Fault::device(
                    code::VALUE_NOT_SET,
                    format!("axis {} has no soft_max", self.axis),
                )
            })
    }

    // ---- Rotator ------------------------------------------------------------------------

    fn rotator(
        &self,
        ctl: &Controller,
        r: &Mutex<RotatorState>,
        m: &str,
        put: bool,
        p: &Params,
    ) -> Answer {
        let st = self.status(ctl)?;
        let t = Turn::of(&self.settings(ctl)?);
        let mut r = lock(r);
        match (m, put) {
            ("canreverse", _) => val(true),
            ("ismoving", _) => val(is_moving(&st)),
            ("mechanicalposition", _) => val(t.deg(t.mechanical(&st, &r))),
            ("position", _) => val(t.deg(t.sky(&st, &r))),
            ("targetposition", _) => val(r.target.unwrap_or_else(|| t.deg(t.sky(&st, &r)))),
            ("reverse", false) => val(r.reverse),
            ("reverse", true) => {
                r.reverse = p.bool("Reverse")?;
                Ok(None)
            }
            ("stepsize", _) => val(360.0 / t.period as f64),
            ("halt", _) => self.halt(ctl),
            ("sync", _) => {
                let to = angle(p, "Position")?;
                r.sync_offset = t.steps(to) - t.mechanical(&st, &r);
                r.target = Some(to);
                Ok(None)
            }
            ("move", _) => {
                let to = norm_deg(t.deg(t.sky(&st, &r)) + p.f64("Position")?);
                let mech = t.steps(to) - r.sync_offset;
                self.rotate(ctl, &t, &mut r, mech, to)
            }
            ("moveabsolute", _) => {
                let to = angle(p, "Position")?;
                let mech = t.steps(to) - r.sync_offset;
                self.rotate(ctl, &t, &mut r, mech, to)
            }
            ("movemechanical", _) => {
                let to = angle(p, "Position")?;
                let sky = t.deg((t.steps(to) + r.sync_offset).rem_euclid(t.period));
                self.rotate(ctl, &t, &mut r, t.steps(to), sky)
            }
            _ => Err(Fault::BadRequest(format!("unknown method {m}"))),
        }
    }

    /// An absolute move of the axis to mechanical angle `mech` (steps): the controller
    /// takes the shortest way round, as for every periodic axis.
    fn rotate(
        &self,
        ctl: &Controller,
        t: &Turn,
        r: &mut RotatorState,
        mech: i64,
        sky: f64,
    ) -> Answer {
        let axis = if r.reverse { -mech } else { mech };
        self.move_to(ctl, Amount::Steps(axis.rem_euclid(t.period)))?;
        r.target = Some(sky);
        Ok(None)
    }

    // ---- FilterWheel --------------------------------------------------------------------

    fn filterwheel(
        &self,
        ctl: &Controller,
        w: &FilterWheelConfig,
        m: &str,
        put: bool,
        p: &Params,
    ) -> Answer {
        match (m, put) {
            ("names", _) => val(w.slots.iter().map(|s| &s.name).collect::<Vec<_>>()),
            ("focusoffsets", _) => val(w.slots.iter().map(|s| s.focus_offset).collect::<Vec<_>>()),
            ("position", false) => {
                let st = self.status(ctl)?;
                val(self.wheel_position(ctl, w, &st)?)
            }
            ("position", true) => {
                let slot = p.i32("Position")?;
                let n = w.slots.len();
                if !(0..n as i64).contains(&(slot as i64)) {
                    return Err(Fault::invalid_value(format!(
                        "Position {slot} is not a slot (0..={})",
                        n - 1
                    )));
                }
                let at = self.slot_position(ctl, w, slot as usize)?;
                self.move_to(ctl, Amount::Steps(at))?;
                Ok(None)
            }
            _ => Err(Fault::BadRequest(format!("unknown method {m}"))),
        }
    }

    /// The slot the axis stands on; −1 while moving or between slots.
    fn wheel_position(
        &self,
        ctl: &Controller,
        w: &FilterWheelConfig,
        st: &AxisStatus,
    ) -> Result<i32, Fault> {
        if is_moving(st) {
            return Ok(-1);
        }
        let period = self.settings(ctl)?.period.map(|p| p as i64);
        let same = |a: i64, b: i64| match period {
            Some(p) => (a - b).rem_euclid(p) == 0,
            None => a == b,
        };
        for i in 0..w.slots.len() {
            // A slot without a saved position cannot be where the wheel is.
            if let Ok(at) = self.slot_position(ctl, w, i) {
                if same(at, st.position) {
                    return Ok(i as i32);
                }
            }
        }
        Ok(-1)
    }

    fn slot_position(
        &self,
        ctl: &Controller,
        w: &FilterWheelConfig,
        i: usize,
    ) -> Result<i64, Fault> {
        let slot = &w.slots[i];
        if let Some(at) = slot.position {
            return Ok(at);
        }
        let named = ctl.with_board(|b, _| b.named_positions())?;
        named
            .get(&slot.name)
            .and_then(|p| p.get(&self.axis))
            .copied()
            .ok_or_else(|| {
                Fault::from(CtlError::UnknownName {
                    what: "position (save it with 'save NAME AXIS')",
                    name: format!("{} for axis {}", slot.name, self.axis),
                })
            })
    }
}

fn is_moving(st: &AxisStatus) -> bool {
    matches!(st.state, AxisState::Moving | AxisState::Homing)
}

fn focuser_position(st: &AxisStatus) -> Result<i32, Fault> {
    i32::try_from(st.position).map_err(|_| {
        Fault::device(
            code::DRIVER,
            format!("position {} does not fit Int32", st.position),
        )
    })
}

/// One turn of a rotator axis. Angles are kept in microsteps (sync offset included), so
/// what is read back is exactly a step's angle.
struct Turn {
    period: i64,
    steps_per_degree: f64,
}

impl Turn {
    fn of(s: &AxisSettings) -> Turn {
        Turn {
            period: s.period.map_or(1, |p| p.max(1) as i64),
            steps_per_degree: s.steps_per_unit,
        }
    }
    /// `deg` (any angle) as microsteps in [0, period).
    fn steps(&self, deg: f64) -> i64 {
        ((deg * self.steps_per_degree).round() as i64).rem_euclid(self.period)
    }
    /// Microsteps in [0, period) as degrees in [0, 360).
    fn deg(&self, steps: i64) -> f64 {
        norm_deg(steps as f64 / self.steps_per_degree)
    }
    /// The mechanical angle (steps) as the device reports it, reversed or not.
    fn mechanical(&self, st: &AxisStatus, r: &RotatorState) -> i64 {
        let sense = if r.reverse { -1 } else { 1 };
        (sense * st.position).rem_euclid(self.period)
    }
    fn sky(&self, st: &AxisStatus, r: &RotatorState) -> i64 {
        (self.mechanical(st, r) + r.sync_offset).rem_euclid(self.period)
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}
