//! The FPGA board (`ms_board`, docs/HDL.md "The board top level") over its serial host
//! link. Moves run on the board's datapath (`multistep_core::int`), loaded with
//! `link::move_writes` and started together by one `Start` write; counts, busy flags, the
//! Hall latch, the e-stop and the session token are read back from the board's registers.
//! A link that stops answering faults the board's axes until it answers again.
//!
//! The host writes a random token to the board's `Session` register when it connects; a
//! reset or power cycle clears it, so any other readback means the board lost its state:
//! every axis is then untrusted until homed. A request whose reply is lost is sent again
//! and answered once (`HostLink`); a start whose outcome stays unknown (the link failed)
//! untrusts its axes.
//!
//! On a board with replay units (`ms_stream`) every other move — any family, non-whole
//! speeds, more pieces than slots once split to the tick width — and tracking run
//! streamed: the host codes the exact edges of `plan` (or of the tracker) and keeps each
//! axis's buffer fed from the poll loop ([`stream::Feed`]).

mod stream;

use super::{BoardBackend, Launch, LinkState, PinEvent, SyncState};
use crate::axis::AxisSettings;
use crate::error::CtlError;
use crate::hall::FilteredEdge;
use crate::motion::{EdgeSource, StepSource};
use crate::tracking::TrackSource;
use multistep_core::int::{IntClock, IntProfile, IntSegment};
use multistep_core::MoveSpec;
use multistep_link::chain::{ChainedMove, CHAIN_LAYOUT};
use multistep_link::{
    self as link, core_addr, status_bits, AxisReg, BoardReg, HostLink, LinkError, Reg, Status,
    BULK_MAX,
};
use multistep_link::{AxisMove, CoreParams};
use stream::Feed;

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

mod readback;
mod session;
mod sync;
use crate::store::LinkSession;
pub use session::{SessionKeeper, ARM_LIFETIME};

/// Baud of `serial:DEVICE` without `@BAUD`: the boards' default build.
pub const DEFAULT_BAUD: u32 = 3_000_000;
/// How long a request waits for its reply before the link counts as failed.
pub const REPLY_TIMEOUT: Duration = Duration::from_millis(500);
/// How often a failed link is tried again.
pub const RECONNECT_PERIOD: Duration = Duration::from_millis(500);
/// How often an idle board is read (its e-stop input, resets, Hall level).
pub const IDLE_POLL: Duration = Duration::from_millis(50);

/// A board link: `serial:DEVICE[@BAUD][,timeout=SECONDS]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LinkSpec {
    pub device: String,
    pub baud: u32,
    /// How long a request waits for its reply ([`REPLY_TIMEOUT`] unless given): a board
    /// answers within a millisecond, a simulated one (`board-sim`) on a busy machine may
    /// need seconds.
    pub timeout: Duration,
}

/// The range of `timeout=` (seconds).
pub const TIMEOUT_RANGE: std::ops::RangeInclusive<f64> = 0.01..=60.0;

impl LinkSpec {
    pub fn parse(s: &str) -> Result<LinkSpec, CtlError> {
        let bad = || {
            CtlError::Setting(format!(
                "board link '{s}': expected serial:DEVICE[@BAUD][,timeout=SECONDS] (BAUD 1200 \
                 to 100000000, SECONDS 0.01 to 60)"
            ))
        };
        let rest = s.strip_prefix("serial:").ok_or_else(bad)?;
        let (rest, timeout) = match rest.rsplit_once(",timeout=") {
            Some((r, t)) => match t.parse::<f64>() {
                Ok(t) if TIMEOUT_RANGE.contains(&t) => (r, Duration::from_secs_f64(t)),
                _ => return Err(bad()),
            },
            None => (rest, REPLY_TIMEOUT),
        };
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
            timeout,
        })
    }
}

impl std::fmt::Display for LinkSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "serial:{}@{}", self.device, self.baud)?;
        if self.timeout != REPLY_TIMEOUT {
            write!(f, ",timeout={}", self.timeout.as_secs_f64())?;
        }
        Ok(())
    }
}

/// A byte stream to the board.
pub trait Port: Read + Write + Send {}
impl<T: Read + Write + Send> Port for T {}

/// Opens the stream (again, after a failure).
pub type Opener = Box<dyn FnMut() -> Result<Box<dyn Port>, String> + Send>;

/// Opens the serial device of `spec` (8N1, its reply timeout).
pub fn serial_opener(spec: &LinkSpec) -> Opener {
    let spec = spec.clone();
    Box::new(move || {
        serialport::new(&spec.device, spec.baud)
            .timeout(spec.timeout)
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
    /// Added to the board's `Position` while the axis runs: a periodic axis wraps its
    /// count mid-motion, when the board's counter cannot be written (it is written, and
    /// this folded into it, once the axis rests).
    offset: i64,
    sensor: bool,
    speed: f64,
    running: Option<Running>,
    settings: AxisSettings,
    /// The streamed schedule of a running streamed move or tracking motion.
    feed: Option<Feed>,
    /// The underrun flag was reported for the motion under way.
    late_told: bool,
    /// Report each poll of a tracking axis as a step (a soft limit lies ahead).
    watch: bool,
}

pub struct FpgaBackend {
    name: String,
    open: Opener,
    link: Option<HostLink<Box<dyn Port>>>,
    /// Why the link is down.
    down: Option<String>,
    last_try: Instant,
    params: CoreParams,
    /// The token this host wrote to the board's `Session` register.
    session: u32,
    /// Axes of a start whose outcome is unknown: its write failed with the link.
    doubt: u32,
    axes: Vec<FpgaAxis>,
    events: VecDeque<(usize, PinEvent)>,
    now: u64,
    estopped: bool,
    estop_input: bool,
    hall_stop: u32,
    /// The axes whose ENABLE the host wants on (the Enable register, 0x0E).
    enabled: u32,
    last_poll: Option<Instant>,
    /// When the board was last read in full (`read_board`).
    read_at: Option<Instant>,
    polled: bool,
    /// The board has replay units for streamed moves.
    streams: bool,
    /// Each axis's stream buffer (bytes; 0: none).
    buffer: u32,
    /// The board computes scurve and scurve4 pieces with a chain unit per axis, from
    /// records of this many bytes (`BoardReg::Chains`; 0: no chain units).
    chains: u32,
    /// The next start writes `Arm` instead of `Start` (the cross-board start, sync.rs).
    arming: bool,
    /// Keeps the session across a restart of the host (session.rs), and what it kept.
    keep: Option<SessionKeeper>,
    kept: Option<LinkSession>,
    /// The board kept the stored session: its counts and motions are this host's.
    adopted: bool,
    /// The axes of a group armed for the SYNC line, and since when.
    armed: u32,
    armed_at: Option<Instant>,
    arm_lifetime: Duration,
    /// The board's registers are set up at the next poll (an adopted board: once every
    /// axis's settings are known, so no running axis's DIR level changes meanwhile).
    setup_due: bool,
    /// Set while a halt waits for the board: a poll lets go of the link (see `HostLink`).
    urgent: Option<Arc<AtomicBool>>,
    /// Idle axes whose offset is folded into the board's counter at the next poll (an
    /// adopted board's: once its session can be kept), and a fold under way.
    fold_due: u32,
    folding: Option<crate::store::Fold>,
}

fn link_err(e: LinkError) -> CtlError {
    match e {
        LinkError::Refused {
            status: Status::Estop,
            ..
        } => CtlError::EStopped,
        e if matches!(e, LinkError::Io(_)) || e.in_doubt() => {
            CtlError::Link(format!("board link: {e}"))
        }
        e => CtlError::LinkRefused(format!("board link: {e}")),
    }
}

impl FpgaBackend {
    /// Connects to the board on `spec` and checks it has at least `axes` axes.
    pub fn connect(spec: &LinkSpec, axes: usize) -> Result<FpgaBackend, CtlError> {
        FpgaBackend::with_opener(spec.to_string(), serial_opener(spec), axes)
    }

    /// [`FpgaBackend::connect`] by a host that kept `before` (see session.rs): the board
    /// still holding its token is adopted as it runs.
    pub fn connect_resuming(
        spec: &LinkSpec,
        axes: usize,
        before: Option<LinkSession>,
    ) -> Result<FpgaBackend, CtlError> {
        FpgaBackend::with_opener_resuming(spec.to_string(), serial_opener(spec), axes, before)
    }

    /// [`FpgaBackend::connect`] over any stream `open` gives.
    pub fn with_opener(name: String, open: Opener, axes: usize) -> Result<FpgaBackend, CtlError> {
        FpgaBackend::with_opener_resuming(name, open, axes, None)
    }

    /// [`FpgaBackend::with_opener`] with the session kept before (see session.rs).
    pub fn with_opener_resuming(
        name: String,
        mut open: Opener,
        axes: usize,
        before: Option<LinkSession>,
    ) -> Result<FpgaBackend, CtlError> {
        let port = open().map_err(CtlError::Link)?;
        let mut l = HostLink::new(port);
        let id = l.build_id().map_err(link_err)?;
        let params = CoreParams::from(&id);
        if (id.axes as usize) < axes {
            return Err(CtlError::Setting(format!(
                "the board on {name} has {} axes, the config {axes}",
                id.axes
            )));
        }
        let session = match before {
            Some(_) => 0,
            None => {
                let t = link::session_token();
                l.claim(t).map_err(link_err)?;
                t
            }
        };
        let mut b = FpgaBackend {
            name,
            open,
            link: Some(l),
            down: None,
            last_try: Instant::now(),
            params,
            session,
            doubt: 0,
            axes: (0..axes)
                .map(|_| FpgaAxis {
                    count: 0,
                    offset: 0,
                    sensor: false,
                    speed: 0.0,
                    running: None,
                    settings: AxisSettings::default(),
                    feed: None,
                    late_told: false,
                    watch: false,
                })
                .collect(),
            events: VecDeque::new(),
            now: 0,
            estopped: false,
            estop_input: false,
            hall_stop: 0,
            enabled: ((1u64 << axes) - 1) as u32,
            last_poll: None,
            read_at: None,
            polled: false,
            streams: false,
            buffer: 0,
            chains: 0,
            arming: false,
            keep: None,
            kept: None,
            adopted: false,
            armed: 0,
            armed_at: None,
            arm_lifetime: ARM_LIFETIME,
            setup_due: false,
            urgent: None,
            fold_due: 0,
            folding: None,
        };
        if let Some(before) = &before {
            b.resume(before).map_err(link_err)?;
        }
        b.buffer = b.probe_streams().map_err(link_err)?;
        b.streams = b.buffer > 0;
        b.chains = b.probe_chains().map_err(link_err)?;
        if b.adopted {
            b.setup_due = true;
        } else {
            b.setup().map_err(link_err)?;
            // a group armed before this host connected belongs to no group of its own
            b.disarm("it was armed before this host connected")
                .map_err(link_err)?;
        }
        b.read_board().map_err(link_err)?;
        b.read_at = Some(Instant::now());
        Ok(b)
    }

    fn mask(&self) -> u32 {
        ((1u64 << self.axes.len()) - 1) as u32
    }

    /// The size of the board's stream buffers (0: no replay units): an idle axis's free
    /// stream count once arming (a `StreamSteps` write; 0 leaves the axis computed)
    /// emptied it; with every axis busy, the most any has free.
    fn probe_streams(&mut self) -> Result<u32, LinkError> {
        let axes = self.axes.len() as u32;
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        for a in 0..axes {
            if !l.axis_state(a)?.busy {
                l.write(Reg::Axis(a, AxisReg::StreamSteps), 0)?;
                return l.read(Reg::Axis(a, AxisReg::StreamFree));
            }
        }
        let mut most = 0;
        for a in 0..axes {
            most = most.max(l.read(Reg::Axis(a, AxisReg::StreamFree))?);
        }
        Ok(most)
    }

    /// The board's chain record size (`BoardReg::Chains`), or 0: a board without chain
    /// units refuses the read.
    fn probe_chains(&mut self) -> Result<u32, LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        match l.read(Reg::Board(BoardReg::Chains)) {
            Err(LinkError::Refused {
                status: Status::BadAddress,
                ..
            }) => Ok(0),
            r => r,
        }
    }

    /// Sends every streaming axis the code its buffer has room for.
    fn feed_streams(&mut self) -> Result<(), LinkError> {
        for i in 0..self.axes.len() {
            let ax = &mut self.axes[i];
            let (Some(f), Some(l)) = (ax.feed.as_mut(), self.link.as_mut()) else {
                continue;
            };
            if f.lost.is_some() {
                // what the board holds of the code is unknown: the axis stops, its count
                // exact; read_board reports it
                if !f.stopped {
                    l.write(Reg::Board(BoardReg::Stop), 1 << i)?;
                    f.stopped = true;
                }
                continue;
            }
            let done = (ax.count - f.count0).unsigned_abs();
            if let Err(e) = pump(l, f, i as u32, done, true) {
                if matches!(e, LinkError::Io(_)) || e.in_doubt() {
                    return Err(e);
                }
                // this axis's stream alone failed (a step its replay unit cannot time, a
                // refused write): the axis halts, its count exact, and the board is read on
                eprintln!(
                    "warning: board link {}: axis {i}: {e}; the axis is halted",
                    self.name
                );
                l.write(Reg::Board(BoardReg::Stop), 1 << i)?;
                ax.feed = None;
                let why = format!(
                    "bad_code: the host cannot code the axis's next step for the board's \
                     replay unit ({e}); the axis was halted there (the count is exact)"
                );
                self.events.push_back((i, PinEvent::Late { why }));
            }
        }
        Ok(())
    }

    /// The board's registers as the host wants them (after start-up and every reset):
    /// debounce, no Hall stops, each axis's DIR and ENABLE levels, ENABLE on.
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
        let axes_where = |f: fn(&AxisSettings) -> bool| -> u32 {
            self.axes
                .iter()
                .enumerate()
                .filter(|(_, a)| f(&a.settings))
                .map(|(i, _)| 1u32 << i)
                .sum()
        };
        let dir_invert = axes_where(|s| s.invert_dir);
        let enable_low = axes_where(|s| !s.enable_active_high);
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        l.write(Reg::Board(BoardReg::Debounce), debounce)?;
        l.write(Reg::Board(BoardReg::HallStop), 0)?;
        // the levels before ENABLE: an active-low driver is never energized by the switch
        l.write(Reg::Board(BoardReg::DirInvert), dir_invert)?;
        l.write(Reg::Board(BoardReg::EnableLow), enable_low)?;
        l.write(Reg::Board(BoardReg::Enable), mask & enabled)?;
        self.hall_stop = 0;
        Ok(())
    }

    fn link(&mut self) -> Result<&mut HostLink<Box<dyn Port>>, CtlError> {
        match (&mut self.link, &self.down) {
            (Some(l), _) => Ok(l),
            (None, why) => Err(CtlError::Link(format!(
                "board link {} is down: {}",
                self.name,
                why.as_deref().unwrap_or("not connected")
            ))),
        }
    }

    /// An error of the link: an I/O failure, or a reply still lost or damaged after the
    /// link's retransmissions, takes the link down (retried later).
    fn failed(&mut self, e: LinkError) -> CtlError {
        if matches!(e, LinkError::Io(_)) || e.in_doubt() {
            if self.down.is_none() {
                eprintln!(
                    "warning: board link {}: {e}; its axes are faulted",
                    self.name
                );
            }
            self.link = None;
            self.down = Some(e.to_string());
            self.last_try = Instant::now();
        } else {
            eprintln!("warning: board link {}: {e}", self.name);
        }
        link_err(e)
    }

    /// Reads what the host shows of the board: e-stop, session, counts, states.
    fn read_board(&mut self) -> Result<(), LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let status = l.read(Reg::Board(BoardReg::Status))?;
        let busy = l.read(Reg::Board(BoardReg::Busy))?;
        self.estop_input = status & status_bits::ESTOP_INPUT != 0;
        // What this poll reads is believed once the session, read last, still holds: a
        // reset between two reads would show a moving axis come to rest.
        let told = self.events.len();
        let running = self
            .axes
            .iter()
            .enumerate()
            .filter(|(_, a)| a.running.is_some())
            .map(|(i, _)| 1u32 << i)
            .sum();
        if status & status_bits::ESTOP != 0 && !self.estopped {
            self.estopped = true;
            self.events.push_back((0, PinEvent::Estop));
        }
        for i in 0..self.axes.len() {
            let a = i as u32;
            let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
            let st = l.axis_state(a)?;
            let ax = &mut self.axes[i];
            let count = readback::count(l.read(Reg::Axis(a, AxisReg::Position))?, ax.offset);
            ax.count = count;
            ax.sensor = st.hall;
            let Some(r) = ax.running.as_mut() else {
                if st.stream_armed {
                    // armed by a start that failed: the next start would replay nothing
                    l.write(Reg::Axis(a, AxisReg::StreamSteps), 0)?;
                }
                continue;
            };
            if st.hall_flag {
                let hp = readback::count(l.read(Reg::Axis(a, AxisReg::HallPosition))?, ax.offset);
                l.write(Reg::Board(BoardReg::Clear), 1 << a)?;
                let trigger = !r.stopping && r.stop_on_sensor == Some(true);
                r.stopping |= trigger;
                let edge = FilteredEdge {
                    tick: self.now,
                    active: true,
                    count_at_start: hp,
                    true_at_start: hp,
                };
                let target = match ax.feed.as_mut().filter(|f| trigger && f.lead_limited) {
                    // a fast streamed search: the host codes the stop ramp after the lead
                    // it had coded and cuts the stream's count to match
                    Some(f) => {
                        let amax = ax.settings.amax;
                        let total = f
                            .ramp_down(amax, self.params.clock_hz)
                            .map_err(LinkError::Move)?;
                        let n = u32::try_from(total).unwrap_or(u32::MAX);
                        l.write(Reg::Axis(a, AxisReg::StreamSteps), n)?;
                        f.count0 + r.dir * total as i64
                    }
                    None => hp + r.dir * r.ramp_steps as i64,
                };
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
                let count = readback::count(l.read(Reg::Axis(a, AxisReg::Position))?, ax.offset);
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
            let pending = status & status_bits::PENDING != 0;
            if pending || (busy >> a & 1 == 1 && st.busy) {
                let period = l.read(Reg::Axis(a, AxisReg::Period))?;
                ax.speed = if period > 0 {
                    self.params.clock_hz / period as f64
                } else {
                    0.0
                };
            } else {
                if st.stream_armed {
                    // armed but never started (a refused start): back to computed
                    l.write(Reg::Axis(a, AxisReg::StreamSteps), 0)?;
                }
                let ax = &mut self.axes[i];
                ax.running = None;
                ax.speed = 0.0;
                // at rest: the board's counter takes the wrapped count
                self.fold_offset(i)?;
                let ax = &mut self.axes[i];
                let feed = ax.feed.take();
                self.events.push_back((i, PinEvent::End { end: self.now }));
                if let Some(f) = &feed {
                    stream_stats(i, f, count);
                }
                if st.underrun || st.stream_fault || feed.as_ref().is_some_and(|f| f.stopped) {
                    let why = late_reason(feed.as_ref(), st.stream_fault);
                    self.events.push_back((i, PinEvent::Late { why }));
                }
                continue;
            }
            let ax = &mut self.axes[i];
            if (st.underrun || st.stream_fault) && !ax.late_told {
                ax.late_told = true;
                eprintln!(
                    "warning: board {}: axis {i}: {}",
                    self.name,
                    late_reason(ax.feed.as_ref(), st.stream_fault)
                );
            }
            if ax.watch && ax.feed.is_some() {
                self.events.push_back((i, PinEvent::Step));
            }
        }
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let session = l.read(Reg::Board(BoardReg::Session))?;
        if session != self.session {
            self.events.truncate(told);
            return self.session_changed(session, running);
        }
        if self.doubt != 0 {
            self.start_in_doubt();
        }
        Ok(())
    }

    /// The board was reset or lost power (its session register no longer holds this
    /// host's token): every axis lost its count, whatever the timing, and the board is
    /// claimed with a new token. `running`: the axes moving before the poll that saw it.
    fn session_changed(&mut self, session: u32, running: u32) -> Result<(), LinkError> {
        let token = link::session_token();
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        l.write(Reg::Board(BoardReg::Session), token)?;
        self.session = token;
        self.doubt = 0;
        self.estopped = false;
        self.setup()?;
        for i in 0..self.axes.len() {
            let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
            let count = readback::count(l.read(Reg::Axis(i as u32, AxisReg::Position))?, 0);
            let ax = &mut self.axes[i];
            ax.feed = None;
            ax.offset = 0;
            let moved = ax.running.take().is_some() || running >> i & 1 == 1;
            let why = format!(
                "the board was reset or lost power (its session register reads {session:#010x}, \
                 not this host's token); its count {} was lost{}; untrusted until homed",
                ax.count,
                if moved { " mid-move" } else { "" }
            );
            self.events.push_back((i, PinEvent::Lost { why }));
            ax.count = count;
            ax.speed = 0.0;
        }
        Ok(())
    }

    /// Logs the requests the link sent again since the last time.
    fn tell_retransmits(&mut self) {
        if let Some(l) = self.link.as_mut().filter(|l| l.retransmitted > 0) {
            eprintln!(
                "note: board link {}: {} request(s) sent again (a reply damaged or late); \
                 each executed once",
                self.name, l.retransmitted
            );
            l.retransmitted = 0;
        }
    }

    /// The link failed at a start, so whether the board started it is unknown: its axes'
    /// counts cannot be trusted.
    fn start_in_doubt(&mut self) {
        for (i, ax) in self.axes.iter_mut().enumerate() {
            if self.doubt >> i & 1 == 1 {
                ax.running = None;
                ax.feed = None;
                let why = "the link failed at its start, so the board may or may not have run \
                           the move; untrusted until homed"
                    .to_string();
                self.events.push_back((i, PinEvent::Lost { why }));
            }
        }
        self.doubt = 0;
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
        if CoreParams::from(&id) != self.params {
            self.down = Some("another board answers on this link".into());
            return;
        }
        self.link = Some(l.with_urgent(self.urgent.clone()));
        eprintln!("board link {}: answering again", self.name);
        self.down = None;
    }

    /// The stop ramp of a Hall stop from `speed` (steps/s) at `amax`: one constant
    /// deceleration segment, its duration rounded down so it ends at or above zero speed.
    fn stop_ramp(&self, speed: f64, amax: f64) -> Result<(IntProfile, u64), CtlError> {
        let clock = self.params.clock_hz as u64;
        let v = speed.round().max(1.0);
        let steps = multistep_core::stop_distance(v, amax, None).ceil().max(1.0) as u64;
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

    /// The writes that set an axis's DIR and arm its replay unit (`arm`: `StreamSteps`, or
    /// `ChainSteps` for chain records) for `steps` steps (its buffer emptied), the Hall and
    /// stopped flags cleared.
    fn arm_writes(
        &self,
        axis: usize,
        dir: i64,
        arm: AxisReg,
        steps: u32,
    ) -> Result<Vec<link::RegWrite>, CtlError> {
        let a = axis as u32;
        let w = self
            .params
            .widths()
            .map_err(|e| CtlError::Setting(format!("the board's widths: {e}")))?;
        Ok(vec![
            link::RegWrite {
                reg: Reg::Board(BoardReg::Clear),
                data: 1 << a,
            },
            // DIR through the core's control word (bit 31), as for computed moves
            link::RegWrite {
                reg: Reg::Core(core_addr(&w, true, a, 1)),
                data: u32::from(dir > 0) << 31,
            },
            link::RegWrite {
                reg: Reg::Axis(a, arm),
                data: steps,
            },
        ])
    }

    /// A move the datapath cannot compute, streamed: `plan`'s exact edges at the board's
    /// clock, coded as the buffer makes room.
    fn load_streamed(
        &mut self,
        l: &Launch,
        now: u64,
    ) -> Result<(Vec<link::RegWrite>, Running, Option<Feed>), CtlError> {
        if !self.streams {
            return Err(CtlError::Setting(NO_REPLAY.into()));
        }
        // A Hall stop on a streamed axis: the board halts it at the edge when that stays
        // within amax (there is no ramp piece to divert to); faster, the stream is coded
        // only a lead ahead and the host codes the stop ramp when it sees the edge.
        let host_ramp = l.stop_on_sensor == Some(true)
            && !halts_within_amax(l.profile.peaks().0, self.axes[l.axis].settings.amax);
        if l.stop_on_sensor == Some(true) && !host_ramp {
            self.hall_stop |= 1 << l.axis;
        } else {
            self.hall_stop &= !(1 << l.axis);
        }
        let clock = self.params.clock_hz;
        let steps = l.profile.steps();
        let n = u32::try_from(steps).map_err(|_| {
            CtlError::Setting(format!(
                "a streamed move of {steps} steps: the board counts at most {} a move",
                u32::MAX
            ))
        })?;
        let src = EdgeSource::new(l.profile.clone(), clock, 0)?;
        let run = Running {
            dir: l.dir,
            stop_on_sensor: l.stop_on_sensor,
            stopping: false,
            end_tick: now + (l.profile.duration() * clock).round() as u64,
            ramp_steps: 0,
        };
        if let Some(c) = self.chained(l) {
            // computed on the board: every record goes before the start
            let steps = c.steps();
            let mut feed = Feed::fixed(Box::new(src), c.bytes, steps, self.params.tick_bits);
            feed.dir = l.dir;
            feed.count0 = self.axes[l.axis].count;
            let w = self.arm_writes(l.axis, l.dir, AxisReg::ChainSteps, n)?;
            return Ok((w, run, Some(feed)));
        }
        let mut feed = Feed::new(Box::new(src), 0, self.params.tick_bits, false);
        feed.dir = l.dir;
        feed.count0 = self.axes[l.axis].count;
        feed.lead_limited = host_ramp;
        let w = self.arm_writes(l.axis, l.dir, AxisReg::StreamSteps, n)?;
        Ok((w, run, Some(feed)))
    }

    /// `l`'s chain records, when the board computes its pieces: chain units whose records
    /// are [`CHAIN_LAYOUT`]'s, a move of polynomial pieces (scurve, scurve4 and trapezoid
    /// pieces) within the units' widths, all its records in the stream buffer at once, a
    /// chain that stays ahead of the pulse unit, and no Hall stop (a homing search
    /// streams, so the host can code its stop ramp).
    fn chained(&self, l: &Launch) -> Option<ChainedMove> {
        if self.chains as usize != CHAIN_LAYOUT.record_bytes() || l.stop_on_sensor.is_some() {
            return None;
        }
        let clock = self.params.clock_hz as u64;
        let bits = self.params.tick_bits;
        ChainedMove::from_profile(&l.profile, clock, bits, &CHAIN_LAYOUT)
            .ok()
            .filter(|c| c.bytes.len() <= self.buffer as usize)
            // a chain walks a tick a clock: a slow tail after a fast stretch can outrun
            // the lead its FIFO holds (multistep_core::tdm::chain), so such a move streams
            .filter(|c| c.keeps_up(self.params.fifo_depth))
    }

    /// Arms the streaming axes' buffers (their free count is the buffer's size) and sends
    /// what fits before the start.
    fn preload(&mut self, feeds: &mut [(usize, Feed)]) -> Result<(), LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        for (i, f) in feeds.iter_mut() {
            let a = *i as u32;
            f.buffer = l.read(Reg::Axis(a, AxisReg::StreamFree))?;
            f.free = f.buffer;
            if f.buffer == 0 {
                return Err(LinkError::Move(NO_REPLAY.into()));
            }
            pump(l, f, a, 0, false)?;
        }
        Ok(())
    }

    /// Loads the moves (`writes`) and the Hall stops, preloads the streams, then starts
    /// `mask` as one group.
    fn send_start(
        &mut self,
        mut writes: Vec<link::RegWrite>,
        feeds: &mut [(usize, Feed)],
        mask: u32,
    ) -> Result<(), CtlError> {
        self.link()?;
        writes.push(link::RegWrite {
            reg: Reg::Board(BoardReg::HallStop),
            data: self.hall_stop,
        });
        if self.arming {
            writes.push(self.arm_timeout_write());
        }
        // `Start`, or `Arm` for a cross-board start (sync.rs)
        let go = self.go_write(mask);
        let no_link = || LinkError::Io("no link".into());
        let r = self
            .link
            .as_mut()
            .ok_or_else(no_link)
            .and_then(|l| l.write_all(&writes))
            .and_then(|_| self.preload(feeds))
            .and_then(|_| {
                let l = self.link.as_mut().ok_or_else(no_link)?;
                // a go whose reply stays lost after the retransmissions may have started
                l.write(go.reg, go.data).inspect_err(|e| {
                    if e.in_doubt() || matches!(e, LinkError::Io(_)) {
                        self.doubt |= mask;
                    }
                })
            });
        self.tell_retransmits();
        if let (Err(e), Some(l)) = (&r, self.link.as_mut()) {
            let busy = matches!(
                e,
                LinkError::Refused {
                    status: Status::Busy,
                    ..
                }
            );
            if !e.in_doubt() && !busy && !matches!(e, LinkError::Io(_)) {
                // refused: nothing started, so nothing stays armed
                for (i, _) in feeds.iter() {
                    let _ = l.write(Reg::Axis(*i as u32, AxisReg::StreamSteps), 0);
                }
            }
        }
        r.map_err(|e| match e {
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
        })
    }

    fn load(
        &mut self,
        l: &Launch,
        now: u64,
    ) -> Result<(Vec<link::RegWrite>, Running, Option<Feed>), CtlError> {
        let Some(ip) = l.datapath.as_ref() else {
            return self.load_streamed(l, now);
        };
        let a = l.axis as u32;
        let m = AxisMove::from_profile(ip, l.dir > 0, &self.params)
            .map_err(|e| CtlError::Setting(format!("the board cannot run this move: {e}")))?;
        let mut w = vec![link::RegWrite {
            reg: Reg::Board(BoardReg::Clear),
            data: 1 << a,
        }];
        if self.streams {
            // computed, whatever an earlier start that failed left armed
            w.push(link::RegWrite {
                reg: Reg::Axis(a, AxisReg::StreamSteps),
                data: 0,
            });
        }
        w.extend(link::move_writes(&self.params, a, &m, 0).map_err(link_err)?);
        let mut ramp_steps = 0;
        if l.stop_on_sensor == Some(true) {
            let slot = self.params.pieces - 1;
            if m.pieces.len() as u32 > slot {
                // its pieces, split to the tick width, take every slot: stream it
                if self.streams {
                    return self.load_streamed(l, now);
                }
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
        Ok((w, run, None))
    }
}

/// Why an axis's motion was late: the board's underrun flag (an edge came late, none
/// early) or a bad code in its replay unit.
/// Each starts with its fault word (docs/PROTOCOL.md).
fn late_reason(feed: Option<&Feed>, bad_code: bool) -> String {
    match (feed, bad_code) {
        (_, true) => {
            "bad_code: the board's replay unit met a bad code and stopped the stream".into()
        }
        (
            Some(Feed {
                lost: Some(why), ..
            }),
            _,
        ) => format!(
            "link_fault: {why}; the axis was stopped short of its target (the count is exact)"
        ),
        (Some(f), _) if f.resent > 0 => "link_fault: a bulk write of the stream was damaged \
             or lost on the link and sent again, so some edges came late (none early; the \
             count is exact)"
            .into(),
        (Some(_), _) => "stream_starved: the link fell behind the streamed move, so some \
                         edges came late (none early; the count is exact)"
            .into(),
        (None, _) => "calculator_late: the board's calculator fell behind, so some edges came \
                      late (none early; the count is exact)"
            .into(),
    }
}

/// With `MULTISTEP_LINK_STATS` set: one line per streamed motion on stderr (steps, link
/// bytes per step, the least code left in the buffer when the host came to top it up).
fn stream_stats(axis: usize, f: &Feed, count: i64) {
    if std::env::var_os("MULTISTEP_LINK_STATS").is_none() {
        return;
    }
    let steps = f.coded().max(1);
    let framed = f.sent + link::BULK_OVERHEAD as u64 * f.frames;
    let what = if f.is_fixed() { "chain record" } else { "code" };
    eprintln!(
        "link stats: axis {axis}: {} steps ({} counted), {} {what} bytes in {} frames: \
         {:.3} {what} bytes/step, {:.3} with frames; buffer {} bytes, least left {} bytes",
        f.coded(),
        (count - f.count0).abs(),
        f.sent,
        f.frames,
        f.sent as f64 / steps as f64,
        framed as f64 / steps as f64,
        f.buffer,
        f.min_left()
    );
}

/// Sends `axis` the code its buffer has room for: fills the frame from the feed, sends it
/// when the free count (the last reply's, read again when it looks short) says it fits.
/// `done`: the steps the board has made of this motion (a tracker codes only a lead
/// beyond them). `may_yield`: ends early, between two frames, for an urgent request.
fn pump<T: Read + Write>(
    l: &mut HostLink<T>,
    f: &mut Feed,
    axis: u32,
    done: u64,
    may_yield: bool,
) -> Result<(), LinkError> {
    let mut refreshed = false;
    loop {
        if may_yield && l.urgent() {
            return Ok(());
        }
        f.fill(BULK_MAX, f.lead_limit(done))
            .map_err(LinkError::Move)?;
        let Some(n) = f.next_frame(BULK_MAX.min(f.free as usize)) else {
            if f.open && f.ended && f.pending() == 0 && !f.closed {
                // the tracker came to rest: the stream ends after the steps coded, so
                // the axis ends as a planned move does (no underrun)
                let n = u32::try_from(f.coded()).unwrap_or(u32::MAX);
                l.write(Reg::Axis(axis, AxisReg::StreamSteps), n)?;
                f.closed = true;
            }
            if refreshed || f.pending() == 0 {
                return Ok(());
            }
            // the board took code since the last reply
            f.free = l.read(Reg::Axis(axis, AxisReg::StreamFree))?;
            f.saw_free();
            refreshed = true;
            continue;
        };
        stream::send_frame(l, f, axis, n)?;
    }
}

/// The board may halt a streamed search at the Hall edge when halting from `speed` stays
/// within `amax`, i.e. a stop at amax would cover at most one step (`speed² ≤ 2·amax`),
/// which is what the simulated backend's stop ramp then does too (`motion::stop_profile`).
fn halts_within_amax(speed: f64, amax: f64) -> bool {
    speed <= (2.0 * amax).sqrt() * (1.0 + 1e-9)
}

/// Why a board refuses what only streaming runs.
const NO_REPLAY: &str = "the board has no replay units for streamed moves (its build has \
    no stream buffers: a bulk write answers status 7), so it runs only trapezoids of \
    whole-number speeds whose pieces, split to its tick width, fit its slots, and no \
    tracking";

/// Checks that every period of `plan`'s edges of `mv` at `clock_hz` fits the replay
/// unit (2 to 2^tick_bits − 1 ticks), before anything starts.
fn check_streamable(
    mv: &multistep_core::Move<'_>,
    clock_hz: f64,
    tick_bits: u32,
) -> Result<(), CtlError> {
    let max = (1u64 << tick_bits.min(63)) - 1;
    let mut last = 0;
    for (i, t) in multistep_core::edges(mv, clock_hz)?.enumerate() {
        let p = t.wrapping_sub(last);
        if p < 2 || p > max {
            return Err(CtlError::Setting(format!(
                "the board cannot stream this move: step {} comes {p} ticks after the one \
                 before; its replay unit takes 2 to {max} ticks ({:.3} s at its clock)",
                i + 1,
                max as f64 / clock_hz
            )));
        }
        last = t;
    }
    Ok(())
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
        if self.link.is_some() && !self.setup_due {
            if let Err(e) = self.setup() {
                self.failed(e);
            }
        }
    }

    /// Trapezoids and seed 000 segments on `multistep_core::int` at the board's clock,
    /// when every piece fits the datapath; any other move is streamed (`None`: the
    /// host's plan runs) on a board with replay units, and refused on one without.
    fn plan_datapath(&self, spec: &MoveSpec) -> Result<Option<IntProfile>, CtlError> {
        let mv = spec.resolve()?;
        let computed = link::int_profile(&mv, self.params.clock_hz as u64).and_then(|ip| {
            AxisMove::from_profile(&ip, true, &self.params)
                .map(|_| ip)
                .map_err(|e| LinkError::Move(e.to_string()))
        });
        match computed {
            Ok(ip) => Ok(Some(ip)),
            Err(_) if self.streams => {
                check_streamable(&mv, self.params.clock_hz, self.params.tick_bits)?;
                Ok(None)
            }
            Err(e) => Err(CtlError::Setting(format!(
                "the board's datapath: {e}; {NO_REPLAY}"
            ))),
        }
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
        let mut feeds = Vec::new();
        let mut mask = 0;
        let mut steps = Vec::new();
        for l in &moves {
            let (w, run, feed) = self.load(l, now)?;
            writes.extend(w);
            mask |= 1 << l.axis;
            steps.push(l.datapath.as_ref().map_or(l.profile.steps(), |p| p.steps()));
            runs.push((l.axis, run));
            feeds.extend(feed.map(|f| (l.axis, f)));
        }
        let streamed = feeds.iter().map(|(i, _)| 1u32 << i).sum();
        self.keep_session_with(streamed, if self.arming { mask } else { 0 });
        self.send_start(writes, &mut feeds, mask)?;
        if self.arming {
            self.armed_now(mask);
        }
        for (i, run) in runs {
            let ax = &mut self.axes[i];
            ax.running = Some(run);
            ax.late_told = false;
            ax.feed = None;
        }
        for (i, f) in feeds {
            self.axes[i].feed = Some(f);
        }
        Ok((now, steps))
    }

    /// Tracking, streamed: the tracker's exact edges, coded a short lead ahead of the
    /// board's count so that a rate change or stop takes effect soon after it is asked for.
    fn start_source(
        &mut self,
        axis: usize,
        mut src: Box<dyn StepSource>,
        dir: i64,
        start: u64,
    ) -> Result<u64, CtlError> {
        if !self.streams {
            return Err(CtlError::Unsupported(format!(
                "tracking on {}: {NO_REPLAY}",
                self.name
            )));
        }
        self.link()?;
        if let Some(t) = src.as_track() {
            // a rate whose steps the replay unit cannot time is refused now, not mid-stream
            t.limit_periods((1u64 << self.params.tick_bits.min(63)) - 1)?;
        }
        let end_tick = src.end_tick();
        let mut feed = Feed::new(src, start, self.params.tick_bits, true);
        feed.dir = dir;
        feed.count0 = self.axes[axis].count;
        self.hall_stop &= !(1 << axis);
        // open-ended: armed for the most steps, closed with the real count at rest
        let writes = self.arm_writes(axis, dir, AxisReg::StreamSteps, u32::MAX)?;
        let mut feeds = [(axis, feed)];
        self.keep_session_with(1 << axis, 0);
        self.send_start(writes, &mut feeds, 1 << axis)?;
        let [(_, feed)] = feeds;
        let ax = &mut self.axes[axis];
        ax.running = Some(Running {
            dir,
            stop_on_sensor: None,
            stopping: false,
            end_tick,
            ramp_steps: 0,
        });
        ax.late_told = false;
        ax.feed = Some(feed);
        Ok(start)
    }

    fn can_track(&self) -> bool {
        self.streams
    }

    fn why_no_tracking(&self) -> String {
        NO_REPLAY.into()
    }

    fn tracker(&mut self, axis: usize) -> Option<&mut TrackSource> {
        self.axes[axis].feed.as_mut()?.tracker()
    }

    fn steps_ahead(&self, axis: usize) -> u64 {
        let ax = &self.axes[axis];
        ax.feed.as_ref().map_or(0, |f| {
            f.committed_ahead((ax.count - f.count0).unsigned_abs())
        })
    }

    fn watch_steps(&mut self, axis: usize, on: bool) {
        self.axes[axis].watch = on;
    }

    fn begin_advance(&mut self) {
        self.polled = false;
    }

    fn set_urgent_flag(&mut self, flag: Arc<AtomicBool>) {
        self.link = self.link.take().map(|l| l.with_urgent(Some(flag.clone())));
        self.urgent = Some(flag);
    }

    fn poll(&mut self, now: u64) -> Option<(usize, PinEvent)> {
        self.now = now.max(self.now);
        if self.events.is_empty() && !self.polled {
            self.polled = true;
            let moving = self.axes.iter().any(|a| a.running.is_some());
            let due = moving || self.last_poll.is_none_or(|t| t.elapsed() >= IDLE_POLL);
            if self.link.is_none() {
                self.reconnect();
                if self.link.is_some() {
                    self.after_reconnect();
                }
            }
            if due && self.link.is_some() {
                self.last_poll = Some(Instant::now());
                // the board is read even when feeding a stream failed, unless the link did
                if let Err(e) = self.feed_streams() {
                    self.failed(e);
                }
                // a halt waiting for the link goes first; the board is read next poll
                let urgent = self.link.as_ref().is_some_and(|l| l.urgent());
                if self.link.is_some() && !urgent {
                    match self.read_board() {
                        Ok(()) => self.read_at = Some(Instant::now()),
                        Err(e) => {
                            self.failed(e);
                        }
                    }
                }
                self.after_read();
                self.tell_retransmits();
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
                ax.count = readback::count(p, ax.offset);
                if let Some(r) = ax.running.as_mut() {
                    r.stopping = true;
                }
                // halted: the rest of a stream is not sent
                ax.feed = None;
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
            ax.feed = None;
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
        let ax = &mut self.axes[axis];
        if ax.running.is_some() {
            // the counter runs (and is not writable): the host shifts its reading
            ax.offset += delta;
            ax.count += delta;
            if let Some(f) = ax.feed.as_mut() {
                f.count0 += delta;
            }
            self.keep_session_now();
            return Ok(());
        }
        if ax.offset != 0 {
            // the write below sets the whole count
            self.fold_offset(axis).map_err(|e| self.failed(e))?;
        }
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
        let r = self.axes[axis].running.as_ref()?;
        (r.end_tick != session::UNKNOWN_END).then_some(r.end_tick)
    }

    fn fault(&self, _axis: usize) -> Option<String> {
        self.down
            .as_ref()
            .map(|d| format!("board link {} down: {d}", self.name))
    }

    fn link_state(&self) -> Option<LinkState> {
        Some(LinkState {
            up: self.down.is_none(),
            read_at: self.read_at,
        })
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
    fn keep_session(&mut self, keep: SessionKeeper) {
        self.keep = Some(keep);
        self.kept = None;
        self.keep_session_now();
    }
    fn adopted(&self) -> bool {
        self.adopted
    }
    fn adopted_motion(&self, axis: usize) -> Option<i64> {
        let r = self.axes[axis].running.as_ref()?;
        (r.end_tick == session::UNKNOWN_END).then_some(r.dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_streamed_search_halts_on_the_board_only_within_amax() {
        // sqrt(2 * 40000) = 282.84…
        assert!(halts_within_amax(250.0, 40_000.0));
        assert!(halts_within_amax(282.0, 40_000.0));
        assert!(!halts_within_amax(283.0, 40_000.0));
    }

    #[test]
    fn link_specs_parse_or_say_what_is_expected() {
        assert_eq!(
            LinkSpec::parse("serial:/dev/ttyUSB0").unwrap(),
            LinkSpec {
                device: "/dev/ttyUSB0".into(),
                baud: DEFAULT_BAUD,
                timeout: REPLY_TIMEOUT,
            }
        );
        let slow = LinkSpec::parse("serial:/dev/pts/3@115200,timeout=2.5").unwrap();
        assert_eq!(
            (slow.baud, slow.timeout),
            (115_200, Duration::from_millis(2500))
        );
        assert_eq!(LinkSpec::parse(&slow.to_string()).unwrap(), slow);
        assert_eq!(
            LinkSpec::parse("serial:/dev/x,timeout=0.01")
                .unwrap()
                .timeout,
            Duration::from_millis(10)
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
            "serial:/dev/x,timeout=0",
            "serial:/dev/x,timeout=61",
            "serial:/dev/x,timeout=NaN",
            "serial:/dev/x@9600,timeout=",
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

/// The board's registers as far as the backend uses them, behind the link's framing:
/// a start makes its axes busy until [`Model::finish`] runs the moves; the last executed
/// frame's reply answers a retransmission of it (as `ms_link.v`); a chosen reply is
/// damaged or lost.
#[cfg(test)]
mod model {
    use super::*;
    use multistep_link::{Reply, Request, REPLY_LEN};
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
        /// The `StreamSteps` written to each axis, in order.
        pub stream_steps: [Vec<u32>; 2],
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
                (0x08 | 0x0D | 0x10 | 0x12 | 0x16 | 0x17, true) => (Status::Ok, 0),
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
                (0x2000..=0x201F, false) if ar == 1 => (Status::Ok, self.position[a] as u32),
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
}

#[cfg(test)]
mod exactly_once {
    use super::model::connect;
    use super::*;
    use multistep_core::MoveParams;

    /// A move of `steps` the board computes.
    pub(super) fn launch(b: &FpgaBackend, axis: usize, steps: u64) -> Launch {
        let spec = MoveSpec {
            steps: Some(steps),
            params: MoveParams {
                vmax: Some(4000.0),
                amax: Some(40_000.0),
                ..MoveParams::default()
            },
            ..MoveSpec::default()
        };
        let datapath = b.plan_datapath(&spec).unwrap();
        assert!(datapath.is_some(), "computed on the board");
        Launch {
            axis,
            profile: spec.plan().unwrap(),
            datapath,
            dir: 1,
            stop_on_sensor: None,
            resync_sensor: true,
        }
    }

    fn events(b: &mut FpgaBackend, now: u64) -> Vec<(usize, PinEvent)> {
        b.begin_advance();
        std::iter::from_fn(|| b.poll(now)).collect()
    }

    fn start(b: &mut FpgaBackend, l: Launch) -> Result<(u64, Vec<u64>), CtlError> {
        b.start(vec![l], None, &multistep_core::tdm::TdmConfig::default(), 0)
    }

    #[test]
    fn a_start_whose_reply_is_damaged_runs_once_and_is_tracked() {
        let (mut b, m) = connect();
        m.lock().unwrap().steps = 800;
        let l = launch(&b, 0, 800);
        m.lock().unwrap().damage = Some(Reg::Board(BoardReg::Start).addr());
        let r = start(&mut b, l);
        assert!(r.is_ok(), "the board started it: {r:?}");
        assert_eq!(m.lock().unwrap().starts, 1);
        assert!(b.end_tick(0).is_some(), "tracked as moving");
        assert!(events(&mut b, 1).is_empty(), "still moving");
        m.lock().unwrap().finish();
        let ev = events(&mut b, 2);
        assert!(matches!(ev[..], [(0, PinEvent::End { .. })]), "{ev:?}");
        assert_eq!((b.count(0), b.end_tick(0)), (800, None));
        // the next move is a new start
        let l = launch(&b, 0, 800);
        start(&mut b, l).unwrap();
        m.lock().unwrap().finish();
        events(&mut b, 3);
        assert_eq!((m.lock().unwrap().starts, b.count(0)), (2, 1600));
    }

    #[test]
    fn the_estop_input_and_the_latched_estop_are_told_apart() {
        let (mut b, m) = connect();
        m.lock().unwrap().steps = 300;
        let l = launch(&b, 0, 300);
        start(&mut b, l).unwrap();
        m.lock().unwrap().estop_input = true;
        assert!(
            events(&mut b, 1).is_empty(),
            "the input alone halts nothing here"
        );
        assert!(b.estop_input());
        (
            m.lock().unwrap().estop_input,
            m.lock().unwrap().estop_latched,
        ) = (false, true);
        let ev = events(&mut b, 2);
        assert!(matches!(ev[..], [(0, PinEvent::Estop)]), "{ev:?}");
        assert!(!b.estop_input());
    }

    #[test]
    fn a_power_cycle_untrusts_every_axis_whatever_the_timing() {
        let (mut b, m) = connect();
        m.lock().unwrap().steps = 300;
        let l = launch(&b, 0, 300);
        start(&mut b, l).unwrap();
        assert!(events(&mut b, 1).is_empty());
        // off and on mid-move: every register as at power-up, Session 0 as before
        m.lock().unwrap().power_cycle();
        let ev = events(&mut b, 2);
        let lost: Vec<usize> = ev
            .iter()
            .filter_map(|(i, e)| match e {
                PinEvent::Lost { why } if why.contains("reset or lost power") => Some(*i),
                _ => None,
            })
            .collect();
        assert_eq!(lost, vec![0, 1], "{ev:?}");
        assert!(events(&mut b, 3).is_empty(), "told once");
        let m = m.lock().unwrap();
        assert_ne!(m.session, 0, "claimed again");
        assert_eq!(m.enable, 0b11, "set up again");
    }

    #[test]
    fn a_power_cycle_between_a_polls_reads_is_not_taken_for_the_end_of_the_move() {
        let (mut b, m) = connect();
        m.lock().unwrap().steps = 300;
        let l = launch(&b, 0, 300);
        start(&mut b, l).unwrap();
        // off and on after the poll read Status and Busy: axis 0 then reads idle at 0
        m.lock().unwrap().cycle_in = Some(2);
        let ev = events(&mut b, 1);
        assert!(
            matches!(&ev[..], [(0, PinEvent::Lost { why }), (1, PinEvent::Lost { .. })]
                if why.contains("mid-move")),
            "{ev:?}"
        );
    }

    #[test]
    fn a_start_whose_outcome_stays_unknown_untrusts_its_axes() {
        let (mut b, m) = connect();
        m.lock().unwrap().steps = 300;
        let l = launch(&b, 1, 300);
        m.lock().unwrap().mute = Some(Reg::Board(BoardReg::Start).addr());
        let outcome = m.lock().unwrap().starts;
        assert!(start(&mut b, l).is_err());
        assert_eq!(m.lock().unwrap().starts, outcome + 1, "it did start");
        m.lock().unwrap().mute = None;
        std::thread::sleep(RECONNECT_PERIOD);
        let ev = events(&mut b, 1);
        assert!(
            matches!(&ev[..], [(1, PinEvent::Lost { why })] if why.contains("may or may not")),
            "{ev:?}"
        );
    }
}

#[cfg(test)]
mod track_feed;

#[cfg(test)]
mod preempt;

#[cfg(test)]
mod link_status;
