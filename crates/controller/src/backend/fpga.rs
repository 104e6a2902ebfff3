//! The FPGA board (`ms_board`, docs/HDL.md "The board top level") over its serial host
//! link. Moves run on the board's datapath (`multistep_core::int`), loaded with
//! `link::move_writes` and started together by one `Start` write; counts, busy flags, the
//! Hall latch, the e-stop and the session value are read back from the board's registers.
//! A link that stops answering faults the board's axes until it answers again.

use super::{BoardBackend, Launch, PinEvent, SyncState};
use crate::axis::AxisSettings;
use crate::error::CtlError;
use crate::hall::FilteredEdge;
use multistep_core::int::{IntClock, IntProfile, IntSegment};
use multistep_core::MoveSpec;
use multistep_hdl::link::{self, AxisReg, BoardReg, BuildId, HostLink, LinkError, Reg, Status};
use multistep_hdl::{AxisMove, CoreParams};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

mod sync;

/// Baud of `serial:DEVICE` without `@BAUD`: the boards' default build.
pub const DEFAULT_BAUD: u32 = 3_000_000;
/// How long a request waits for its reply before the link counts as failed.
pub const REPLY_TIMEOUT: Duration = Duration::from_millis(500);
/// How often a failed link is tried again.
pub const RECONNECT_PERIOD: Duration = Duration::from_millis(500);
/// How often an idle board is read (its e-stop input, resets, Hall level).
pub const IDLE_POLL: Duration = Duration::from_millis(50);

/// A board link: `serial:DEVICE[@BAUD]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LinkSpec {
    pub device: String,
    pub baud: u32,
}

impl LinkSpec {
    pub fn parse(s: &str) -> Result<LinkSpec, CtlError> {
        let bad = || {
            CtlError::Setting(format!(
                "board link '{s}': expected serial:DEVICE or serial:DEVICE@BAUD (BAUD 1200 to 100000000)"
            ))
        };
        let rest = s.strip_prefix("serial:").ok_or_else(bad)?;
        let (device, baud) = match rest.rsplit_once('@') {
            Some((d, b)) => (d, b.parse::<u32>().map_err(|_| bad())?),
            None => (rest, DEFAULT_BAUD),
        };
        if device.is_empty() || !(1200..=100_000_000).contains(&baud) {
            return Err(bad());
        }
        Ok(LinkSpec {
            device: device.to_string(),
            baud,
        })
    }
}

impl std::fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "serial:{}@{}", self.device, self.baud)
    }
}

/// A byte stream to the board.
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// Opens the stream (again, after a failure).
pub type Opener = Box<dyn FnMut() -> Result<Box<dyn Port>, String> + Send>;

/// Opens the serial device of `spec` (8N1, [`REPLY_TIMEOUT`]).
pub fn serial_opener(spec: &LinkSpec) -> Opener {
    let spec = spec.clone();
    Box::new(move || {
        serialport::new(&spec.device, spec.baud)
            .timeout(REPLY_TIMEOUT)
            .open()
            .map(|p| Box::new(p) as Box<dyn Port>)
            .map_err(|e| format!("{}: {e}", spec.device))
    })
}

struct Running {
    dir: i64,
    stop_on_sensor: Option<bool>,
    stopping: bool,
    end_tick: u64,
    /// Steps of the stop ramp loaded for a Hall stop.
    ramp_steps: u64,
}

struct FpgaAxis {
    count: i64,
    sensor: bool,
    speed: f64,
    running: Option<Running>,
    settings: AxisSettings,
}

pub struct FpgaBackend {
    name: String,
    open: Opener,
    link: Option<HostLink<Box<dyn Port>>>,
    /// Why the link is down.
    down: Option<String>,
    last_try: Instant,
    params: CoreParams,
    session: u32,
    axes: Vec<FpgaAxis>,
    events: VecDeque<(usize, PinEvent)>,
    now: u64,
    estopped: bool,
    estop_input: bool,
    hall_stop: u32,
    /// The axes whose ENABLE the host wants on (the Enable register, 0x0E).
    enabled: u32,
    last_poll: Option<Instant>,
    polled: bool,
    /// The next start writes `Arm` instead of `Start` (the cross-board start, sync.rs).
    arming: bool,
}

fn link_err(e: LinkError) -> CtlError {
    match e {
        LinkError::Refused {
            status: Status::Estop,
            ..
        } => CtlError::EStopped,
        e => CtlError::Connection(format!("board link: {e}")),
    }
}

impl FpgaBackend {
    /// Connects to the board on `spec` and checks it has at least `axes` axes.
    pub fn connect(spec: &LinkSpec, axes: usize) -> Result<FpgaBackend, CtlError> {
        FpgaBackend::with_opener(spec.to_string(), serial_opener(spec), axes)
    }

    /// [`FpgaBackend::connect`] over any stream `open` gives.
    pub fn with_opener(
        name: String,
        mut open: Opener,
        axes: usize,
    ) -> Result<FpgaBackend, CtlError> {
        let port = open().map_err(CtlError::Connection)?;
        let mut l = HostLink::new(port);
        let id = l.build_id().map_err(link_err)?;
        let params = params_of(&id);
        if (id.axes as usize) < axes {
            return Err(CtlError::Setting(format!(
                "the board on {name} has {} axes, the config {axes}",
                id.axes
            )));
        }
        let session = l.read(Reg::Board(BoardReg::Session)).map_err(link_err)?;
        let mut b = FpgaBackend {
            name,
            open,
            link: Some(l),
            down: None,
            last_try: Instant::now(),
            params,
            session,
            axes: (0..axes)
                .map(|_| FpgaAxis {
                    count: 0,
                    sensor: false,
                    speed: 0.0,
                    running: None,
                    settings: AxisSettings::default(),
                })
                .collect(),
            events: VecDeque::new(),
            now: 0,
            estopped: false,
            estop_input: false,
            hall_stop: 0,
            enabled: ((1u64 << axes) - 1) as u32,
            last_poll: None,
            polled: false,
            arming: false,
        };
        b.setup().map_err(link_err)?;
        b.read_board().map_err(link_err)?;
        Ok(b)
    }

    fn mask(&self) -> u32 {
        ((1u64 << self.axes.len()) - 1) as u32
    }

    /// The board's registers as the host wants them (after start-up and every reset):
    /// debounce, no Hall stops, ENABLE on.
    fn setup(&mut self) -> Result<(), LinkError> {
        let clock = self.params.clock_hz;
        let debounce = self
            .axes
            .iter()
            .map(|a| (a.settings.debounce * clock).ceil())
            .fold(0.0, f64::max)
            .min(u32::MAX as f64) as u32;
        let mask = self.mask();
        let enabled = self.enabled;
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        l.write(Reg::Board(BoardReg::Debounce), debounce)?;
        l.write(Reg::Board(BoardReg::HallStop), 0)?;
        l.write(Reg::Board(BoardReg::Enable), mask & enabled)?;
        self.hall_stop = 0;
        Ok(())
    }

    fn link(&mut self) -> Result<&mut HostLink<Box<dyn Port>>, CtlError> {
        match (&mut self.link, &self.down) {
            (Some(l), _) => Ok(l),
            (None, why) => Err(CtlError::Connection(format!(
                "board link {} is down: {}",
                self.name,
                why.as_deref().unwrap_or("not connected")
            ))),
        }
    }

    /// An error of the link: an I/O failure takes the link down (retried later).
    fn failed(&mut self, e: LinkError) -> CtlError {
        if matches!(
            e,
            LinkError::Io(_) | LinkError::Sequence { .. } | LinkError::Crc { .. }
        ) {
            if self.down.is_none() {
                eprintln!(
                    "warning: board link {}: {e}; its axes are faulted",
                    self.name
                );
            }
            self.link = None;
            self.down = Some(e.to_string());
            self.last_try = Instant::now();
        }
        link_err(e)
    }

    /// Reads what the host shows of the board: e-stop, session, counts, states.
    fn read_board(&mut self) -> Result<(), LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let status = l.read(Reg::Board(BoardReg::Status))?;
        let session = l.read(Reg::Board(BoardReg::Session))?;
        let busy = l.read(Reg::Board(BoardReg::Busy))?;
        self.estop_input = status & 2 != 0;
        if session != self.session {
            return self.session_changed(session);
        }
        if status & 1 != 0 && !self.estopped {
            self.estopped = true;
            self.events.push_back((0, PinEvent::Estop));
        }
        for i in 0..self.axes.len() {
            let a = i as u32;
            let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
            let st = l.axis_state(a)?;
            let count = l.read(Reg::Axis(a, AxisReg::Position))? as i32 as i64;
            let ax = &mut self.axes[i];
            ax.count = count;
            ax.sensor = st.hall;
            let Some(r) = ax.running.as_mut() else {
                continue;
            };
            if st.hall_flag {
                let hp = l.read(Reg::Axis(a, AxisReg::HallPosition))? as i32 as i64;
                l.write(Reg::Board(BoardReg::Clear), 1 << a)?;
                let trigger = !r.stopping && r.stop_on_sensor == Some(true);
                r.stopping |= trigger;
                let edge = FilteredEdge {
                    tick: self.now,
                    active: true,
                    count_at_start: hp,
                    true_at_start: hp,
                };
                let target = hp + r.dir * r.ramp_steps as i64;
                self.events.push_back((
                    i,
                    PinEvent::Sensor {
                        edge,
                        speed: ax.speed,
                        triggered: trigger.then_some(target),
                    },
                ));
            } else if !st.hall && !r.stopping && r.stop_on_sensor == Some(false) {
                // The board latches entering edges only: leaving is seen here, and the
                // axis halts at once (homing speed).
                l.write(Reg::Board(BoardReg::Stop), 1 << a)?;
                r.stopping = true;
                let count = l.read(Reg::Axis(a, AxisReg::Position))? as i32 as i64;
                ax.count = count;
                let edge = FilteredEdge {
                    tick: self.now,
                    active: false,
                    count_at_start: count,
                    true_at_start: count,
                };
                self.events.push_back((
                    i,
                    PinEvent::Sensor {
                        edge,
                        speed: ax.speed,
                        triggered: Some(count),
                    },
                ));
            }
            // A group waiting out its DIR setup has not started yet.
            let pending = status & 4 != 0;
            if pending || (busy >> a & 1 == 1 && st.busy) {
                let period = l.read(Reg::Axis(a, AxisReg::Period))?;
                ax.speed = if period > 0 {
                    self.params.clock_hz / period as f64
                } else {
                    0.0
                };
            } else {
                let ax = &mut self.axes[i];
                ax.running = None;
                ax.speed = 0.0;
                self.events.push_back((i, PinEvent::End { end: self.now }));
            }
        }
        Ok(())
    }

    /// The board was reset or lost power: every axis that moved, or whose count now
    /// differs from what the host saw, lost its count.
    fn session_changed(&mut self, session: u32) -> Result<(), LinkError> {
        self.session = session;
        self.estopped = false;
        self.setup()?;
        for i in 0..self.axes.len() {
            let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
            let count = l.read(Reg::Axis(i as u32, AxisReg::Position))? as i32 as i64;
            let ax = &mut self.axes[i];
            let moved = ax.running.take().is_some();
            if moved || count != ax.count {
                let why = format!(
                    "the board was reset (session {session:#010x}); its count {} was lost{}; untrusted until homed",
                    ax.count,
                    if moved { " mid-move" } else { "" }
                );
                self.events.push_back((i, PinEvent::Lost { why }));
            }
            ax.count = count;
            ax.speed = 0.0;
        }
        Ok(())
    }

    fn reconnect(&mut self) {
        if self.last_try.elapsed() < RECONNECT_PERIOD {
            return;
        }
        self.last_try = Instant::now();
        let port = match (self.open)() {
            Ok(p) => p,
            Err(e) => {
                self.down = Some(e);
                return;
            }
        };
        let mut l = HostLink::new(port);
        let id = match l.build_id() {
            Ok(id) => id,
            Err(e) => {
                self.down = Some(e.to_string());
                return;
            }
        };
        if params_of(&id) != self.params {
            self.down = Some("another board answers on this link".into());
            return;
        }
        self.link = Some(l);
        eprintln!("board link {}: answering again", self.name);
        self.down = None;
    }

    /// The stop ramp of a Hall stop from `speed` (steps/s) at `amax`: one constant
    /// deceleration segment, its duration rounded down so it ends at or above zero speed.
    fn stop_ramp(&self, speed: f64, amax: f64) -> Result<(IntProfile, u64), CtlError> {
        let clock = self.params.clock_hz as u64;
        let v = speed.round().max(1.0);
        let steps = (v * v / (2.0 * amax)).ceil().max(1.0) as u64;
        let ticks = (2.0 * steps as f64 * clock as f64 / v).floor() as u64;
        let p = IntProfile::segments(
            &[IntSegment {
                v0: v as u64,
                ticks,
                steps,
            }],
            IntClock::hz(clock),
        )
        .map_err(|e| CtlError::Setting(format!("the Hall stop ramp: {e}")))?;
        Ok((p, steps))
    }

    fn load(&mut self, l: &Launch, now: u64) -> Result<(Vec<link::RegWrite>, Running), CtlError> {
        let ip = l.datapath.as_ref().ok_or_else(|| {
            CtlError::Setting("the board runs moves planned for its datapath only".into())
        })?;
        let a = l.axis as u32;
        let m = AxisMove::from_profile(ip, l.dir > 0, &self.params)
            .map_err(|e| CtlError::Setting(format!("the board cannot run this move: {e}")))?;
        let mut w = vec![link::RegWrite {
            reg: Reg::Board(BoardReg::Clear),
            data: 1 << a,
        }];
        w.extend(link::move_writes(&self.params, a, &m, 0).map_err(link_err)?);
        let mut ramp_steps = 0;
        if l.stop_on_sensor == Some(true) {
            let slot = self.params.pieces - 1;
            if m.pieces.len() as u32 > slot {
                return Err(CtlError::Setting(format!(
                    "a homing move of {} pieces leaves no slot for the stop ramp",
                    m.pieces.len()
                )));
            }
            let amax = self.axes[l.axis].settings.amax;
            let (ramp, steps) = self.stop_ramp(l.profile.peaks().0, amax)?;
            let rm = AxisMove::from_profile(&ramp, l.dir > 0, &self.params)
                .map_err(|e| CtlError::Setting(format!("the Hall stop ramp: {e}")))?;
            w.extend(
                link::stop_ramp_writes(&self.params, a, slot, &rm.pieces[0]).map_err(link_err)?,
            );
            ramp_steps = steps;
            self.hall_stop |= 1 << a;
        } else {
            self.hall_stop &= !(1 << a);
        }
        let run = Running {
            dir: l.dir,
            stop_on_sensor: l.stop_on_sensor,
            stopping: false,
            end_tick: now + ip.end_tick(),
            ramp_steps,
        };
        Ok((w, run))
    }
}

/// The core's parameters as the board reports them.
fn params_of(id: &BuildId) -> CoreParams {
    CoreParams {
        axes: id.axes,
        fifo_depth: 1 << id.fifo_depth_bits,
        pieces: 1 << id.slot_bits,
        step_bits: id.step_bits,
        tick_bits: id.tick_bits,
        radicand_bits: id.radicand_bits,
        kernel_bits: id.kernel_bits,
        radix_bits: id.radix_bits,
        clock_hz: id.clock_hz as f64,
        ..CoreParams::default()
    }
}

impl BoardBackend for FpgaBackend {
    fn describe(&self) -> String {
        self.name.clone()
    }
    fn is_simulated(&self) -> bool {
        false
    }
    fn clock_hz(&self) -> Option<f64> {
        Some(self.params.clock_hz)
    }
    fn attach(&mut self, _axis: usize, _count: i64, _sim_position: i64) {
        // The board's counter is the count.
    }
    fn configure(&mut self, axis: usize, settings: &AxisSettings) {
        self.axes[axis].settings = settings.clone();
        if self.link.is_some() {
            if let Err(e) = self.setup() {
                self.failed(e);
            }
        }
    }

    /// Trapezoids and seed 000 segments on `multistep_core::int` at the board's clock.
    fn plan_datapath(&self, spec: &MoveSpec) -> Result<Option<IntProfile>, CtlError> {
        let mv = spec.resolve()?;
        link::int_profile(&mv, self.params.clock_hz as u64)
            .map(Some)
            .map_err(|e| CtlError::Setting(format!("the board's datapath: {e}")))
    }

    fn start(
        &mut self,
        moves: Vec<Launch>,
        _report: Option<&multistep_core::tdm::Report>,
        _tdm: &multistep_core::tdm::TdmConfig,
        now: u64,
    ) -> Result<(u64, Vec<u64>), CtlError> {
        self.link()?;
        let mut writes = Vec::new();
        let mut runs = Vec::new();
        let mut mask = 0;
        let mut steps = Vec::new();
        for l in &moves {
            let (w, run) = self.load(l, now)?;
            writes.extend(w);
            mask |= 1 << l.axis;
            steps.push(l.datapath.as_ref().map_or(0, |p| p.steps()));
            runs.push((l.axis, run));
        }
        writes.push(link::RegWrite {
            reg: Reg::Board(BoardReg::HallStop),
            data: self.hall_stop,
        });
        writes.push(self.go_write(mask));
        let r = self.link()?.write_all(&writes);
        if let Err(e) = r {
            return Err(match e {
                LinkError::Refused {
                    status: Status::Busy,
                    ..
                } => CtlError::Busy {
                    axis: format!("on {}", self.name),
                    state: "busy",
                },
                LinkError::Refused {
                    status: Status::BadAddress,
                    ..
                } if self.arming => super::no_sync(&self.name),
                e => self.failed(e),
            });
        }
        for (i, run) in runs {
            self.axes[i].running = Some(run);
        }
        Ok((now, steps))
    }

    fn begin_advance(&mut self) {
        self.polled = false;
    }

    fn poll(&mut self, now: u64) -> Option<(usize, PinEvent)> {
        self.now = now.max(self.now);
        if self.events.is_empty() && !self.polled {
            self.polled = true;
            let moving = self.axes.iter().any(|a| a.running.is_some());
            let due = moving || self.last_poll.is_none_or(|t| t.elapsed() >= IDLE_POLL);
            if self.link.is_none() {
                self.reconnect();
            }
            if due && self.link.is_some() {
                self.last_poll = Some(Instant::now());
                if let Err(e) = self.read_board() {
                    self.failed(e);
                }
            }
        }
        self.events.pop_front()
    }

    fn now(&self) -> u64 {
        self.now
    }

    /// Halts the axis at once (the `Stop` register): the board counts every STEP it
    /// gave, so the count stays exact.
    fn stop(&mut self, axis: usize, _now: u64) -> Result<i64, CtlError> {
        let a = axis as u32;
        let r = self
            .link()?
            .write(Reg::Board(BoardReg::Stop), 1 << a)
            .and_then(|_| {
                self.link
                    .as_mut()
                    .map_or(Err(LinkError::Io("no link".into())), |l| {
                        l.read(Reg::Axis(a, AxisReg::Position))
                    })
            });
        match r {
            Ok(p) => {
                let ax = &mut self.axes[axis];
                ax.count = p as i32 as i64;
                if let Some(r) = ax.running.as_mut() {
                    r.stopping = true;
                }
                Ok(ax.count)
            }
            Err(e) => Err(self.failed(e)),
        }
    }

    fn estop(&mut self, _now: u64) {
        self.estopped = true;
        if let Ok(l) = self.link() {
            if let Err(e) = l.write(Reg::Board(BoardReg::Estop), 1) {
                self.failed(e);
            }
        }
        for ax in &mut self.axes {
            ax.running = None;
            ax.speed = 0.0;
        }
    }

    fn set_enabled(&mut self, axis: usize, on: bool) -> Result<(), CtlError> {
        let bit = 1u32 << axis;
        let enabled = if on {
            self.enabled | bit
        } else {
            self.enabled & !bit
        };
        let mask = self.mask();
        let r = self
            .link()?
            .write(Reg::Board(BoardReg::Enable), enabled & mask);
        match r {
            Ok(()) => {
                self.enabled = enabled;
                Ok(())
            }
            Err(e) => Err(self.failed(e)),
        }
    }

    fn clear_estop(&mut self) -> Result<(), CtlError> {
        let mask = self.mask();
        let enabled = self.enabled & mask;
        let l = self.link()?;
        let r = l
            .write(Reg::Board(BoardReg::Estop), 0)
            .and_then(|_| l.write(Reg::Board(BoardReg::Clear), mask))
            .and_then(|_| l.write(Reg::Board(BoardReg::Enable), enabled));
        match r {
            Ok(()) => {
                self.estopped = false;
                Ok(())
            }
            Err(LinkError::Refused {
                status: Status::Estop,
                ..
            }) => Err(CtlError::Setting(
                "the board's e-stop input is still active".into(),
            )),
            Err(e) => Err(self.failed(e)),
        }
    }

    fn estop_input(&self) -> bool {
        self.estop_input
    }

    fn count(&self, axis: usize) -> i64 {
        self.axes[axis].count
    }

    fn rebase(&mut self, axis: usize, delta: i64, _mechanics: bool) -> Result<(), CtlError> {
        let to = self.axes[axis].count + delta;
        let v = i32::try_from(to).map_err(|_| {
            CtlError::Setting(format!("the board's 32-bit counter cannot hold {to}"))
        })?;
        let r = self
            .link()?
            .write(Reg::Axis(axis as u32, AxisReg::Position), v as u32);
        match r {
            Ok(()) => {
                self.axes[axis].count = to;
                Ok(())
            }
            Err(e) => Err(self.failed(e)),
        }
    }

    fn sensor(&self, axis: usize) -> bool {
        self.axes[axis].sensor
    }

    fn resync_sensor(&mut self, _axis: usize, _now: u64) {
        // The board's filter runs continuously.
    }

    fn speed(&self, axis: usize, _now: u64) -> f64 {
        self.axes[axis].speed
    }

    fn end_tick(&self, axis: usize) -> Option<u64> {
        self.axes[axis].running.as_ref().map(|r| r.end_tick)
    }

    fn fault(&self, _axis: usize) -> Option<String> {
        self.down
            .as_ref()
            .map(|d| format!("board link {} down: {d}", self.name))
    }

    fn polls_when_idle(&self) -> bool {
        true
    }

    fn has_sync(&self) -> bool {
        true
    }
    fn arm(&mut self, moves: Vec<Launch>, now: u64) -> Result<(u64, Vec<u64>), CtlError> {
        self.arm_moves(moves, now)
    }
    fn fire(&mut self) -> Result<(), CtlError> {
        self.fire_sync()
    }
    fn sync_state(&mut self) -> Result<SyncState, CtlError> {
        self.read_sync()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn link_specs_parse_or_say_what_is_expected() {
        assert_eq!(
            LinkSpec::parse("serial:/dev/ttyUSB0").unwrap(),
            LinkSpec {
                device: "/dev/ttyUSB0".into(),
                baud: DEFAULT_BAUD
            }
        );
        assert_eq!(
            LinkSpec::parse("serial:/dev/pts/3@115200").unwrap().baud,
            115_200
        );
        for bad in [
            "",
            "serial:",
            "tcp:x",
            "serial:/dev/x@",
            "serial:/dev/x@12",
            "/dev/x",
        ] {
            let e = LinkSpec::parse(bad).unwrap_err().to_string();
            assert!(e.contains("serial:DEVICE"), "{bad}: {e}");
        }
    }

    /// A stream that never answers: the link fails with an I/O error (the port's timeout).
    struct Silent;
    impl Read for Silent {
        fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
            Err(std::io::ErrorKind::TimedOut.into())
        }
    }
    impl Write for Silent {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_board_that_does_not_answer_is_one_clear_error() {
        let open: Opener = Box::new(|| Ok(Box::new(Silent) as Box<dyn Port>));
        let e = FpgaBackend::with_opener("test".into(), open, 2)
            .err()
            .expect("no board, no backend")
            .to_string();
        assert!(e.contains("board link") && e.contains("I/O"), "{e}");
        let open: Opener = Box::new(|| Err("no such device".into()));
        let e = FpgaBackend::with_opener("test".into(), open, 2)
            .err()
            .expect("no device")
            .to_string();
        assert_eq!(e, "no such device");
    }

    #[test]
    fn garbage_instead_of_replies_is_an_error_not_a_panic() {
        struct Noise(u8);
        impl Read for Noise {
            fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
                for x in b.iter_mut() {
                    self.0 = self.0.wrapping_mul(73).wrapping_add(41);
                    *x = self.0;
                }
                Ok(b.len())
            }
        }
        impl Write for Noise {
            fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
                Ok(b.len())
            }
            fn flush(&mut self) -> std::io::Result<()> {
                Ok(())
            }
        }
        let open: Opener = Box::new(|| Ok(Box::new(Noise(1)) as Box<dyn Port>));
        assert!(FpgaBackend::with_opener("noise".into(), open, 1).is_err());
    }
}
