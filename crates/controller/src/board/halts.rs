//! Halting: `stop` (the ramp at amax), `estop` (at once, latched) and `reset`.

use super::*;

impl Board {
    /// Controlled stop (decelerates at amax) of one axis or all; homing is abandoned.
    pub fn stop(&mut self, axis: Option<&str>, now: u64) -> Result<(), CtlError> {
        self.advance(now);
        let which: Vec<usize> = match axis {
            Some(a) => vec![self.index(a)?],
            None => (0..self.axes.len()).collect(),
        };
        for i in which {
            if self.stop_tracking(i) {
                continue;
            }
            let b = self.axes[i].backlash();
            if let Some(m) = self.axes[i].motion.as_mut() {
                m.purpose = Purpose::Move;
                if !m.stopping {
                    m.stopping = true;
                    let motor = self.pins.stop(i, self.now)?;
                    m.target = motor - slack_after(m.slack0, motor - m.motor0, b);
                }
                self.axes[i].state = AxisState::Moving;
            }
        }
        Ok(())
    }

    /// Emergency stop: every axis halts on the spot and the board refuses motion until
    /// `reset`. An axis that was moving is marked untrusted: a real motor halted at speed
    /// can slip, so its count may be wrong (the simulation itself loses no steps).
    pub fn estop(&mut self, now: u64) {
        self.advance(now);
        self.estop_now();
    }

    /// [`Board::estop`] at the board's present tick.
    pub(super) fn estop_now(&mut self) {
        let halted = self.estop_halt();
        self.record_halted(halted);
    }

    /// The first half of [`Board::estop`]: the pins halt and the board refuses motion.
    /// The halted axes' records are written by [`Board::record_halted`] (disk writes: a
    /// service answers the e-stop before them).
    pub fn estop_latch(&mut self, now: u64) -> Halted {
        self.advance(now);
        self.estop_halt()
    }

    pub(super) fn estop_halt(&mut self) -> Halted {
        self.estopped = true;
        self.pins.estop(self.now);
        let mut halted = Vec::new();
        for (i, ax) in self.axes.iter_mut().enumerate() {
            if ax.motion.take().is_some() {
                ax.state = AxisState::Fault;
                ax.fault = Some("emergency stop".into());
                ax.trusted = false;
                ax.move_end = Some(self.now);
                halted.push(i);
            }
        }
        Halted(halted)
    }

    /// Writes down the axes an e-stop halted (untrusted, no longer moving).
    pub fn record_halted(&mut self, halted: Halted) {
        for i in halted.0 {
            self.persist(i);
        }
    }

    /// Clears an emergency stop and axis faults.
    pub fn reset(&mut self, now: u64) {
        self.advance(now);
        if let Err(e) = self.pins.clear_estop() {
            if self.warnings.len() < 100 {
                self.warnings.push(format!("reset: {e}"));
            }
            return;
        }
        self.estopped = false;
        for ax in &mut self.axes {
            if ax.state == AxisState::Fault {
                ax.state = AxisState::Idle;
                ax.fault = None;
            }
        }
    }
}
