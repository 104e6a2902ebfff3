//! The devices: each maps Alpaca calls onto the [`Controller`]'s methods for one axis.
//! Moves go through `Controller::move_axis`, so limits, homing, e-stop and the shortest
//! way round a periodic axis are the controller's, as for the line protocol.

mod filterwheel;
mod focuser;
mod rotator;
mod telescope;

use crate::config::{AlpacaSection, FilterWheelConfig, FocuserConfig};
use crate::errors::{code, Fault};
use crate::mapping::Turn;
use crate::params::Params;
use focuser::focuser_position;
use multistep_controller::mount::Mount;
use multistep_controller::protocol::Amount;
use multistep_controller::{AxisSettings, AxisState, AxisStatus, Controller, MoveOpts};
use rotator::RotatorState;
use serde_json::{json, Value};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

pub type Answer = Result<Option<Value>, Fault>;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DeviceType {
    Focuser,
    Rotator,
    FilterWheel,
    Telescope,
}

impl DeviceType {
    /// As in the URL (`/api/v1/filterwheel/0/…`).
    pub fn path(self) -> &'static str {
        match self {
            DeviceType::Focuser => "focuser",
            DeviceType::Rotator => "rotator",
            DeviceType::FilterWheel => "filterwheel",
            DeviceType::Telescope => "telescope",
        }
    }
    /// As in the management API (`DeviceType`).
    pub fn name(self) -> &'static str {
        match self {
            DeviceType::Focuser => "Focuser",
            DeviceType::Rotator => "Rotator",
            DeviceType::FilterWheel => "FilterWheel",
            DeviceType::Telescope => "Telescope",
        }
    }
    /// IFocuserV4, IRotatorV4, IFilterWheelV3, ITelescopeV4: the Platform 7 interfaces
    /// (Connect, Disconnect, Connecting, DeviceState).
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
            DeviceType::Telescope => telescope::METHODS,
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
    Telescope(Arc<Mount>),
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

/// Builds the devices of `section`; numbers count up per type in listed order. A
/// telescope's mount is the controller's ([`Controller::attach_mounts`]), the one its
/// `mount` command drives too.
pub fn build(
    section: &AlpacaSection,
    board: &str,
    ctl: &Arc<Controller>,
) -> Result<Vec<Device>, String> {
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
            Role::Rotator(Mutex::new(RotatorState::new(
                r.travel().map_err(|e| e.to_string())?,
            ))),
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
    // The controller's mounts, opened by `serve` for every protocol, or here if not yet.
    let mounts = ctl
        .attach_mounts(&section.telescope)
        .map_err(|e| format!("telescope: {e}"))?;
    for ((n, t), mount) in section.telescope.iter().enumerate().zip(mounts) {
        add(
            DeviceType::Telescope,
            n,
            &t.ra_axis,
            &t.name,
            Role::Telescope(mount),
        );
    }
    Ok(out)
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
        if let (Role::Telescope(m), "devicestate") = (&self.role, method) {
            return self.telescope_state(ctl, m);
        }
        if method == "devicestate" {
            return self.device_state(ctl);
        }
        match &self.role {
            Role::Focuser(f) => self.focuser(ctl, f, method, put, p),
            Role::Rotator(r) => self.rotator(ctl, r, method, put, p),
            Role::FilterWheel(w) => self.filterwheel(ctl, w, method, put, p),
            Role::Telescope(m) => self.telescope(ctl, m, method, put, p),
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
                let s = self.settings(ctl)?;
                let t = Turn::new(s.period, s.steps_per_unit);
                let mut r = lock(r);
                let st = self.next_leg(ctl, &mut r, st)?;
                vec![
                    item("IsMoving", json!(rotator::moving(&st, &r))),
                    item(
                        "MechanicalPosition",
                        json!(t.deg(rotator::mechanical(&t, &st, &r))),
                    ),
                    item("Position", json!(t.deg(rotator::sky(&t, &st, &r)))),
                ]
            }
            Role::FilterWheel(w) => {
                vec![item("Position", json!(self.wheel_position(ctl, w, &st)?))]
            }
            Role::Telescope(m) => return self.telescope_state(ctl, m),
        };
        val(items)
    }
}

fn is_moving(st: &AxisStatus) -> bool {
    matches!(
        st.state,
        AxisState::Moving | AxisState::Homing | AxisState::Tracking
    )
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}
