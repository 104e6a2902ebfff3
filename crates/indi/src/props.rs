//! INDI property vectors (numbers, switches, texts) and their def/set/del messages, as
//! the INDI protocol (version 1.7) lays them out.

use crate::xml::Out;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State {
    Idle,
    Ok,
    Busy,
    Alert,
}

impl State {
    fn word(self) -> &'static str {
        match self {
            State::Idle => "Idle",
            State::Ok => "Ok",
            State::Busy => "Busy",
            State::Alert => "Alert",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Perm {
    Ro,
    Rw,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    OneOfMany,
    AtMostOne,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: f64,
    pub step: f64,
    /// printf format, as INDI clients read it.
    pub format: &'static str,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Number(f64, Range),
    Switch(bool),
    Text(String),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    pub name: String,
    pub label: String,
    pub value: Value,
}

impl Element {
    pub fn number(name: &str, label: &str, value: f64, range: Range) -> Element {
        Element {
            name: name.into(),
            label: label.into(),
            value: Value::Number(value, range),
        }
    }
    pub fn switch(name: &str, label: &str, on: bool) -> Element {
        Element {
            name: name.into(),
            label: label.into(),
            value: Value::Switch(on),
        }
    }
    pub fn text(name: &str, label: &str, text: &str) -> Element {
        Element {
            name: name.into(),
            label: label.into(),
            value: Value::Text(text.into()),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Vector {
    pub device: String,
    pub name: &'static str,
    pub label: &'static str,
    pub group: &'static str,
    pub perm: Perm,
    /// Switches only.
    pub rule: Rule,
    pub state: State,
    pub elements: Vec<Element>,
}

impl Vector {
    pub fn new(
        device: &str,
        name: &'static str,
        label: &'static str,
        group: &'static str,
        perm: Perm,
        elements: Vec<Element>,
    ) -> Vector {
        Vector {
            device: device.into(),
            name,
            label,
            group,
            perm,
            rule: Rule::OneOfMany,
            state: State::Idle,
            elements,
        }
    }
    pub fn rule(mut self, rule: Rule) -> Vector {
        self.rule = rule;
        self
    }

    fn kind(&self) -> &'static str {
        match self.elements.first().map(|e| &e.value) {
            Some(Value::Switch(_)) => "Switch",
            Some(Value::Text(_)) => "Text",
            _ => "Number",
        }
    }

    /// `defXVector`: the whole property, as a client first learns it.
    pub fn def(&self) -> Out {
        let kind = self.kind();
        let mut v = Out::new(def_name(kind))
            .attr("device", &self.device)
            .attr("name", self.name)
            .attr("label", self.label)
            .attr("group", self.group)
            .attr("state", self.state.word())
            .attr(
                "perm",
                match self.perm {
                    Perm::Ro => "ro",
                    Perm::Rw => "rw",
                },
            )
            .attr("timeout", "60");
        if kind == "Switch" {
            v = v.attr(
                "rule",
                match self.rule {
                    Rule::OneOfMany => "OneOfMany",
                    Rule::AtMostOne => "AtMostOne",
                },
            );
        }
        for e in &self.elements {
            let c = Out::new(match kind {
                "Switch" => "defSwitch",
                "Text" => "defText",
                _ => "defNumber",
            })
            .attr("name", &e.name)
            .attr("label", &e.label);
            v = v.child(match &e.value {
                Value::Number(x, r) => c
                    .attr("format", r.format)
                    .attr("min", r.min.to_string())
                    .attr("max", r.max.to_string())
                    .attr("step", r.step.to_string())
                    .text(x.to_string()),
                other => c.text(value_text(other)),
            });
        }
        v
    }

    /// `setXVector`: the values and state now, with an optional message.
    pub fn set(&self, message: Option<&str>) -> Out {
        let kind = self.kind();
        let mut v = Out::new(match kind {
            "Switch" => "setSwitchVector",
            "Text" => "setTextVector",
            _ => "setNumberVector",
        })
        .attr("device", &self.device)
        .attr("name", self.name)
        .attr("state", self.state.word());
        if let Some(m) = message {
            v = v.attr("message", m);
        }
        for e in &self.elements {
            let c = Out::new(match kind {
                "Switch" => "oneSwitch",
                "Text" => "oneText",
                _ => "oneNumber",
            })
            .attr("name", &e.name);
            v = v.child(match &e.value {
                // a changed range goes with the value (a new soft limit)
                Value::Number(x, r) => c
                    .attr("min", r.min.to_string())
                    .attr("max", r.max.to_string())
                    .text(x.to_string()),
                other => c.text(value_text(other)),
            });
        }
        v
    }

    pub fn element(&self, name: &str) -> Option<&Element> {
        self.elements.iter().find(|e| e.name == name)
    }

    pub fn number(&self, name: &str) -> f64 {
        match self.element(name).map(|e| &e.value) {
            Some(Value::Number(x, _)) => *x,
            _ => f64::NAN,
        }
    }

    pub fn set_number(&mut self, name: &str, value: f64) {
        for e in &mut self.elements {
            if let (true, Value::Number(x, _)) = (e.name == name, &mut e.value) {
                *x = value;
            }
        }
    }

    pub fn set_text(&mut self, name: &str, text: &str) {
        for e in &mut self.elements {
            if let (true, Value::Text(t)) = (e.name == name, &mut e.value) {
                *t = text.to_string();
            }
        }
    }

    pub fn switch(&self, name: &str) -> bool {
        matches!(
            self.element(name).map(|e| &e.value),
            Some(Value::Switch(true))
        )
    }

    /// Turns `name` on; under OneOfMany the others go off.
    pub fn set_switch(&mut self, name: &str, on: bool) {
        let one = self.rule == Rule::OneOfMany;
        for e in &mut self.elements {
            if let Value::Switch(s) = &mut e.value {
                if e.name == name {
                    *s = on;
                } else if one && on {
                    *s = false;
                }
            }
        }
    }
}

fn def_name(kind: &str) -> &'static str {
    match kind {
        "Switch" => "defSwitchVector",
        "Text" => "defTextVector",
        _ => "defNumberVector",
    }
}

fn value_text(v: &Value) -> String {
    match v {
        Value::Switch(true) => "On".into(),
        Value::Switch(false) => "Off".into(),
        Value::Text(t) => t.clone(),
        Value::Number(x, _) => x.to_string(),
    }
}

/// `delProperty`: the device's property `name` is gone (all of them without a name).
pub fn del(device: &str, name: Option<&str>) -> Out {
    let o = Out::new("delProperty").attr("device", device);
    match name {
        Some(n) => o.attr("name", n),
        None => o,
    }
}

/// A message from the device, shown in the client's log.
pub fn message(device: &str, text: &str) -> Out {
    Out::new("message")
        .attr("device", device)
        .attr("message", text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_switch_vector_defines_and_sets() {
        let mut v = Vector::new(
            "F",
            "CONNECTION",
            "Connection",
            "Main Control",
            Perm::Rw,
            vec![
                Element::switch("CONNECT", "Connect", false),
                Element::switch("DISCONNECT", "Disconnect", true),
            ],
        );
        v.set_switch("CONNECT", true);
        assert!(v.switch("CONNECT") && !v.switch("DISCONNECT"));
        let d = String::from_utf8(v.def().to_bytes()).unwrap();
        assert!(
            d.starts_with("<defSwitchVector device=\"F\" name=\"CONNECTION\""),
            "{d}"
        );
        assert!(
            d.contains("rule=\"OneOfMany\"") && d.contains(">On</defSwitch>"),
            "{d}"
        );
        v.state = State::Alert;
        let s = String::from_utf8(v.set(Some("no <board>")).to_bytes()).unwrap();
        assert!(
            s.contains("state=\"Alert\" message=\"no &lt;board&gt;\""),
            "{s}"
        );
    }
}
