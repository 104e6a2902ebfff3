//! The board's registers as far as the backend uses them, behind the link's framing:
//! a start makes its axes busy until [`Model::finish`] runs the moves; the last executed
//! frame's reply answers a retransmission of it (as `ms_link.v`); a chosen reply is
//! damaged or lost.

use super::*;
use multistep_link::{Reply, Request, REPLY_LEN};
use std::io::{Read, Write};
use std::sync::{Arc, Mutex};

#[derive(Default)]
pub struct Model {
    pub session: u32,
    pub enable: u32,
    pub busy: u32,
    pub position: [i64; 2],
    /// Steps each start runs (signed).
    pub steps: i64,
    pub starts: usize,
    /// Damage the next reply to a write of this address; lose every reply to writes
    /// of `mute`.
    pub damage: Option<u16>,
    pub mute: Option<u16>,
    /// Power off and on before the request after this many more.
    pub cycle_in: Option<usize>,
    /// A group armed for the SYNC line (`Arm`), and the axes whose DIR is forward.
    pub armed: bool,
    pub dir: u32,
    /// The link is cut: nothing reaches the board.
    pub cut: bool,
    /// `ArmTimeout` as written; the armed axes; the board cut an armed group.
    pub arm_timeout: Option<u32>,
    pub arm_mask: u32,
    pub arm_expired: bool,
    /// Busy axes report an underrun (a stream no host feeds).
    pub underrun: bool,
    /// The e-stop input is active / the e-stop is latched (`Status` bits 1 and 0).
    pub estop_input: bool,
    pub estop_latched: bool,
    /// The free-running count `Ticks` reads.
    pub ticks: u32,
    /// The `StreamSteps` written to each axis, in order.
    pub stream_steps: [Vec<u32>; 2],
    /// Reads of each axis's `Position`.
    pub position_reads: [usize; 2],
    /// The Hall and limit filter time written, ticks.
    pub debounce: u32,
    /// Commits and control words to the core are refused with status 4 (a Hall stop
    /// diverted the axis), and counted.
    pub refuse_core: bool,
    pub refused: usize,
    last: Option<(Vec<u8>, Reply)>,
    out: Vec<u8>,
}

impl Model {
    /// The moves under way end.
    pub fn finish(&mut self) {
        for a in 0..2 {
            if self.busy >> a & 1 == 1 {
                self.position[a] += self.steps;
            }
        }
        self.busy = 0;
    }

    /// The shared SYNC line falls (another board fired): an armed group starts.
    pub fn sync_fall(&mut self) {
        if self.armed {
            self.armed = false;
            self.starts += 1;
        }
    }

    /// The armed group waited past `ArmTimeout`: the board cuts it.
    pub fn arm_expire(&mut self) {
        if self.armed && self.arm_timeout.is_some_and(|t| t > 0) {
            self.armed = false;
            self.busy &= !self.arm_mask;
            self.arm_expired = true;
        }
    }

    /// Power off and on: every register at its power-up value.
    pub fn power_cycle(&mut self) {
        *self = Model {
            steps: self.steps,
            ..Model::default()
        };
    }

    fn execute(&mut self, r: &Request) -> (Status, u32) {
        let write = r.command == link::Command::Write;
        let (a, ar) = ((r.addr >> 4 & 0xF) as usize, r.addr & 0xF);
        match (r.addr, write) {
            (0x00, false) => (Status::Ok, 0x4D53_0010),
            (0x01, false) => (Status::Ok, 0x0204_0201),
            (0x02, false) => (Status::Ok, 0x1418_8044),
            (0x03, false) => (Status::Ok, 50_000_000),
            (0x04, false) => (Status::Ok, 3_000_000),
            (0x05, false) => (Status::Ok, self.session),
            (0x1A, false) => (Status::Ok, self.ticks),
            (0x05, true) => {
                self.session = r.data;
                (Status::Ok, 0)
            }
            (0x06, false) => {
                let bit = |on: bool, b: u32| if on { b } else { 0 };
                let s = bit(self.armed, status_bits::PENDING | status_bits::ARMED)
                    | bit(self.estop_input, status_bits::ESTOP_INPUT)
                    | bit(self.estop_latched, status_bits::ESTOP)
                    | bit(self.arm_expired, status_bits::ARM_EXPIRED);
                (Status::Ok, s)
            }
            (0x13, true) => {
                self.busy |= r.data;
                self.armed = true;
                (self.arm_mask, self.arm_expired) = (r.data, false);
                (Status::Ok, 0)
            }
            (0x07, false) => (Status::Ok, self.busy),
            (0x09, true) if self.busy & r.data != 0 => (Status::Busy, 0),
            (0x09, true) => {
                self.busy |= r.data;
                self.starts += 1;
                (Status::Ok, 0)
            }
            (0x0A, true) => {
                self.armed = false;
                self.busy &= !r.data;
                (Status::Ok, 0)
            }
            (0x19, true) => {
                self.arm_timeout = Some(r.data);
                (Status::Ok, 0)
            }
            (0x0E, true) => {
                self.enable = r.data;
                (Status::Ok, 0)
            }
            // the e-stop: 1 latches it and halts every axis; 0 clears it unless the input
            // is active
            (0x08, true) if r.data == 0 && self.estop_input => (Status::Estop, 0),
            (0x08, true) => {
                self.estop_latched = r.data != 0;
                if self.estop_latched {
                    self.busy = 0;
                }
                (Status::Ok, 0)
            }
            (0x0D, true) => {
                self.debounce = r.data;
                (Status::Ok, 0)
            }
            (0x10 | 0x12 | 0x16 | 0x17, true) => (Status::Ok, 0),
            // the core's commands: bit 6 of its address (AW = 7 for two axes)
            (0x1040..=0x107F, true) if self.refuse_core => {
                self.refused += 1;
                (Status::Busy, 0)
            }
            (0x1000..=0x1FFF, true) => (Status::Ok, 0),
            (0x2000..=0x201F, false) if ar == 0 => {
                let busy = self.busy >> a & 1 == 1;
                let st = link::AxisState {
                    run: [link::AxisRun::Idle, link::AxisRun::Running][usize::from(busy)],
                    busy,
                    underrun: busy && self.underrun,
                    dir: self.dir >> a & 1 == 1,
                    ..link::AxisState::IDLE
                };
                (Status::Ok, st.encode())
            }
            (0x2000..=0x201F, false) if ar == 1 => {
                self.position_reads[a] += 1;
                (Status::Ok, self.position[a] as u32)
            }
            (0x2000..=0x201F, false) if ar == 3 || ar == 6 => (Status::Ok, 0),
            (0x2000..=0x201F, true) if ar == 1 || ar == 5 => {
                if ar == 1 {
                    self.position[a] = link::position_count(r.data, 0);
                } else {
                    self.stream_steps[a].push(r.data);
                }
                (Status::Ok, 0)
            }
            _ => (Status::BadAddress, 0),
        }
    }
}

pub struct ModelPort(pub Arc<Mutex<Model>>);

impl Write for ModelPort {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        let mut m = self.0.lock().unwrap();
        if m.cut {
            return Err(std::io::ErrorKind::BrokenPipe.into());
        }
        match m.cycle_in {
            Some(0) => m.power_cycle(),
            Some(n) => m.cycle_in = Some(n - 1),
            None => {}
        }
        let req = Request::decode(b).expect("the backend sends whole requests");
        let reply = match &m.last {
            Some((f, r)) if f == b => *r,
            _ => {
                let (status, data) = m.execute(&req);
                let r = Reply {
                    seq: req.seq,
                    status,
                    data,
                };
                m.last = Some((b.to_vec(), r));
                r
            }
        };
        let mut f = reply.encode();
        if m.damage == Some(req.addr) && req.command == link::Command::Write {
            m.damage = None;
            f[REPLY_LEN - 1] ^= 0x10;
        }
        if m.mute != Some(req.addr) {
            m.out.extend_from_slice(&f);
        }
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Read for ModelPort {
    fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
        read_out(&mut self.0.lock().unwrap().out, b)
    }
}

/// A fake board's reply bytes read by the host: a timeout while there are none.
pub fn read_out(out: &mut Vec<u8>, b: &mut [u8]) -> std::io::Result<usize> {
    if out.is_empty() {
        return Err(std::io::ErrorKind::TimedOut.into());
    }
    let n = out.len().min(b.len());
    b[..n].copy_from_slice(&out[..n]);
    out.drain(..n);
    Ok(n)
}

/// A backend on the model, and the model.
pub fn connect() -> (FpgaBackend, Arc<Mutex<Model>>) {
    let m = Arc::new(Mutex::new(Model::default()));
    let port = m.clone();
    let open: Opener = Box::new(move || Ok(Box::new(ModelPort(port.clone())) as Box<dyn Port>));
    let b = FpgaBackend::with_opener("model".into(), open, 2).expect("the model answers");
    (b, m)
}
