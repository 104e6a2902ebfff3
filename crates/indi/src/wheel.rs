//! Filter wheel: slots are positions of the axis, from the config or the board's saved
//! named positions, as the Alpaca FilterWheel has them; INDI numbers slots from 1.

use crate::device::{fault, moving, Props, Values};
use crate::link::{Link, LinkError};
use crate::props::{Element, Perm, Range, State, Vector};
use crate::xml::Out;
use multistep_alpaca::config::SlotConfig;
use multistep_alpaca::mapping::slot_at;
use multistep_controller::AxisStatus;

pub struct Wheel {
    slots: Vec<SlotConfig>,
    period: Option<u64>,
}

const SLOT: &str = "FILTER_SLOT";

impl Wheel {
    pub fn new(slots: Vec<SlotConfig>) -> Wheel {
        Wheel {
            slots,
            period: None,
        }
    }

    pub fn build(
        &mut self,
        dev: &str,
        link: &mut Link,
        axis: &str,
        st: &AxisStatus,
    ) -> Result<Vec<Vector>, LinkError> {
        self.period = link.setting(axis, "period")?.map(|p| p as u64);
        let n = self.slots.len() as f64;
        let at = self.slot_now(link, axis, st)?;
        let mut slot = Vector::new(
            dev,
            SLOT,
            "Filter Slot",
            "Filter Wheel",
            Perm::Rw,
            vec![Element::number(
                "FILTER_SLOT_VALUE",
                "Filter",
                at.map_or(1.0, |i| i as f64 + 1.0),
                Range {
                    min: 1.0,
                    max: n,
                    step: 1.0,
                    format: "%.0f",
                },
            )],
        );
        slot.state = if at.is_some() { State::Ok } else { State::Idle };
        let names = self
            .slots
            .iter()
            .enumerate()
            .map(|(i, s)| {
                Element::text(
                    &format!("FILTER_SLOT_NAME_{}", i + 1),
                    &format!("Filter#{}", i + 1),
                    &s.name,
                )
            })
            .collect();
        let mut names = Vector::new(
            dev,
            "FILTER_NAME",
            "Filter",
            "Filter Wheel",
            Perm::Ro,
            names,
        );
        names.state = State::Ok;
        Ok(vec![slot, names])
    }

    /// Slot positions now: the config's, else the saved named position's (None if unsaved).
    fn positions(&self, link: &mut Link, axis: &str) -> Result<Vec<Option<i64>>, LinkError> {
        let named = if self.slots.iter().any(|s| s.position.is_none()) {
            link.request("positions")?
        } else {
            vec![]
        };
        Ok(self
            .slots
            .iter()
            .map(|s| {
                s.position.or_else(|| {
                    named.iter().find_map(|l| {
                        let mut w = l.split_whitespace();
                        (w.next() == Some(s.name.as_str())).then_some(())?;
                        w.find_map(|kv| kv.strip_prefix(axis)?.strip_prefix('=')?.parse().ok())
                    })
                })
            })
            .collect())
    }

    /// The slot (0-based) the wheel stands on, None while it moves or between slots.
    fn slot_now(
        &self,
        link: &mut Link,
        axis: &str,
        st: &AxisStatus,
    ) -> Result<Option<usize>, LinkError> {
        if moving(st) {
            return Ok(None);
        }
        Ok(slot_at(
            &self.positions(link, axis)?,
            self.period,
            st.position,
        ))
    }

    pub fn on_new(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        axis: &str,
        name: &str,
        values: &Values,
    ) -> Vec<Out> {
        if name != SLOT {
            return vec![];
        }
        let n = self.slots.len();
        let slot = match crate::device::number_of(values, "FILTER_SLOT_VALUE") {
            Ok(x) if x.fract() == 0.0 && (1.0..=n as f64).contains(&x) => x as usize,
            Ok(x) => return p.alert(SLOT, &format!("{x} is not a slot (1..={n})")),
            Err(e) => return p.alert(SLOT, &e),
        };
        let at = match self.positions(link, axis) {
            Ok(at) => at[slot - 1],
            Err(e) => return p.alert(SLOT, &e.to_string()),
        };
        let Some(at) = at else {
            let s = &self.slots[slot - 1].name;
            return p.alert(
                SLOT,
                &format!("slot {slot} '{s}' has no position: save it with 'save {s} {axis}'"),
            );
        };
        match link.request(&format!("moveto {axis} {at}")) {
            Ok(_) => {
                let Some(v) = p.get_mut(SLOT) else {
                    return vec![];
                };
                v.set_number("FILTER_SLOT_VALUE", slot as f64);
                v.state = State::Busy;
                vec![v.set(None)]
            }
            Err(e) => p.alert(SLOT, &e.to_string()),
        }
    }

    pub fn poll(
        &mut self,
        p: &mut Props,
        link: &mut Link,
        axis: &str,
        st: &AxisStatus,
    ) -> Vec<Out> {
        let busy = moving(st);
        let Some(was) = p.get(SLOT).map(|v| v.state) else {
            return vec![];
        };
        if busy {
            return if was == State::Busy {
                vec![]
            } else {
                p.state(SLOT, State::Busy, None)
            };
        }
        if was != State::Busy {
            return vec![];
        }
        // The move just ended: on a slot, or not.
        if let Some(why) = fault(st) {
            return p.alert(SLOT, &why);
        }
        match self.slot_now(link, axis, st) {
            Ok(Some(i)) => {
                let Some(v) = p.get_mut(SLOT) else {
                    return vec![];
                };
                v.set_number("FILTER_SLOT_VALUE", i as f64 + 1.0);
                v.state = State::Ok;
                vec![v.set(None)]
            }
            Ok(None) => p.alert(
                SLOT,
                &format!("the wheel stands between slots (at {})", st.position),
            ),
            Err(e) => p.alert(SLOT, &e.to_string()),
        }
    }
}
