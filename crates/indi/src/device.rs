//! One INDI device over one axis: its standard properties, the role's own ones, and what
//! changes when a client sets them or the axis moves.

use crate::focuser::Focuser;
use crate::link::{Link, LinkError};
use crate::props::{Element, Perm, State, Vector};
use crate::rotator::Rotator;
use crate::telescope::Telescope;
use crate::wheel::Wheel;
use crate::xml::Out;
use multistep_controller::{AxisState, AxisStatus};

/// INDI's driver interface bits (DRIVER_INFO.DRIVER_INTERFACE).
pub const TELESCOPE_INTERFACE: u32 = 1 << 0;
pub const GUIDER_INTERFACE: u32 = 1 << 2;
pub const FOCUSER_INTERFACE: u32 = 1 << 3;
pub const FILTER_INTERFACE: u32 = 1 << 4;
pub const ROTATOR_INTERFACE: u32 = 1 << 12;

pub enum Role {
    Focuser(Focuser),
    Rotator(Rotator),
    Wheel(Wheel),
    /// The board's mount; its axis is the polar one.
    Telescope(Telescope),
}

/// The properties of a connected device, found by name.
#[derive(Default)]
pub struct Props(pub Vec<Vector>);

impl Props {
    pub fn get(&self, name: &str) -> Option<&Vector> {
        self.0.iter().find(|v| v.name == name)
    }
    pub fn get_mut(&mut self, name: &str) -> Option<&mut Vector> {
        self.0.iter_mut().find(|v| v.name == name)
    }
    /// Sets `name`'s state and returns its `set` message.
    pub fn state(&mut self, name: &str, s: State, msg: Option<&str>) -> Vec<Out> {
        match self.get_mut(name) {
            Some(v) => {
                v.state = s;
                vec![v.set(msg)]
            }
            None => vec![],
        }
    }
    /// `name` in Alert with the reason: a refused value or a controller error. The reason
    /// also goes to stderr, which indiserver writes to its log.
    pub fn alert(&mut self, name: &str, why: &str) -> Vec<Out> {
        eprintln!("{name}: {why}");
        self.state(name, State::Alert, Some(why))
    }
}

/// A value set by a client: element name and its text.
pub type Values = [(String, String)];

/// The number a client set for `element`, if it is one.
pub fn number_of(values: &Values, element: &str) -> Result<f64, String> {
    let (_, t) = values
        .iter()
        .find(|(n, _)| n == element)
        .ok_or_else(|| format!("{element} missing"))?;
    match t.trim().parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("{element}: '{}' is not a number", t.trim())),
    }
}

/// An abort switch (FOCUS_ABORT_MOTION, ROTATOR_ABORT_MOTION): a stop of the axis.
pub fn abort(dev: &str, name: &'static str) -> Vector {
    Vector::new(
        dev,
        name,
        "Abort Motion",
        "Main Control",
        Perm::Rw,
        vec![Element::switch("ABORT", "Abort", false)],
    )
    .rule(crate::props::Rule::AtMostOne)
}

/// Whether the axis is under way (a move, homing or tracking).
pub fn moving(st: &AxisStatus) -> bool {
    matches!(
        st.state,
        AxisState::Moving | AxisState::Homing | AxisState::Tracking
    )
}

/// The Alert message of an axis in fault, if it is.
pub fn fault(st: &AxisStatus) -> Option<String> {
    (st.state == AxisState::Fault).then(|| {
        format!(
            "axis {} in fault: {}",
            st.axis,
            st.fault.as_deref().unwrap_or("see the controller")
        )
    })
}

pub struct Device {
    pub name: String,
    pub axis: String,
    pub role: Role,
    pub connected: bool,
    /// CONNECTION and DRIVER_INFO, defined while the driver runs.
    pub base: Props,
    /// The role's properties, defined while connected.
    pub props: Props,
    /// The controller is known to be unreachable (its properties are in Alert).
    pub lost: bool,
}

impl Device {
    pub fn new(name: String, axis: String, role: Role) -> Device {
        let interface = match role {
            Role::Focuser(_) => FOCUSER_INTERFACE,
            Role::Rotator(_) => ROTATOR_INTERFACE,
            Role::Wheel(_) => FILTER_INTERFACE,
            Role::Telescope(_) => TELESCOPE_INTERFACE | GUIDER_INTERFACE,
        };
        let connection = Vector::new(
            &name,
            "CONNECTION",
            "Connection",
            "Main Control",
            Perm::Rw,
            vec![
                Element::switch("CONNECT", "Connect", false),
                Element::switch("DISCONNECT", "Disconnect", true),
            ],
        );
        let mut info = Vector::new(
            &name,
            "DRIVER_INFO",
            "Driver Info",
            "General Info",
            Perm::Ro,
            vec![
                Element::text("DRIVER_NAME", "Name", "multistep"),
                Element::text("DRIVER_EXEC", "Exec", "indi_multistep"),
                Element::text("DRIVER_VERSION", "Version", env!("CARGO_PKG_VERSION")),
                Element::text("DRIVER_INTERFACE", "Interface", &interface.to_string()),
            ],
        );
        info.state = State::Ok;
        Device {
            name,
            axis,
            role,
            connected: false,
            base: Props(vec![connection, info]),
            props: Props::default(),
            lost: false,
        }
    }

    /// Every property defined now, as `def` messages.
    pub fn defs(&self) -> Vec<Out> {
        let shown = if self.connected {
            &self.props.0[..]
        } else {
            &[]
        };
        self.base.0.iter().chain(shown).map(Vector::def).collect()
    }

    /// CONNECT: reads the axis and defines the role's properties; DISCONNECT deletes them.
    pub fn connect(&mut self, link: &mut Link, on: bool) -> Vec<Out> {
        let mut out = Vec::new();
        if on && !self.connected {
            match self.build(link) {
                Ok(props) => {
                    self.props = Props(props);
                    self.connected = true;
                    self.lost = false;
                    out.extend(self.props.0.iter().map(Vector::def));
                }
                Err(e) => {
                    let c = self.conn();
                    c.set_switch("DISCONNECT", true);
                    c.state = State::Alert;
                    return vec![c.set(Some(&e.to_string()))];
                }
            }
        } else if !on && self.connected {
            out.extend(
                self.props
                    .0
                    .iter()
                    .map(|v| crate::props::del(&self.name, Some(v.name))),
            );
            self.props = Props::default();
            self.connected = false;
        }
        let c = self.conn();
        c.set_switch(if on { "CONNECT" } else { "DISCONNECT" }, true);
        c.state = if on { State::Ok } else { State::Idle };
        out.push(c.set(None));
        out
    }

    fn conn(&mut self) -> &mut Vector {
        &mut self.base.0[0]
    }

    fn build(&mut self, link: &mut Link) -> Result<Vec<Vector>, LinkError> {
        let st = axis_status(link, &self.axis)?;
        match &mut self.role {
            Role::Telescope(t) => t.build(&self.name, link),
            Role::Focuser(f) => f.build(&self.name, link, &self.axis, &st),
            Role::Rotator(r) => r.build(&self.name, link, &self.axis, &st),
            Role::Wheel(w) => w.build(&self.name, link, &self.axis, &st),
        }
    }

    /// A client set one of the role's properties.
    pub fn on_new(&mut self, link: &mut Link, name: &str, values: &Values) -> Vec<Out> {
        if !self.connected {
            return vec![];
        }
        let axis = self.axis.clone();
        match &mut self.role {
            Role::Focuser(f) => f.on_new(&mut self.props, link, &axis, name, values),
            Role::Rotator(r) => r.on_new(&mut self.props, link, &axis, name, values),
            Role::Wheel(w) => w.on_new(&mut self.props, link, &axis, name, values),
            Role::Telescope(t) => t.on_new(&mut self.props, link, name, values),
        }
    }

    /// The axis's status now: values and Busy/Ok/Alert states that changed.
    pub fn poll(&mut self, link: &mut Link, all: &Result<Vec<AxisStatus>, LinkError>) -> Vec<Out> {
        if !self.connected {
            return vec![];
        }
        let st = match all {
            Ok(all) => all.iter().find(|s| s.axis == self.axis),
            Err(e) => return self.lose(&e.to_string()),
        };
        let Some(st) = st else {
            return self.lose(&format!("the controller has no axis {}", self.axis));
        };
        let mut out = Vec::new();
        if self.lost {
            self.lost = false;
            out.push(crate::props::message(
                &self.name,
                "controller reachable again",
            ));
            for v in &mut self.props.0 {
                if v.state == State::Alert {
                    v.state = State::Ok;
                    out.push(v.set(None));
                }
            }
        }
        let axis = self.axis.clone();
        out.extend(match &mut self.role {
            Role::Focuser(f) => f.poll(&mut self.props, st),
            Role::Rotator(r) => r.poll(&mut self.props, link, &axis, st),
            Role::Wheel(w) => w.poll(&mut self.props, link, &axis, st),
            Role::Telescope(t) => t.poll(&mut self.props, link),
        });
        out
    }

    /// The controller went away: every property in Alert, said once.
    fn lose(&mut self, why: &str) -> Vec<Out> {
        if self.lost {
            return vec![];
        }
        self.lost = true;
        if let Role::Rotator(r) = &mut self.role {
            r.abandon();
        }
        self.props
            .0
            .iter_mut()
            .map(|v| {
                v.state = State::Alert;
                v.set(Some(why))
            })
            .collect()
    }
}

/// One axis's status from the controller.
pub fn axis_status(link: &mut Link, axis: &str) -> Result<AxisStatus, LinkError> {
    link.status()?
        .into_iter()
        .find(|s| s.axis == axis)
        .ok_or_else(|| LinkError::Refused {
            code: 4,
            message: format!("no axis {axis}"),
        })
}
