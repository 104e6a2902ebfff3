//! Several boards in one process, each on its own pty, their SYNC pins wired as one
//! open-drain line (docs/HDL.md, "Cross-board start"), each on its own clock (a rate error
//! in ppm and a power-up instant) on one common time base.
//!
//! The boards are stepped conservatively: the board whose next clock edge comes first runs,
//! up to the earliest instant at which another board could change the SYNC line. A board
//! changes it only by executing a `Fire` request, which completes with a byte on its UART,
//! so a board receiving nothing bounds no one, one receiving a byte bounds the others at
//! that byte's stop bit, and a board that just completed a byte or drives the line bounds
//! them at its next clock edge. A board's edges therefore see every line change made
//! before them, as wired boards do. Host bytes reach a board no earlier than the latest
//! board's time (a USB-UART's latency), so no board has run past a request's effects.
//! With every board idle, time stops for all of them.

use crate::{world_step, Control, HilError, Options, SimState, World};
use multistep_hdl::verilator::watch;
use multistep_hdl::BoardTop;
use serde::Serialize;
use std::io::Write;
use std::sync::mpsc;

/// How to run the boards.
#[derive(Clone, Debug, Default)]
pub struct MultiOptions {
    /// One per board.
    pub boards: Vec<Options>,
    /// Per board: its clock's rate error, ppm (missing: 0).
    pub ppm: Vec<f64>,
    /// Per board: the instant its clock starts, µs of common time (missing: 0).
    pub power_up_us: Vec<f64>,
}

/// One board's clock on the common time base: clock edge c (counted from 1 as the
/// board's cycle counter counts them) is at `start_ps + c · period_ps`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BoardClock {
    pub period_ps: f64,
    pub start_ps: f64,
}

impl BoardClock {
    pub fn time_ps(&self, cycle: f64) -> f64 {
        self.start_ps + cycle * self.period_ps
    }
}

enum MultiControl {
    Board(usize, Control),
    State(mpsc::Sender<Vec<SimState>>),
    Quit,
}

/// Running boards: their ptys, in order, and the controls. Dropping it stops them.
pub struct MultiBoardSim {
    pub pty_paths: Vec<String>,
    pub boards: Vec<BoardTop>,
    pub clocks: Vec<BoardClock>,
    tx: mpsc::Sender<MultiControl>,
    thread: Option<std::thread::JoinHandle<Result<(), HilError>>>,
}

impl MultiBoardSim {
    /// Builds (or loads) every board's model and starts them in one thread. Each board
    /// with an edge log gets a first line `# clock PERIOD_PS START_PS`.
    pub fn start(opts: &MultiOptions) -> Result<MultiBoardSim, HilError> {
        if opts.boards.is_empty() {
            return Err(HilError::Setting("no boards".into()));
        }
        let mut worlds = Vec::new();
        let mut boards = Vec::new();
        let mut clocks = Vec::new();
        for (i, o) in opts.boards.iter().enumerate() {
            let ppm = opts.ppm.get(i).copied().unwrap_or(0.0);
            let up = opts.power_up_us.get(i).copied().unwrap_or(0.0);
            if !(-1000.0..=1000.0).contains(&ppm) || !(0.0..=1e6).contains(&up) {
                return Err(HilError::Setting(format!(
                    "board {i}: ppm must be in -1000..=1000 and power-up in 0..=1e6 us, got {ppm} and {up}"
                )));
            }
            let (mut w, top) = World::new(o)?;
            let clock = BoardClock {
                period_ps: 1e12 / (top.core.clock_hz * (1.0 + ppm * 1e-6)),
                start_ps: up * 1e6,
            };
            if let Some(f) = w.edges.as_mut() {
                let _ = writeln!(f, "# clock {} {}", clock.period_ps, clock.start_ps);
            }
            w.power_on();
            worlds.push(w);
            boards.push(top);
            clocks.push(clock);
        }
        let pty_paths = worlds.iter().map(|w| w.pty.path.clone()).collect();
        let (tx, rx) = mpsc::channel();
        let n = worlds.len();
        let multi = Multi {
            worlds,
            clocks: clocks.clone(),
            pending: vec![None; n],
            line: Vec::new(),
            quit: false,
        };
        let thread = std::thread::Builder::new()
            .name("board-sim".into())
            .spawn(move || multi.run(rx))
            .map_err(|e| HilError::Io {
                what: "thread".into(),
                source: e,
            })?;
        Ok(MultiBoardSim {
            pty_paths,
            boards,
            clocks,
            tx,
            thread: Some(thread),
        })
    }

    fn send(&self, c: MultiControl) -> Result<(), HilError> {
        self.tx.send(c).map_err(|_| HilError::Stopped)
    }

    /// Every board's state, in order.
    pub fn state(&self) -> Result<Vec<SimState>, HilError> {
        let (tx, rx) = mpsc::channel();
        self.send(MultiControl::State(tx))?;
        rx.recv().map_err(|_| HilError::Stopped)
    }

    /// Stops the boards and waits for them.
    pub fn quit(mut self) -> Result<(), HilError> {
        self.stop()
    }

    fn stop(&mut self) -> Result<(), HilError> {
        let _ = self.tx.send(MultiControl::Quit);
        match self.thread.take() {
            Some(t) => t.join().map_err(|_| HilError::Stopped)?,
            None => Ok(()),
        }
    }

    /// Runs one control line: `[@BOARD] COMMAND` with `BoardSim::command`'s commands, for
    /// board BOARD (default 0); `state` prints a JSON array of every board's state.
    pub fn command(&self, line: &str) -> Result<(Option<String>, bool), HilError> {
        let (board, rest) = match line.trim_start().strip_prefix('@') {
            Some(r) => {
                let (b, rest) = r.split_once(char::is_whitespace).unwrap_or((r, ""));
                let b: usize = b
                    .parse()
                    .ok()
                    .filter(|&b| b < self.boards.len())
                    .ok_or_else(|| HilError::Setting(format!("{line:?}: no board {b}")))?;
                (b, rest)
            }
            None => (0, line),
        };
        match crate::parse_command(rest, self.boards[board].core.axes as usize)? {
            crate::Cmd::None => Ok((None, false)),
            crate::Cmd::Quit => Ok((None, true)),
            crate::Cmd::State => {
                let s = self.state()?;
                let j = serde_json::to_string(&s).map_err(|e| HilError::Setting(e.to_string()))?;
                Ok((Some(j), false))
            }
            crate::Cmd::Control(c) => {
                self.send(MultiControl::Board(board, c))?;
                Ok((None, false))
            }
        }
    }
}

impl Drop for MultiBoardSim {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}

struct Multi {
    worlds: Vec<World>,
    clocks: Vec<BoardClock>,
    /// Per board: host bytes read and the instant (ps) they may reach its line.
    pending: Vec<Option<(Vec<u8>, f64)>>,
    /// Every board's changes of its SYNC output: (ps, board, driving), in time order.
    line: Vec<(f64, usize, bool)>,
    quit: bool,
}

/// Clocks after a completed byte during which its request may still execute.
const EXEC_CYCLES: f64 = 64.0;

impl Multi {
    fn now_ps(&self, i: usize) -> f64 {
        self.clocks[i].time_ps(self.worlds[i].cycle() as f64)
    }

    fn drives(&self, i: usize) -> bool {
        self.worlds[i].last & watch::SYNC_OE != 0
    }

    /// The line's level seen by clock edges after `t`: high unless a board drives it.
    fn level_after(&self, t: f64) -> bool {
        !(0..self.worlds.len()).any(|i| {
            self.line
                .iter()
                .rev()
                .find(|c| c.0 <= t && c.1 == i)
                .is_some_and(|c| c.2)
        })
    }

    /// The earliest instant (ps) at which board j could change the line.
    fn bound(&self, j: usize) -> f64 {
        let w = &self.worlds[j];
        let c = w.cycle() as f64;
        let (clock, rx) = (self.clocks[j], &w.rx_line);
        let next_edge = clock.time_ps(c + 1.0);
        if self.drives(j) || c < rx.last_end() + 2.0 * rx.bit() + EXEC_CYCLES {
            return next_edge;
        }
        let mut b = clock.time_ps(rx.next_byte_end(w.cycle()));
        if let Some((_, rel)) = &self.pending[j] {
            b = b.min(rel.max(clock.time_ps(c)) + 9.0 * rx.bit() * clock.period_ps);
        }
        b.max(next_edge)
    }

    fn control(&mut self, c: MultiControl) {
        match c {
            MultiControl::Board(i, c) => {
                if let Some(w) = self.worlds.get_mut(i) {
                    w.control(c);
                }
            }
            MultiControl::State(tx) => {
                let _ = tx.send(self.worlds.iter().map(World::state).collect());
            }
            MultiControl::Quit => self.quit = true,
        }
    }

    fn take_host_bytes(&mut self) {
        let frontier = (0..self.worlds.len())
            .map(|i| self.now_ps(i))
            .fold(f64::NEG_INFINITY, f64::max);
        for (w, p) in self.worlds.iter_mut().zip(self.pending.iter_mut()) {
            w.pty.read_available(&mut w.host);
            if w.cut {
                w.host.clear();
                *p = None;
            }
            if !w.host.is_empty() {
                match p {
                    Some((bytes, _)) => bytes.append(&mut w.host),
                    None => *p = Some((std::mem::take(&mut w.host), frontier)),
                }
            }
        }
    }

    fn busy(&self) -> bool {
        self.worlds.iter().any(|w| w.busy(w.cycle()))
            || self.pending.iter().any(Option::is_some)
            || (0..self.worlds.len()).any(|i| self.drives(i))
    }

    fn run(mut self, rx: mpsc::Receiver<MultiControl>) -> Result<(), HilError> {
        let steps: Vec<u64> = self.worlds.iter().map(|w| world_step(w.clock_hz)).collect();
        let mut iter: u32 = 0;
        // as for one board (`World::run`): the hosts are heard every LISTEN_S of simulated
        // time at least, however far a busy board runs without stepping
        let listen = super::LISTEN_S * 1e12;
        let mut heard = self.earliest_ps();
        while !self.quit {
            iter = iter.wrapping_add(1);
            if !self.busy() {
                for w in &mut self.worlds {
                    if let Some(f) = w.edges.as_mut() {
                        let _ = f.flush();
                    }
                }
                while let Ok(c) = rx.try_recv() {
                    self.control(c);
                }
                if self.quit {
                    break;
                }
                for w in &self.worlds {
                    if w.pty.wait_readable(1) {
                        break;
                    }
                }
                self.take_host_bytes();
                continue;
            }
            let now = self.earliest_ps();
            if iter.is_multiple_of(64) || now >= heard + listen {
                heard = now;
                while let Ok(c) = rx.try_recv() {
                    self.control(c);
                }
                self.take_host_bytes();
            }
            self.step_earliest(&steps, heard + listen);
        }
        for w in &mut self.worlds {
            if let Some(f) = w.edges.as_mut() {
                let _ = f.flush();
            }
        }
        Ok(())
    }

    /// The time of the board furthest behind (ps).
    fn earliest_ps(&self) -> f64 {
        (0..self.worlds.len())
            .map(|i| self.now_ps(i))
            .fold(f64::INFINITY, f64::min)
    }

    /// Runs the board whose next clock edge comes first, as far as the others allow and
    /// no further than `until` (ps).
    fn step_earliest(&mut self, steps: &[u64], until: f64) {
        let n = self.worlds.len();
        let next = |m: &Multi, i: usize| m.clocks[i].time_ps(m.worlds[i].cycle() as f64 + 1.0);
        let k = (0..n)
            .min_by(|&a, &b| next(self, a).total_cmp(&next(self, b)))
            .unwrap_or(0);
        let t = self.now_ps(k);
        let mut bound = (0..n)
            .filter(|&j| j != k)
            .map(|j| self.bound(j))
            .fold(f64::INFINITY, f64::min);
        if let Some(c) = self.line.iter().find(|c| c.0 > t) {
            bound = bound.min(c.0);
        }
        if let Some((_, rel)) = &self.pending[k] {
            if *rel <= t {
                if let Some((bytes, _)) = self.pending[k].take() {
                    self.worlds[k].rx_line.push(&bytes);
                }
            } else {
                bound = bound.min(*rel);
            }
        }
        let period = self.clocks[k].period_ps;
        let bound = bound.min(until);
        let cycles = if bound.is_finite() {
            (((bound - t) / period).floor() as u64).max(1)
        } else {
            u64::MAX
        };
        let level = self.level_after(t);
        let before = self.drives(k);
        let w = &mut self.worlds[k];
        w.sync_in = level;
        let cycle = w.cycle();
        w.step_once(cycle, steps[k], cycle.saturating_add(cycles));
        let drives = self.drives(k);
        if drives != before {
            let at = self.now_ps(k);
            let pos = self.line.partition_point(|c| c.0 <= at);
            self.line.insert(pos, (at, k, drives));
            if self.line.len() > 4096 {
                // long past: a fire is two changes, and only the last of each board counts
                self.line.drain(..2048);
            }
        }
    }
}
