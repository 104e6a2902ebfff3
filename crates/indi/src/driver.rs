//! The driver: the devices the controller's `[alpaca]` section names, the messages
//! indiserver sends them, and the status poll that reports moves as they go.

use crate::device::{Device, Role};
use crate::focuser::Focuser;
use crate::link::{Link, LinkError};
use crate::rotator::Rotator;
use crate::telescope::Telescope;
use crate::wheel::Wheel;
use crate::xml::{Node, Out};
use multistep_alpaca::AlpacaSection;
use std::io::Write;

pub struct Driver {
    link: Link,
    devices: Vec<Device>,
    out: Box<dyn Write + Send>,
}

#[derive(Debug, thiserror::Error)]
pub enum DriverError {
    #[error(transparent)]
    Link(#[from] LinkError),
    #[error("the controller's `devices` answer: {0}")]
    Devices(String),
    #[error("the controller names no focuser, rotator, filter wheel or telescope (its board config has no [alpaca] devices)")]
    NoDevices,
}

impl Driver {
    /// Learns the devices from the controller (`info` for the board's name, `devices` for
    /// its `[alpaca]` section); devices are named as the Alpaca side names them.
    pub fn discover(mut link: Link, out: Box<dyn Write + Send>) -> Result<Driver, DriverError> {
        let board = link
            .request("info")?
            .iter()
            .find_map(|l| l.strip_prefix("board=").map(str::to_string))
            .unwrap_or_else(|| "multistep".into());
        let json = link.request("devices")?;
        let section: AlpacaSection = serde_json::from_str(json.first().map_or("{}", |s| s))
            .map_err(|e| DriverError::Devices(e.to_string()))?;
        let name = |n: &Option<String>, kind: &str, axis: &str| {
            n.clone()
                .unwrap_or_else(|| format!("{board} {kind} {axis}"))
        };
        let mut devices = Vec::new();
        for f in &section.focuser {
            let n = name(&f.name, "focuser", &f.axis);
            devices.push(Device::new(
                n,
                f.axis.clone(),
                Role::Focuser(Focuser::default()),
            ));
        }
        for r in &section.rotator {
            let n = name(&r.name, "rotator", &r.axis);
            let travel = r
                .travel()
                .map_err(|e| DriverError::Devices(e.to_string()))?;
            devices.push(Device::new(
                n,
                r.axis.clone(),
                Role::Rotator(Rotator::new(travel)),
            ));
        }
        for w in &section.filterwheel {
            let n = name(&w.name, "filterwheel", &w.axis);
            let role = Role::Wheel(Wheel::new(w.slots.clone()));
            devices.push(Device::new(n, w.axis.clone(), role));
        }
        // One device per telescope; with several, `mount K …` names the K-th.
        let several = section.telescope.len() > 1;
        for (k, t) in section.telescope.iter().enumerate() {
            let n = name(&t.name, "telescope", &t.ra_axis);
            let mount = if several {
                format!("mount {k}")
            } else {
                "mount".to_string()
            };
            let role = Role::Telescope(Telescope::new(mount, t.clone()));
            devices.push(Device::new(n, t.ra_axis.clone(), role));
        }
        if devices.is_empty() {
            return Err(DriverError::NoDevices);
        }
        Ok(Driver { link, devices, out })
    }

    fn send(&mut self, msgs: Vec<Out>) {
        for m in msgs {
            // indiserver gone: the read loop sees the end of stdin and stops the driver.
            let _ = self.out.write_all(&m.to_bytes());
        }
        let _ = self.out.flush();
    }

    /// One message from indiserver.
    pub fn handle(&mut self, node: &Node) {
        let device = node.attr("device");
        let mine = |d: &Device| device.is_none_or(|x| x == d.name);
        let mut out = Vec::new();
        match node.name.as_str() {
            "getProperties" => {
                let prop = node.attr("name");
                for d in self.devices.iter().filter(|d| mine(d)) {
                    out.extend(d.defs().into_iter().filter(|o| {
                        prop.is_none_or(|p| o.attrs.iter().any(|(k, v)| *k == "name" && v == p))
                    }));
                }
            }
            "newSwitchVector" | "newNumberVector" | "newTextVector" => {
                let Some(prop) = node.attr("name") else {
                    return;
                };
                let values: Vec<(String, String)> = node
                    .children
                    .iter()
                    .filter_map(|c| Some((c.attr("name")?.to_string(), c.text.clone())))
                    .collect();
                let link = &mut self.link;
                for d in self.devices.iter_mut().filter(|d| mine(d)) {
                    if prop == "CONNECTION" {
                        let on = values.iter().any(|(e, t)| {
                            (e == "CONNECT" && t.trim() == "On")
                                || (e == "DISCONNECT" && t.trim() == "Off")
                        });
                        out.extend(d.connect(link, on));
                    } else {
                        out.extend(d.on_new(link, prop, &values));
                    }
                }
            }
            _ => {}
        }
        self.send(out);
    }

    /// Reads the controller's status once and reports what changed.
    pub fn poll(&mut self) {
        if !self.devices.iter().any(|d| d.connected) {
            return;
        }
        let all = self.link.status();
        let mut out = Vec::new();
        for d in &mut self.devices {
            out.extend(d.poll(&mut self.link, &all));
        }
        self.send(out);
    }
}
