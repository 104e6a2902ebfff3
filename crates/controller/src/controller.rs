//! The board running in real time: a ticker thread advances the simulation along the
//! edge timeline at wall-clock rate × time scale, and every front end (line protocol,
//! host tools, a future web page) goes through [`Controller`]'s methods.

use crate::axis::AxisStatus;
use crate::backend::BoardBackend;
use crate::board::{Board, Halted, PlannedAxis};
use crate::clock_rate::Reading;
use crate::config::BoardConfig;
use crate::domain::{Amount, MoveOpts};
use crate::error::CtlError;
use crate::mount::{Mount, MountConfig, MountError};
use crate::pool::{Lane, WorkPool};
use crate::protocol::{self, Command, Reply};
use crate::store::Store;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, OnceLock, TryLockError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

mod commands;
mod halts;

use halts::{HaltKind, Halts};

/// Board ticks since start-up: wall time × time scale × clock.
#[derive(Clone, Copy, Debug)]
struct SimClock {
    t0: Instant,
    ticks_per_s: f64,
}

impl SimClock {
    fn now(&self) -> u64 {
        (self.t0.elapsed().as_secs_f64() * self.ticks_per_s) as u64
    }

    /// A simulated board's counter read now, stamped with host time (wall time × time
    /// scale): read and answered at once.
    fn reading(&self, time_scale: f64) -> Reading {
        let t = self.t0.elapsed().as_secs_f64();
        let host = (t * time_scale * 1e9) as u64;
        Reading {
            sent_ns: host,
            recv_ns: host,
            tick: (t * self.ticks_per_s) as u64,
        }
    }
}

/// How often the host reads a simulated board's counter (host time).
pub const CLOCK_READ_PERIOD: Duration = Duration::from_secs(1);

/// Most simulation work (steps plus sensor events) one lock of the board may do: a few
/// milliseconds. Past it the simulated clock falls behind, and no command waits long.
pub const WORK_BUDGET: u64 = 100_000;

/// How often the simulated mechanics of moving axes are written down (wall time).
pub const SIM_SAVE_PERIOD: Duration = Duration::from_millis(50);

/// The time scales a simulated board runs at. At the lower end a board on the slowest
/// clock (1000 Hz) still ticks once a wall-clock second; slower, a board looks frozen (a
/// stop of a second's deceleration would take over 16 minutes).
pub const TIME_SCALE_RANGE: (f64, f64) = (1e-3, 1e4);

/// Checks a time scale against [`TIME_SCALE_RANGE`].
pub fn check_time_scale(time_scale: f64) -> Result<(), CtlError> {
    let (lo, hi) = TIME_SCALE_RANGE;
    if (lo..=hi).contains(&time_scale) {
        Ok(())
    } else {
        Err(CtlError::Setting(format!(
            "time scale must be in [{lo}, {hi}] (got {time_scale})"
        )))
    }
}

/// The board and what is asked of it without its lock.
struct Shared {
    board: Mutex<Board>,
    halts: Halts,
    /// A board with a link: its status as each holder of the board left it, answered by
    /// `status` without the board's lock, which a link exchange may hold for long (a
    /// faulty link's retransmissions and timeouts). `None` for other boards.
    seen: Option<Mutex<Seen>>,
}

/// Every axis's status as the last holder of the board left it.
struct Seen {
    all: Vec<AxisStatus>,
    at: Instant,
}

impl Seen {
    /// The axes `axes` (names, else numbers; all when empty), their ages as of now.
    fn pick(&self, axes: &[String]) -> Result<Vec<AxisStatus>, CtlError> {
        let later = self.at.elapsed().as_millis() as u64;
        let one = |w: &String| {
            self.all
                .iter()
                .find(|s| &s.axis == w)
                .or_else(|| {
                    self.all
                        .iter()
                        .find(|s| crate::board::axis_number(w) == Some(s.number))
                })
                .cloned()
                .ok_or_else(|| CtlError::UnknownAxis(w.clone()))
        };
        let mut v = if axes.is_empty() {
            self.all.clone()
        } else {
            axes.iter().map(one).collect::<Result<Vec<_>, _>>()?
        };
        for s in &mut v {
            s.age_ms = s.age_ms.map(|a| a + later);
        }
        Ok(v)
    }
}

/// The board locked. Halts asked for meanwhile are applied when it is let go, by the
/// holder itself: no hand-over to the asker's thread, which may not be scheduled soon.
struct Locked<'a> {
    board: MutexGuard<'a, Board>,
    halts: &'a Halts,
    seen: Option<&'a Mutex<Seen>>,
}

impl std::ops::Deref for Locked<'_> {
    type Target = Board;
    fn deref(&self) -> &Board {
        &self.board
    }
}

impl std::ops::DerefMut for Locked<'_> {
    fn deref_mut(&mut self) -> &mut Board {
        &mut self.board
    }
}

impl Drop for Locked<'_> {
    fn drop(&mut self) {
        self.halts.apply(&mut self.board);
        if let Some(seen) = self.seen {
            publish(seen, &self.board);
        }
    }
}

/// Keeps the board's status for `status` (see [`Shared::seen`]).
fn publish(seen: &Mutex<Seen>, b: &Board) {
    if let Ok(all) = b.status_now(&[]) {
        *seen.lock().unwrap_or_else(|p| p.into_inner()) = Seen {
            all,
            at: Instant::now(),
        };
    }
}

impl Shared {
    /// The board, with every halt asked for so far applied.
    fn lock(&self) -> Locked<'_> {
        let mut b = lock(&self.board);
        self.halts.apply(&mut b);
        self.halts.record(&mut b);
        Locked {
            board: b,
            halts: &self.halts,
            seen: self.seen.as_ref(),
        }
    }

    /// [`Shared::lock`] if the board is free within `wait`, else `None`.
    fn lock_within(&self, wait: Duration) -> Option<Locked<'_>> {
        let deadline = Instant::now() + wait;
        let mut b = loop {
            match self.board.try_lock() {
                Ok(b) => break b,
                Err(TryLockError::Poisoned(p)) => break p.into_inner(),
                Err(TryLockError::WouldBlock) if Instant::now() >= deadline => return None,
                Err(TryLockError::WouldBlock) => std::thread::sleep(HALT_RETRY),
            }
        };
        self.halts.apply(&mut b);
        self.halts.record(&mut b);
        Some(Locked {
            board: b,
            halts: &self.halts,
            seen: self.seen.as_ref(),
        })
    }

    /// Asks for a halt at tick `at` and waits until it is applied: by this thread as soon
    /// as the board is free, or by whichever thread holds it, when that one lets go.
    fn halt(&self, kind: HaltKind, at: u64) -> Result<(), CtlError> {
        let ticket = self.halts.ask(kind, at);
        loop {
            let mut q = self.halts.queue();
            if let Some(r) = q.done.remove(&ticket) {
                return r;
            }
            let board = match self.board.try_lock() {
                Ok(b) => Some(b),
                Err(TryLockError::Poisoned(p)) => Some(p.into_inner()),
                Err(TryLockError::WouldBlock) => None,
            };
            match board {
                Some(mut b) => {
                    drop(q);
                    self.halts.apply(&mut b);
                    if let Some(seen) = &self.seen {
                        publish(seen, &b);
                    }
                }
                // Woken when a holder applies it; the timeout retries the lock in case
                // the holder let go without locking again.
                None => drop(
                    self.halts
                        .applied
                        .wait_timeout(q, HALT_RETRY)
                        .unwrap_or_else(|p| p.into_inner()),
                ),
            }
        }
    }
}

/// How long `status` of a board over a link waits for the board before it answers from
/// the board as last left ([`Shared::seen`]).
const STATUS_WAIT: Duration = Duration::from_millis(100);

/// How often a waiting halt tries the board lock again.
const HALT_RETRY: Duration = Duration::from_micros(200);

pub struct Controller {
    shared: Arc<Shared>,
    clock: SimClock,
    /// The board's clock (ticks per board second).
    clock_hz: f64,
    time_scale: f64,
    quit: Arc<AtomicBool>,
    ticker: Option<JoinHandle<()>>,
    /// Where groups and previews are timed (see [`WorkPool`]).
    pool: WorkPool,
    /// The config's `[alpaca]` section as JSON, answered by `devices`.
    devices: String,
    /// The board's telescope mounts, opened once and shared by every protocol that
    /// drives them (see [`Controller::attach_mounts`]).
    mounts: OnceLock<Vec<Arc<Mount>>>,
}

impl Controller {
    /// Opens the board's store in `data` and starts its clock (on simulated pins).
    #[cfg(feature = "sim")]
    pub fn open(
        config: &BoardConfig,
        data: &std::path::Path,
        time_scale: f64,
    ) -> Result<Controller, CtlError> {
        check_time_scale(time_scale)?;
        Controller::open_store(config, Store::open(data)?, time_scale)
    }

    /// Runs the board on an already opened store (see [`Store::open_or_reset`]), on
    /// simulated pins.
    #[cfg(feature = "sim")]
    pub fn open_store(
        config: &BoardConfig,
        store: Store,
        time_scale: f64,
    ) -> Result<Controller, CtlError> {
        let mut sim = crate::backend::SimBackend::new(config.board.clock_hz, config.axes.len());
        if let Some(line) = &config.board.sync_line {
            crate::backend::check_line_path(line, store.dir())?;
            sim = sim.with_sync_line(line, config.board.clock_hz * time_scale);
        }
        Controller::open_backend(config, store, time_scale, Box::new(sim))
    }

    /// A simulated board whose crystal is `ppm` off (in [`crate::clock_rate::PPM_RANGE`]):
    /// its ticks come `clock·(1 + ppm·10⁻⁶)` a host second (its SYNC line's falls too).
    /// The host reads its counter every [`CLOCK_READ_PERIOD`] and corrects tracking by
    /// the fit (see [`Board::clock_reading`]).
    #[cfg(feature = "sim")]
    pub fn open_sim(
        config: &BoardConfig,
        store: Store,
        time_scale: f64,
        ppm: f64,
    ) -> Result<Controller, CtlError> {
        check_time_scale(time_scale)?;
        crate::clock_rate::check_ppm(ppm)?;
        let crystal = 1.0 + ppm * 1e-6;
        let mut sim = crate::backend::SimBackend::new(config.board.clock_hz, config.axes.len());
        if let Some(line) = &config.board.sync_line {
            crate::backend::check_line_path(line, store.dir())?;
            sim = sim.with_sync_line(line, config.board.clock_hz * time_scale * crystal);
        }
        Controller::open_pins(config, store, time_scale, Box::new(sim), Some(crystal))
    }

    /// Runs the board on the given pins; hardware runs in real time (time scale 1).
    pub fn open_backend(
        config: &BoardConfig,
        store: Store,
        time_scale: f64,
        pins: Box<dyn BoardBackend>,
    ) -> Result<Controller, CtlError> {
        Controller::open_pins(config, store, time_scale, pins, None)
    }

    /// [`Controller::open_backend`]; `crystal`: a simulated board's ticks per nominal
    /// tick, whose counter the host reads.
    fn open_pins(
        config: &BoardConfig,
        store: Store,
        time_scale: f64,
        pins: Box<dyn BoardBackend>,
        crystal: Option<f64>,
    ) -> Result<Controller, CtlError> {
        check_time_scale(time_scale)?;
        if pins.clock_hz().is_some() && time_scale != 1.0 {
            return Err(CtlError::Setting(format!(
                "a real board runs in real time: time scale 1 (got {time_scale})"
            )));
        }
        let devices = serde_json::to_string(&config.alpaca.clone().unwrap_or_default())?;
        let mut board = Board::open_with(config, store, pins)?;
        // Stored values brought into range, said once at start-up (and kept for `info`).
        for w in board.warnings() {
            eprintln!("warning: {w}");
        }
        board.set_work_budget(Some(WORK_BUDGET));
        let clock = SimClock {
            t0: Instant::now(),
            ticks_per_s: board.clock_hz() * time_scale * crystal.unwrap_or(1.0),
        };
        let clock_hz = board.clock_hz();
        let halts = Halts::default();
        board.set_halt_tick(halts.tick.clone());
        board.set_halt_flag(halts.pending.clone());
        // advanced once, so what the board said at open (an adopted motion halted, a
        // share disarmed) is in the first status
        let seen = board.has_link().then(|| {
            Mutex::new(Seen {
                all: board.status(&[], clock.now()).unwrap_or_default(),
                at: Instant::now(),
            })
        });
        let shared = Arc::new(Shared {
            board: Mutex::new(board),
            halts,
            seen,
        });
        let quit = Arc::new(AtomicBool::new(false));
        let ticker = {
            let (shared, quit) = (shared.clone(), quit.clone());
            std::thread::Builder::new()
                .name("board-ticker".into())
                .spawn(move || {
                    let mut saved = Instant::now();
                    let mut read: Option<Instant> = None;
                    let read_every = CLOCK_READ_PERIOD.div_f64(time_scale);
                    while !quit.load(Ordering::Relaxed) {
                        std::thread::sleep(Duration::from_millis(1));
                        let mut b = shared.lock();
                        if read.is_none_or(|r| r.elapsed() >= read_every) {
                            read = Some(Instant::now());
                            if crystal.is_some() {
                                // in order, each once: the fit cannot refuse it
                                let _ = b.clock_reading(clock.reading(time_scale));
                            } else if b.has_link() {
                                // an FPGA board's own count, stamped with host time
                                b.read_clock();
                            }
                        }
                        if b.needs_polling() {
                            b.advance(clock.now());
                            if saved.elapsed() >= SIM_SAVE_PERIOD && b.is_simulated() {
                                b.save_sim();
                                saved = Instant::now();
                            }
                        }
                    }
                })
                .map_err(|e| CtlError::Io(e.to_string()))?
        };
        Ok(Controller {
            shared,
            clock,
            clock_hz,
            time_scale,
            quit,
            ticker: Some(ticker),
            pool: WorkPool::for_this_machine()?,
            devices,
            mounts: OnceLock::new(),
        })
    }

    /// Opens the mounts of `cfgs` (each checked against the board already), starts the
    /// thread that looks after each, and keeps them for the `mount` command; the first is
    /// the one `mount` drives. Once per controller: later calls find the mounts already
    /// open and return those.
    pub fn attach_mounts(
        self: &Arc<Self>,
        cfgs: &[MountConfig],
    ) -> Result<Vec<Arc<Mount>>, MountError> {
        if let Some(m) = self.mounts.get() {
            return Ok(m.clone());
        }
        let mut mounts = Vec::new();
        for c in cfgs {
            let m = Arc::new(Mount::open(c.clone(), self)?);
            Mount::supervise(&m, self.clone()).map_err(|e| CtlError::Io(e.to_string()))?;
            mounts.push(m);
        }
        Ok(self.mounts.get_or_init(|| mounts).clone())
    }

    /// The mounts [`Controller::attach_mounts`] opened (none before).
    pub fn mounts(&self) -> &[Arc<Mount>] {
        self.mounts.get().map_or(&[], Vec::as_slice)
    }

    /// Board tick now.
    pub fn now(&self) -> u64 {
        self.clock.now()
    }

    /// The board's clock rate (Hz).
    pub fn clock_hz(&self) -> f64 {
        self.clock_hz
    }

    /// Runs `f` on the board at the current tick. The board is locked meanwhile: `f`
    /// should be quick (a `stop` or `estop` asked for meanwhile waits for it to return).
    pub fn with_board<R>(&self, f: impl FnOnce(&mut Board, u64) -> R) -> R {
        let mut b = self.shared.lock();
        let now = self.clock.now();
        f(&mut b, now)
    }

    /// What `group_move(targets, absolute, sync, opts)` would run from the counted
    /// positions now, without starting anything (see [`Board::preview`]). Only the
    /// planning holds the board; the TDM timing runs with the board free, in the timing
    /// pool behind any move waiting there (`error:23` when its queue is full).
    pub fn preview(
        &self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
    ) -> Result<Vec<PlannedAxis>, CtlError> {
        let plan = self.with_board(|b, _| b.plan_preview(targets, absolute, sync, opts))?;
        self.pool.run(Lane::Preview, move || plan.time())?
    }

    /// When the last e-stop was applied to the board (on the FPGA board: its write).
    pub fn last_estop_applied(&self) -> Option<Instant> {
        *self
            .shared
            .halts
            .estop_applied
            .lock()
            .unwrap_or_else(|p| p.into_inner())
    }

    /// Each axis's status. A board with a link is read now if it is free within
    /// [`STATUS_WAIT`]; behind a longer link exchange (a faulty link's retries and
    /// timeouts) `status` answers from the board as its last holder left it, and `age_ms`
    /// says how old that is.
    pub fn status(&self, axes: &[String]) -> Result<Vec<AxisStatus>, CtlError> {
        let Some(seen) = &self.shared.seen else {
            return self.with_board(|b, now| b.status(axes, now));
        };
        // the board read now when it is free soon (a poll's exchange takes milliseconds);
        // behind a longer exchange, as last left
        match self.shared.lock_within(STATUS_WAIT) {
            Some(mut b) => b.status(axes, self.clock.now()),
            None => seen.lock().unwrap_or_else(|p| p.into_inner()).pick(axes),
        }
    }
    pub fn move_axis(
        &self,
        axis: &str,
        amount: Amount,
        absolute: bool,
        opts: &MoveOpts,
    ) -> Result<i64, CtlError> {
        self.group_move(&[(axis.to_string(), amount)], absolute, false, opts)
            .map(|t| t[0])
    }
    pub fn group_move(
        &self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
    ) -> Result<Vec<i64>, CtlError> {
        self.group_move_or_arm(targets, absolute, sync, opts, false)
    }

    /// A group started now, or (`arm`) armed for the SYNC line's fall.
    fn group_move_or_arm(
        &self,
        targets: &[(String, Amount)],
        absolute: bool,
        sync: bool,
        opts: &MoveOpts,
        arm: bool,
    ) -> Result<Vec<i64>, CtlError> {
        // The TDM timing runs with the board free, in the timing pool: estop and other
        // clients do not wait on it.
        // If another client's move ran on these axes meanwhile, plan again from where they
        // are now (planning refuses at once while they still move).
        if arm {
            self.with_board(|b, _| b.check_sync())?;
        }
        let mut tries = 0;
        loop {
            let pending =
                self.with_board(|b, now| b.plan_group_move(targets, absolute, sync, opts, now))?;
            // timed in the pool, ahead of previews
            let (pending, report) = self.pool.run(Lane::Move, move || {
                let r = pending.time();
                (pending, r)
            })?;
            let report = report?;
            let started = self.with_board(|b, now| {
                if arm {
                    b.arm_group_move(pending, now)
                } else {
                    b.start_group_move(pending, report.as_ref(), now)
                }
            });
            match started {
                Err(CtlError::Busy { .. }) if tries < 3 => tries += 1,
                other => return other,
            }
        }
    }
    pub fn home(&self, axis: &str) -> Result<(), CtlError> {
        self.with_board(|b, now| b.home(axis, now))
    }
    /// Controlled stop of one axis or all, from the tick it is asked at; it does not wait
    /// behind other clients' work on the board.
    pub fn stop(&self, axis: Option<&str>) -> Result<(), CtlError> {
        let kind = HaltKind::Stop(axis.map(str::to_string));
        self.shared.halt(kind, self.clock.now())
    }
    /// Emergency stop at the tick it is asked at: applied by whoever holds the board
    /// next, before anything else.
    pub fn estop(&self) {
        let _ = self.shared.halt(HaltKind::EStop, self.clock.now());
    }
    pub fn reset(&self) {
        self.with_board(|b, now| b.reset(now))
    }

    /// Parses and runs one received line.
    pub fn execute_bytes(&self, line: &[u8]) -> Reply {
        match protocol::parse_bytes(line) {
            Ok(cmd) => self.execute(&cmd),
            Err(e) => Reply::err(e),
        }
    }

    /// Runs one command: the single place where protocol words meet the board.
    pub fn execute(&self, cmd: &Command) -> Reply {
        Reply::from_result(self.run(cmd))
    }
}

/// A poisoned lock means a thread panicked mid-update; the board data is still the best
/// there is, so carry on rather than take the service down.
fn lock(b: &Mutex<Board>) -> MutexGuard<'_, Board> {
    b.lock().unwrap_or_else(|p| p.into_inner())
}

impl Drop for Controller {
    fn drop(&mut self) {
        self.quit.store(true, Ordering::Relaxed);
        if let Some(t) = self.ticker.take() {
            let _ = t.join();
        }
    }
}
