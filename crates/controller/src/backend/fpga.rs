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
//! On a board with replay units (`ms_replay`) every other move — any family, non-whole
//! speeds, more pieces than slots once split to the tick width — and tracking run
//! streamed: the host codes the exact edges of `plan` (or of the tracker) and keeps each
//! axis's buffer fed from the poll loop ([`stream::Feed`]).

mod stream;

use super::{BoardBackend, Launch, LinkState, PinEvent, SyncLine, SyncState, Tracking};
use crate::axis::AxisSettings;
use crate::clock_rate::Reading;
use crate::error::CtlError;
use crate::hall::FilteredEdge;
use crate::motion::{EdgeSource, StepSource};
use crate::tracking::TrackSource;
use multistep_core::int::{IntClock, IntProfile, IntSegment};
use multistep_core::MoveSpec;
use multistep_link::chain::{ChainedMove, CHAIN_LAYOUT};
use multistep_link::{
    self as link, core_addr, status_bits, AxisReg, BoardReg, HostLink, LinkError, Reg, Status,
};
use multistep_link::{AxisMove, CoreParams};
use stream::Feed;

use std::collections::VecDeque;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

mod readback;
mod session;
mod sync;
mod ticks;
use crate::store::LinkSession;
pub use session::{SessionKeeper, ARM_LIFETIME};

mod connect;
mod load;
mod poll;
mod roll;
mod spec;
#[cfg(test)]
use load::halts_within_amax;
use load::{check_streamable, NO_REPLAY};
pub use spec::*;
use stream::pump;

struct Running {
    dir: i64,
    stop_on_sensor: Option<bool>,
    stopping: bool,
    end_tick: u64,
    /// Steps of the stop ramp loaded for a Hall stop.
    ramp_steps: u64,
    /// What a periodic axis's count was shifted by in wraps (whole periods) while it runs,
    /// not yet in the kept session: one durable write (an fsync) per wrap would be a
    /// busy disk's every few seconds while the axis tracks. Kept once the axis rests.
    wraps: i64,
    /// A computed move of more pieces than slots: the pieces still to load.
    roll: Option<roll::Roll>,
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
    /// A durable write runs beside the thread that feeds the streams (`fed_during`).
    writing: bool,
    /// The board kept the stored session: its counts and motions are this host's.
    adopted: bool,
    /// The axes of a group armed for the SYNC line, and since when.
    armed: u32,
    armed_at: Option<Instant>,
    arm_lifetime: Duration,
    /// The board's registers are set up at the next poll (an adopted board: once every
    /// axis's settings are known, so no running axis's DIR level changes meanwhile).
    setup_due: bool,
    /// The board was found reset and claimed, but its registers are not all set up again
    /// (the link failed part way): done at the next poll, and before any start.
    reclaim: bool,
    /// Set while a halt waits for the board: a poll lets go of the link (see `HostLink`).
    urgent: Option<Arc<AtomicBool>>,
    /// Idle axes whose offset is folded into the board's counter at the next poll (an
    /// adopted board's: once its session can be kept), and a fold under way.
    fold_due: u32,
    folding: Option<crate::store::Fold>,
    /// The board's count read against host time (ticks.rs).
    ticks: ticks::TickReader,
    /// How often the board was seen to lose its state (its session changed).
    session_changes: u64,
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
    fn plan_datapath(
        &self,
        spec: &MoveSpec,
        clock_hz: f64,
    ) -> Result<Option<IntProfile>, CtlError> {
        let mv = spec.resolve()?;
        let computed = link::int_profile(&mv, clock_hz as u64).and_then(|ip| {
            self.computed(&ip, true, None)
                .map(|_| ip)
                .map_err(LinkError::Move)
        });
        match computed {
            Ok(ip) => Ok(Some(ip)),
            Err(_) if self.streams => {
                check_streamable(&mv, clock_hz, self.params.tick_bits)?;
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
        self.finish_claim()?;
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
        // fed by the host: streams, and moves loaded while they run (a host restarted
        // mid-way halts them: the rest is lost with it)
        let streamed = feeds.iter().map(|(i, _)| 1u32 << i).sum();
        let rolled = (runs.iter())
            .filter(|(_, r)| r.roll.is_some())
            .map(|(i, _)| 1u32 << i)
            .sum();
        self.keep_session_with(streamed, rolled, if self.arming { mask } else { 0 });
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
        self.finish_claim()?;
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
        self.keep_session_with(1 << axis, 0, 0);
        self.send_start(writes, &mut feeds, 1 << axis)?;
        let [(_, feed)] = feeds;
        let ax = &mut self.axes[axis];
        ax.running = Some(Running {
            dir,
            stop_on_sensor: None,
            stopping: false,
            end_tick,
            ramp_steps: 0,
            wraps: 0,
            roll: None,
        });
        ax.late_told = false;
        ax.feed = Some(feed);
        Ok(start)
    }

    fn tracking(&mut self) -> Result<&mut dyn Tracking, CtlError> {
        if self.streams {
            Ok(self)
        } else {
            Err(CtlError::Unsupported(format!(
                "tracking is not supported on {} ({NO_REPLAY})",
                self.name
            )))
        }
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
        if self.axes[axis].running.is_some() {
            // the counter runs (and is not writable): the host shifts its reading
            self.shift_reading(axis, delta);
            self.keep_session_now();
            return Ok(());
        }
        if self.axes[axis].offset != 0 {
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

    fn during_write(&mut self, write: &mut (dyn FnMut() + Send)) {
        self.fed_during(write);
    }

    fn wrap(&mut self, axis: usize, delta: i64) -> Result<(), CtlError> {
        match self.axes[axis].running.as_mut() {
            Some(run) => {
                run.wraps += delta;
                self.shift_reading(axis, delta);
                Ok(())
            }
            None => self.rebase(axis, delta, true),
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

    fn sync_line(&mut self) -> Result<&mut dyn SyncLine, CtlError> {
        Ok(self)
    }
    fn keep_session(&mut self, keep: SessionKeeper) {
        self.keep = Some(keep);
        self.kept = None;
        self.keep_session_now();
    }
    fn adopted(&self) -> bool {
        self.adopted
    }
    fn tick_reading(&mut self) -> Option<(Reading, bool)> {
        self.read_ticks()
    }

    fn adopted_motion(&self, axis: usize) -> Option<i64> {
        let r = self.axes[axis].running.as_ref()?;
        (r.end_tick == session::UNKNOWN_END).then_some(r.dir)
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod model;

#[cfg(test)]
mod exactly_once;

#[cfg(test)]
mod track_feed;

#[cfg(test)]
mod preempt;

#[cfg(test)]
mod link_status;

impl SyncLine for FpgaBackend {
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

impl Tracking for FpgaBackend {
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
}
