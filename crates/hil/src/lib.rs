//! multistep-hil: hardware in the loop on one machine. The board's real top level
//! (`ms_board`, with the parameters `multistep hdl build` uses for the board) runs in
//! Verilator ([`multistep_hdl::verilator`]); its UART is a pseudo-terminal a host opens
//! as a serial port; its STEP / DIR / ENABLE outputs drive simulated motors and its Hall
//! inputs come from simulated sensors ([`axis`]).
//!
//! Time runs as fast as the simulation goes while anything happens (an axis busy or
//! settling, a byte on either UART line, an input within its debounce time). When the
//! board is idle and no byte is in flight, simulated time stops until the host sends
//! something: the board cannot tell, since nothing in it changes while it waits.

pub mod axis;
pub mod fault;
pub mod multi;
pub mod proxy;
pub mod pty;
pub mod uart;

pub use axis::PinLevels;
use axis::{AxisReport, SimAxis};
pub use fault::{CorruptReply, CorruptRx};
use multistep_hdl::boards::Board;
use multistep_hdl::verilator::{default_cache_dir, watch, Inputs, VerilatedBoard};
use multistep_hdl::{BoardTop, HdlError};
use multistep_sim::hall::SensorSettings;
use multistep_sim::integrate::Incremental;
use multistep_sim::{Motor, SimConfig};
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// What can go wrong starting a simulation.
#[derive(Debug, thiserror::Error)]
pub enum HilError {
    #[error(transparent)]
    Hdl(#[from] HdlError),
    #[error("motor: {0}")]
    Motor(#[from] multistep_sim::SimError),
    #[error("{0}")]
    Setting(String),
    #[error("{what}: {source}")]
    Io {
        what: String,
        source: std::io::Error,
    },
    #[error("the simulation has stopped")]
    Stopped,
}

/// The Hall sensor of one axis, in the controller's `sim.*` terms (seconds, microsteps).
#[derive(Clone, Debug, PartialEq)]
pub struct SensorOptions {
    pub sensor_at: i64,
    pub sensor_width: u64,
    pub home_dir: i8,
    pub period: Option<u64>,
    pub bounce_count: u32,
    pub bounce_time: f64,
    pub glitch_rate: f64,
    pub glitch_max: f64,
    pub glitch_gap: f64,
    pub seed: u64,
}

impl Default for SensorOptions {
    /// The controller's defaults: a 400-microstep window at 0, homing towards −.
    fn default() -> Self {
        SensorOptions {
            sensor_at: 0,
            sensor_width: 400,
            home_dir: -1,
            period: None,
            bounce_count: 0,
            bounce_time: 0.0002,
            glitch_rate: 0.0,
            glitch_max: 0.0005,
            glitch_gap: 0.005,
            seed: 1,
        }
    }
}

impl SensorOptions {
    fn settings(&self, clock_hz: f64) -> SensorSettings {
        SensorSettings::from_seconds(
            self.sensor_at,
            self.sensor_width,
            self.home_dir,
            self.period,
            self.bounce_count,
            self.bounce_time,
            self.glitch_rate,
            self.glitch_max,
            self.glitch_gap,
            self.seed,
            clock_hz,
        )
    }
}

/// How to run a board.
#[derive(Clone, Debug)]
pub struct Options {
    /// A board of `multistep hdl boards`.
    pub board: String,
    /// Axes (default: the board's `hdl build` default).
    pub axes: Option<u32>,
    /// UART baud (default: the board's).
    pub baud: Option<u32>,
    /// A motor of `multistep-sim` by name, or a motor file.
    pub motor: String,
    pub microsteps: u32,
    /// Per axis; the last one repeats for the axes after it (empty: the defaults).
    pub sensors: Vec<SensorOptions>,
    /// Per axis, how its driver reads DIR and ENABLE; the last one repeats (empty: the
    /// board's reset levels).
    pub levels: Vec<PinLevels>,
    /// Log every STEP rise (`AXIS CYCLE`) and every group start (`# go CYCLE`) here.
    pub edges: Option<PathBuf>,
    /// Never run faster than the wall clock.
    pub realtime: bool,
    /// Where built models are kept (default [`default_cache_dir`]).
    pub cache_dir: Option<PathBuf>,
    /// The core with the per-step recurrence, its multiplier digit in bits (default: the
    /// board's choice).
    pub recurrence: Option<u32>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            board: "ulx3s-25f".into(),
            axes: None,
            baud: None,
            motor: "42mm".into(),
            microsteps: 16,
            sensors: Vec::new(),
            levels: Vec::new(),
            edges: None,
            realtime: false,
            cache_dir: None,
            recurrence: None,
        }
    }
}

/// `state`: the simulation's time and every axis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SimState {
    /// Clock cycles since the start.
    pub ticks: u64,
    pub seconds: f64,
    pub clock_hz: f64,
    /// The board is at work (an axis running, a frame in flight, a sensor settling): its
    /// time passes. An idle board's time stands still until the host says something.
    pub busy: bool,
    pub estop: bool,
    pub cut: bool,
    /// Bytes the host has sent the board over the link since the start.
    pub host_bytes: u64,
    /// The cycle at which an ENABLE pin last changed (0: none yet). The e-stop drops every
    /// ENABLE a clock after it latches (`Levels` bit 5, set at reset), so after an e-stop
    /// this is when the board took it: the `Estop` write's arrival, or the input.
    pub enable_changed: u64,
    pub axes: Vec<AxisReport>,
}

enum Control {
    Estop(bool),
    Reset,
    Cut(bool),
    Slip(usize, i64),
    Glitch(usize),
    Corrupt(CorruptReply),
    CorruptRx(CorruptRx),
    PowerCycle,
    State(mpsc::Sender<SimState>),
    Quit,
}

/// A running simulation: the pty's path and the controls. Dropping it stops it.
pub struct BoardSim {
    pub pty_path: String,
    pub board: BoardTop,
    /// A clock cycle is the model's NBA region called directly, not `eval` on both edges
    /// ([`multistep_hdl::verilator::posedge`]).
    pub direct: bool,
    /// The model was built with the profile of its training run (GCC's profile-guided
    /// optimization: about a fifth less CPU time per simulated second).
    pub trained: bool,
    tx: mpsc::Sender<Control>,
    thread: Option<std::thread::JoinHandle<Result<(), HilError>>>,
}

/// How often (simulated seconds) a busy board looks for host bytes and controls at least.
const LISTEN_S: f64 = 100e-6;
/// Cycles the reset pin is held low by `reset`.
const RESET_CYCLES: u64 = 8;
/// Cycles after power-on before the host is let in (the board's own power-on reset).
const POWER_ON_CYCLES: u64 = 64;

impl BoardSim {
    /// Builds (or loads from the cache) the board's model and starts it in a thread.
    pub fn start(opts: &Options) -> Result<BoardSim, HilError> {
        let (mut world, top) = World::new(opts)?;
        let pty_path = world.pty.path.clone();
        let direct = world.model.direct();
        let trained = world.model.trained();
        let (tx, rx) = mpsc::channel();
        world.power_on();
        let thread = std::thread::Builder::new()
            .name("board-sim".into())
            .spawn(move || world.run(rx))
            .map_err(|e| HilError::Io {
                what: "thread".into(),
                source: e,
            })?;
        Ok(BoardSim {
            pty_path,
            board: top,
            direct,
            trained,
            tx,
            thread: Some(thread),
        })
    }

    fn send(&self, c: Control) -> Result<(), HilError> {
        self.tx.send(c).map_err(|_| HilError::Stopped)
    }

    /// The e-stop input: true = active (pressed).
    pub fn estop(&self, on: bool) -> Result<(), HilError> {
        self.send(Control::Estop(on))
    }
    /// Pulses the external reset.
    pub fn reset(&self) -> Result<(), HilError> {
        self.send(Control::Reset)
    }
    /// The link drops every byte both ways.
    pub fn cut(&self) -> Result<(), HilError> {
        self.send(Control::Cut(true))
    }
    pub fn restore(&self) -> Result<(), HilError> {
        self.send(Control::Cut(false))
    }
    /// The mechanics of `axis` jump by `microsteps`.
    pub fn slip(&self, axis: usize, microsteps: i64) -> Result<(), HilError> {
        self.check_axis(axis)?;
        self.send(Control::Slip(axis, microsteps))
    }
    /// One Hall glitch on `axis` now, half the debounce time long.
    pub fn glitch(&self, axis: usize) -> Result<(), HilError> {
        self.check_axis(axis)?;
        self.send(Control::Glitch(axis))
    }
    /// Switches the board off and on: a fresh model, every register at its power-up
    /// value (the motors keep their positions).
    pub fn power_cycle(&self) -> Result<(), HilError> {
        self.send(Control::PowerCycle)
    }
    /// Damages the reply to the next request (or the next write to `c.addr`).
    pub fn corrupt_reply(&self, c: CorruptReply) -> Result<(), HilError> {
        self.send(Control::Corrupt(c))
    }
    /// Damages a byte of the host's next request (or of the next write to `c.addr`).
    pub fn corrupt_rx(&self, c: CorruptRx) -> Result<(), HilError> {
        self.send(Control::CorruptRx(c))
    }
    pub fn state(&self) -> Result<SimState, HilError> {
        let (tx, rx) = mpsc::channel();
        self.send(Control::State(tx))?;
        rx.recv().map_err(|_| HilError::Stopped)
    }

    fn check_axis(&self, axis: usize) -> Result<(), HilError> {
        if axis >= self.board.core.axes as usize {
            return Err(HilError::Setting(format!(
                "axis {axis} out of range (the board has {})",
                self.board.core.axes
            )));
        }
        Ok(())
    }

    /// Stops the simulation and waits for it.
    pub fn quit(mut self) -> Result<(), HilError> {
        self.stop()
    }

    fn stop(&mut self) -> Result<(), HilError> {
        let _ = self.tx.send(Control::Quit);
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| HilError::Stopped)?,
            None => Ok(()),
        }
    }

    /// Runs one control line (`estop on|off`, `reset`, `cut`, `restore`, `slip AXIS
    /// STEPS`, `glitch AXIS`, `corrupt-reply BYTE [ADDR]`, `corrupt-rx BYTE [ADDR [TIMES]]`,
    /// `power-cycle`, `state`, `quit`); returns what
    /// to print (state: one JSON line) and whether to stop.
    pub fn command(&self, line: &str) -> Result<(Option<String>, bool), HilError> {
        match parse_command(line, self.board.core.axes as usize)? {
            Cmd::None => {}
            Cmd::Control(c) => self.send(c)?,
            Cmd::State => {
                let s = self.state()?;
                let j = serde_json::to_string(&s).map_err(|e| HilError::Setting(e.to_string()))?;
                return Ok((Some(j), false));
            }
            Cmd::Quit => return Ok((None, true)),
        }
        Ok((None, false))
    }
}

/// A control line, parsed.
enum Cmd {
    None,
    Control(Control),
    State,
    Quit,
}

fn parse_command(line: &str, axes: usize) -> Result<Cmd, HilError> {
    let w: Vec<&str> = line.split_whitespace().collect();
    let num = |i: usize| -> Result<i64, HilError> {
        w.get(i)
            .and_then(|s| s.parse().ok())
            .ok_or_else(|| HilError::Setting(format!("{line:?}: argument {i} must be an integer")))
    };
    let axis = |i: usize| -> Result<usize, HilError> {
        let a = usize::try_from(num(i)?)
            .map_err(|_| HilError::Setting(format!("{line:?}: bad axis")))?;
        if a >= axes {
            return Err(HilError::Setting(format!(
                "axis {a} out of range (the board has {axes})"
            )));
        }
        Ok(a)
    };
    Ok(match w.as_slice() {
        [] => Cmd::None,
        ["estop", "on"] => Cmd::Control(Control::Estop(true)),
        ["estop", "off"] => Cmd::Control(Control::Estop(false)),
        ["reset"] => Cmd::Control(Control::Reset),
        ["power-cycle"] => Cmd::Control(Control::PowerCycle),
        ["cut"] => Cmd::Control(Control::Cut(true)),
        ["restore"] => Cmd::Control(Control::Cut(false)),
        ["slip", _, _] => Cmd::Control(Control::Slip(axis(1)?, num(2)?)),
        ["glitch", _] => Cmd::Control(Control::Glitch(axis(1)?)),
        ["corrupt-reply", byte, rest @ ..] if rest.len() <= 1 => {
            let byte = byte
                .parse::<usize>()
                .ok()
                .filter(|&b| b < multistep_hdl::link::REPLY_LEN)
                .ok_or_else(|| HilError::Setting(format!("{line:?}: BYTE must be 0 to 8")))?;
            let addr = addr_arg(line, rest.first())?;
            Cmd::Control(Control::Corrupt(CorruptReply { byte, addr }))
        }
        ["corrupt-rx", byte, rest @ ..] if rest.len() <= 2 => {
            let addr = addr_arg(line, rest.first())?;
            let times = match rest.get(1) {
                None => 1,
                Some(t) => t.parse::<u32>().ok().filter(|t| (1..=100).contains(t)).ok_or_else(
                    || HilError::Setting(format!("{line:?}: TIMES must be 1 to 100")),
                )?,
            };
            let least = if addr.is_some() { 5 } else { 0 };
            let byte = byte
                .parse::<usize>()
                .ok()
                .filter(|&b| (least..8 + 255).contains(&b))
                .ok_or_else(|| {
                    HilError::Setting(format!("{line:?}: BYTE must be {least} to 262"))
                })?;
            Cmd::Control(Control::CorruptRx(CorruptRx { byte, addr, times }))
        }
        ["state"] => Cmd::State,
        ["quit"] => Cmd::Quit,
        _ => {
            return Err(HilError::Setting(format!(
                "unknown command {line:?} (estop on|off, reset, cut, restore, slip AXIS STEPS, glitch AXIS, corrupt-reply BYTE [ADDR], corrupt-rx BYTE [ADDR [TIMES]], power-cycle, state, quit)"
            )))
        }
    })
}

/// A control's optional register address (hex, `0x` optional).
fn addr_arg(line: &str, a: Option<&&str>) -> Result<Option<u16>, HilError> {
    a.map(|a| {
        u16::from_str_radix(a.trim_start_matches("0x"), 16)
            .map_err(|_| HilError::Setting(format!("{line:?}: ADDR is hex")))
    })
    .transpose()
}

impl Drop for BoardSim {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}

/// The simulation thread's state: the model and everything around it.
struct World {
    model: VerilatedBoard,
    /// Cycles of the models before the present one (a power cycle starts a new model).
    base: u64,
    /// Where the model came from (a power cycle loads it again).
    top: BoardTop,
    cache: PathBuf,
    /// The inputs last set on the model.
    inputs: Inputs,
    /// The e-stop input (active).
    estop: bool,
    rx_line: uart::RxLine,
    tx_dec: uart::TxDecoder,
    /// Bytes taken from the host (the link's load).
    host_bytes: u64,
    faults: fault::LinkFaults,
    pty: pty::Pty,
    axes: Vec<SimAxis>,
    edges: Option<std::io::BufWriter<std::fs::File>>,
    clock_hz: f64,
    cut: bool,
    /// The reset pin is low until this cycle.
    reset_until: u64,
    /// An input changed: run until its filter has accepted it, or never will.
    settle_until: u64,
    /// Host bytes read, not yet on the line.
    host: Vec<u8>,
    realtime: Option<Instant>,
    /// The watch word after the last run.
    last: u64,
    /// The cycle of the last ENABLE change ([`SimState::enable_changed`]).
    enable_changed: u64,
    quit: bool,
    /// The SYNC line's level (boards run together: [`multi`]).
    sync_in: bool,
}

/// While motors move, the world is stepped at least this often (cycles): the sensor sees
/// the mechanics' position at this resolution.
fn world_step(clock_hz: f64) -> u64 {
    ((clock_hz * multistep_sim::DEFAULT_DT) as u64).max(1)
}

impl World {
    /// The board's model (built or loaded from the cache), its pty and its axes.
    fn new(opts: &Options) -> Result<(World, BoardTop), HilError> {
        let b = Board::by_name(&opts.board)?;
        let mut params = b.params(opts.axes.unwrap_or(b.default_axes))?;
        if opts.recurrence.is_some() {
            params.recurrence = opts.recurrence;
        }
        // the board's own build: its stream buffers (none on the iCEBreaker) and SYNC
        let top = BoardTop {
            baud: opts.baud.unwrap_or(b.baud),
            ..b.board_top(&params)
        };
        top.widths()?;
        let clock_hz = top.core.clock_hz;
        let motor = Motor::load(&opts.motor)?;
        let mut cfg = SimConfig::for_motor(&motor);
        cfg.driver.microsteps = opts.microsteps;
        let k = top.core.axes as usize;
        let mut axes = Vec::with_capacity(k);
        for a in 0..k {
            let s = per_axis(&opts.sensors, a);
            if !(s.home_dir == 1 || s.home_dir == -1) {
                return Err(HilError::Setting(format!(
                    "home_dir must be 1 or -1, got {}",
                    s.home_dir
                )));
            }
            let m = Incremental::new(&motor, &cfg, clock_hz)?;
            let levels = per_axis(&opts.levels, a);
            axes.push(SimAxis::new(m, &s.settings(clock_hz), levels, clock_hz));
        }
        let edges = match &opts.edges {
            Some(p) => Some(std::io::BufWriter::new(std::fs::File::create(p).map_err(
                |e| HilError::Io {
                    what: p.display().to_string(),
                    source: e,
                },
            )?)),
            None => None,
        };
        let cache = opts.cache_dir.clone().unwrap_or_else(default_cache_dir);
        let model = VerilatedBoard::new(&top, &cache)?;
        let (model_top, model_cache) = (top.clone(), cache.clone());
        let pty = pty::Pty::open().map_err(|e| HilError::Io {
            what: "pseudo-terminal".into(),
            source: e,
        })?;
        let world = World {
            inputs: Inputs::default(),
            estop: false,
            rx_line: uart::RxLine::new(clock_hz, f64::from(top.baud)),
            tx_dec: uart::TxDecoder::new(top.div()),
            host_bytes: 0,
            faults: fault::LinkFaults::default(),
            model,
            base: 0,
            top: model_top,
            cache: model_cache,
            pty,
            axes,
            edges,
            clock_hz,
            cut: false,
            reset_until: 0,
            settle_until: 0,
            host: Vec::new(),
            realtime: opts.realtime.then(Instant::now),
            last: 0,
            enable_changed: 0,
            quit: false,
            sync_in: true,
        };
        Ok((world, top))
    }

    fn cycle(&self) -> u64 {
        self.base + self.model.outputs().cycle
    }

    /// Off and on: a fresh model (configuration: every register at its power-up value),
    /// its own power-on reset; a reply being sent is lost.
    fn power_cycle(&mut self) {
        let fresh = match VerilatedBoard::new(&self.top, &self.cache) {
            Ok(m) => m,
            Err(e) => {
                eprintln!("error: power-cycle: {e}");
                return;
            }
        };
        self.base = self.cycle();
        self.model = fresh;
        self.tx_dec = uart::TxDecoder::new(self.top.div());
        self.faults.resync();
        self.power_on();
    }

    fn power_on(&mut self) {
        self.model.set_inputs(&self.inputs);
        self.model.run(POWER_ON_CYCLES, 0);
        self.last = self.model.outputs().word;
    }

    fn busy(&self, cycle: u64) -> bool {
        self.model.outputs().active()
            || self.rx_line.busy()
            || self.tx_dec.busy()
            || cycle < self.reset_until
            || cycle < self.settle_until
            || self.axes.iter().any(|a| a.live(cycle))
    }

    fn control(&mut self, c: Control) {
        let cycle = self.cycle();
        match c {
            Control::Estop(on) => {
                self.estop = on;
                self.settle_until = cycle + 16;
            }
            Control::Reset => {
                self.faults.resync();
                self.reset_until = cycle + RESET_CYCLES;
                // run on past the release: the board's own reset counts 16 more clocks
                self.settle_until = self.reset_until + 32;
            }
            Control::Cut(on) => {
                self.cut = on;
                if on {
                    self.host.clear();
                    self.rx_line.clear_queue();
                    self.faults.resync();
                }
            }
            Control::Corrupt(c) => self.faults.corrupt(c),
            Control::CorruptRx(c) => self.faults.corrupt_rx(c),
            Control::PowerCycle => self.power_cycle(),
            Control::Slip(a, s) => {
                if let Some(ax) = self.axes.get_mut(a) {
                    ax.slip(cycle, s);
                }
            }
            Control::Glitch(a) => {
                let len = (self.model.outputs().debounce / 2).max(1);
                if let Some(ax) = self.axes.get_mut(a) {
                    ax.glitch(cycle, len);
                }
            }
            Control::State(tx) => {
                let _ = tx.send(self.state());
            }
            Control::Quit => self.quit = true,
        }
    }

    fn state(&self) -> SimState {
        let ticks = self.cycle();
        SimState {
            ticks,
            seconds: ticks as f64 / self.clock_hz,
            clock_hz: self.clock_hz,
            busy: self.busy(ticks),
            estop: self.estop,
            cut: self.cut,
            host_bytes: self.host_bytes,
            enable_changed: self.enable_changed,
            axes: self.axes.iter().map(SimAxis::report).collect(),
        }
    }

    fn take_host_bytes(&mut self) {
        self.pty.read_available(&mut self.host);
        if self.cut {
            self.host.clear();
        } else if !self.host.is_empty() {
            self.host_bytes += self.host.len() as u64;
            self.faults.from_host(&mut self.host);
            self.rx_line.push(&self.host);
            self.host.clear();
        }
    }

    fn run(mut self, rx: mpsc::Receiver<Control>) -> Result<(), HilError> {
        let mut iter: u32 = 0;
        let step = world_step(self.clock_hz);
        // a board busy without stepping runs up to 2^16 cycles an iteration: the host is
        // heard at least every LISTEN cycles of simulated time too, so a request waits
        // for at most that, not 64 such iterations (84 ms at 50 MHz)
        let listen = ((self.clock_hz * LISTEN_S) as u64).max(1);
        let mut heard = self.cycle();
        while !self.quit {
            let cycle = self.cycle();
            iter = iter.wrapping_add(1);
            if !self.busy(cycle) {
                // idle: time stops until the host or a control says something
                if let Some(f) = self.edges.as_mut() {
                    let _ = f.flush();
                }
                while let Ok(c) = rx.try_recv() {
                    self.control(c);
                }
                if self.quit {
                    break;
                }
                self.pty.wait_readable(2);
                self.take_host_bytes();
                if let Some(t0) = self.realtime.as_mut() {
                    // the wall clock does not wait for an idle board to catch up later
                    *t0 = Instant::now() - Duration::from_secs_f64(cycle as f64 / self.clock_hz);
                }
                continue;
            }
            if iter.is_multiple_of(64) || cycle >= heard + listen {
                heard = cycle;
                while let Ok(c) = rx.try_recv() {
                    self.control(c);
                }
                self.take_host_bytes();
                self.pace(cycle);
            }
            self.step_once(cycle, step, heard + listen);
        }
        if let Some(f) = self.edges.as_mut() {
            let _ = f.flush();
        }
        Ok(())
    }

    fn pace(&self, cycle: u64) {
        if let Some(t0) = self.realtime {
            let sim = Duration::from_secs_f64(cycle as f64 / self.clock_hz);
            let wall = t0.elapsed();
            if sim > wall {
                std::thread::sleep(sim - wall);
            }
        }
    }

    /// Sets the inputs for `cycle`, runs the model to the next event (or to cycle `cap`),
    /// handles its outputs.
    fn step_once(&mut self, cycle: u64, step: u64, cap: u64) {
        // inputs at this cycle
        let mut inp = self.inputs;
        inp.rst_n = cycle >= self.reset_until;
        inp.uart_rx = self.rx_line.level(cycle);
        let mut hall = 0u32;
        for (a, ax) in self.axes.iter_mut().enumerate() {
            ax.advance(cycle);
            hall |= u32::from(ax.hall()) << a;
        }
        inp.hall = hall;
        inp.estop = self.estop;
        inp.sync = self.sync_in;
        if inp.hall != self.inputs.hall {
            self.settle_until =
                cycle + multistep_hdl::filter_latest(self.model.outputs().debounce) + 16;
        }
        if inp != self.inputs {
            self.model.set_inputs(&inp);
            self.inputs = inp;
        }
        // the next event
        let mut until = cycle + (1 << 16);
        if self.axes.iter().any(|a| a.live(cycle)) {
            until = until.min(cycle + step);
        }
        until = until
            .min(self.rx_line.next_change(cycle))
            .min(self.tx_dec.deadline());
        for ax in &self.axes {
            until = until.min(ax.next_noise().max(cycle + 1));
        }
        if self.reset_until > cycle {
            until = until.min(self.reset_until);
        }
        if self.settle_until > cycle {
            until = until.min(self.settle_until);
        }
        let until = until.min(cap).max(cycle + 1);
        let mask =
            watch::STEP | watch::DIR | watch::ENABLE | watch::UART_TX | watch::GO | watch::SYNC_OE;
        self.model.run(until - cycle, mask);
        let out = self.model.outputs();
        let now = self.base + out.cycle;
        let changed = out.word ^ self.last;
        self.last = out.word;
        if changed & watch::UART_TX != 0 {
            if let Some(b) = self.tx_dec.change(now, out.uart_tx()) {
                self.send_to_host(b);
            }
        }
        if let Some(b) = self.tx_dec.poll(now) {
            self.send_to_host(b);
        }
        if changed & watch::GO != 0 && out.go() {
            // go is sampled at the next clock edge: that edge is the move's tick 0
            if let Some(f) = self.edges.as_mut() {
                let _ = writeln!(f, "# go {}", now + 1);
            }
        }
        if changed & watch::ENABLE != 0 {
            self.enable_changed = now;
        }
        let (step_pins, dir_pins, en_pins) = (out.step(), out.dir(), out.enable());
        for (a, ax) in self.axes.iter_mut().enumerate() {
            ax.pins(dir_pins >> a & 1 == 1, en_pins >> a & 1 == 1);
            let rose = (changed & watch::STEP) >> a & 1 == 1 && step_pins >> a & 1 == 1;
            if rose {
                ax.step(now);
                if let Some(f) = self.edges.as_mut() {
                    let _ = writeln!(f, "{a} {now}");
                }
            }
        }
    }

    fn send_to_host(&mut self, b: u8) {
        // every edge before a reply is in the log when the host reads that reply (a test
        // that waits for idle then reads the file); flushing an empty buffer costs nothing
        if let Some(f) = self.edges.as_mut() {
            let _ = f.flush();
        }
        let b = self.faults.to_host(b);
        if !self.cut {
            self.pty.write(&[b]);
        }
    }
}
/// Axis `a`'s entry of a per-axis option list: the last entry serves the axes past the
/// list's end, the default an empty list.
fn per_axis<T: Clone + Default>(list: &[T], a: usize) -> T {
    list.get(a).or(list.last()).cloned().unwrap_or_default()
}
