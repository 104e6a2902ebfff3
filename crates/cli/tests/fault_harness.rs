//! Fault injection on the board link. `multistep serve --board-link` drives the FPGA board's
//! RTL (`multistep board-sim`) through a proxy that flips, drops, duplicates and delays
//! bytes both ways; the board is reset and power-cycled and `serve` is killed (SIGKILL) and
//! started again, between and during random commands: moves of every family, groups,
//! homing, tracking, stops and e-stops. After every step the link is made clean and the
//! harness checks, against the simulated mechanics (which no fault touches):
//! - every position reported trusted is the mechanics' position plus the offset the last
//!   homing fixed (a power cycle the host missed, or a move run twice, breaks this);
//! - no move ran more than once: each axis moved between 0 and the move's distance, and a
//!   move answered `ok` that ended without a fault word went all the way;
//! - every axis comes to rest (idle, or a fault with its count) within a bound.
//!
//! `MULTISTEP_FAULT_STEPS` (default 8) sets the number of steps and `MULTISTEP_FAULT_SEED`
//! the seed; the long run of docs/HIL.md is
//! `MULTISTEP_FAULT_STEPS=400 cargo test -p multistep --test fault_harness -- --nocapture`.

mod common;

use common::Proc;
use multistep_controller::axis::Link;
use multistep_controller::client::{Client, ClientError};
use multistep_controller::{AxisState, AxisStatus};
use multistep_hil::proxy::{FaultKind, LinkProxy, ProxyOptions};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

/// The binary under test; `MULTISTEP_FAULT_BIN` names a copy (a long run outlives rebuilds).
fn bin() -> String {
    std::env::var("MULTISTEP_FAULT_BIN").unwrap_or_else(|_| env!("CARGO_BIN_EXE_multistep").into())
}

/// Two axes that home onto a Hall sensor whose edge is at -300 (as in board_link.rs), with
/// the jerk and snap the S-curve families plan with in limits mode.
const AXIS: &str = r#"
vmax = 4000.0
amax = 40000.0
jmax = 2000000.0
smax = 200000000.0
home_dir = -1
home_offset = 500
home_speed = 2000.0
home_slow_speed = 500.0
home_backoff = 40
home_search = 20000
debounce = 0.00002
[axis.sim]
sensor_at = -300
sensor_width = 200
"#;

const AXES: [&str; 2] = ["X", "Y"];
const FAMILIES: [&str; 6] = [
    "trapezoid",
    "scurve",
    "scurve4",
    "parabolic",
    "exponential",
    "sine",
];
/// Mechanical positions random moves aim at: above the sensor, within a homing's reach.
const AIM: std::ops::Range<i64> = 0..2500;
/// Once the link is clean, every axis is at rest (its board reachable) within this (wall time: the RTL runs
/// slower than a board).
const SETTLE: Duration = Duration::from_secs(90);
/// The service's reply timeout on the link (s): short, so a damaged exchange costs little.
const LINK_TIMEOUT: f64 = 0.15;

/// What the harness counts.
#[derive(Debug, Default)]
struct Tally {
    steps: u64,
    commands: u64,
    answered_error: u64,
    board_resets: u64,
    power_cycles: u64,
    serve_kills: u64,
    /// Trusted positions that were not the mechanics' position plus the homing's offset.
    wrong_trusted: u64,
    /// Moves that went further than asked (run twice, or partly again).
    double_moves: u64,
    /// Moves answered `ok` that ended short of their target with no fault word.
    short_without_fault: u64,
    /// Axes not at rest within [`SETTLE`] of a clean link.
    stuck: u64,
    /// `error:6` (busy) for an axis the last status showed at rest.
    busy_at_rest: u64,
    /// Restarts of `serve` that ended at once: the damaged link gave the board's start-up
    /// reads no intact reply (then the link is made clean and it starts again).
    refused_starts: u64,
    recovery: Vec<Duration>,
}

/// A relative move the step asked for, to check once at rest.
struct Asked {
    axis: usize,
    distance: i64,
    /// The mechanics' commanded count before it.
    before: i64,
    answered_ok: bool,
}

struct Harness {
    dir: tempfile::TempDir,
    board: Proc,
    proxy: LinkProxy,
    serve: Proc,
    client: Client,
    rng: StdRng,
    t: Tally,
    /// Per axis: trusted position minus commanded count, as the last homing fixed it.
    offset: [Option<i64>; 2],
    /// The first homing's offset: every later homing lands on the same edge (± debounce).
    home_offset: [Option<i64>; 2],
}

impl Harness {
    fn new(seed: u64) -> Harness {
        let dir = tempfile::tempdir().unwrap();
        let axis = |n: &str| format!("[[axis]]\nname = \"{n}\"{AXIS}");
        let config = dir.path().join("board.toml");
        std::fs::write(
            &config,
            format!("[board]\nname = \"t\"\n{}{}", axis("X"), axis("Y")),
        )
        .unwrap();
        let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("verilator");
        let (board, first) = Proc::spawn(
            Command::new(bin())
                .args(["board-sim", "--board", "ulx3s-25f", "--axes", "2"])
                .arg("--config")
                .arg(&config)
                .arg("--cache-dir")
                .arg(cache),
            1,
        );
        let pty = first[0]
            .strip_prefix("pty ")
            .unwrap_or_else(|| panic!("board-sim said: {first:?}"));
        let proxy = LinkProxy::start(
            pty,
            ProxyOptions {
                seed,
                ..ProxyOptions::default()
            },
        )
        .expect("the proxy starts");
        let link = format!("serial:{},timeout={LINK_TIMEOUT}", proxy.path);
        let (serve, client) = common::serve_on_link(&bin(), dir.path(), &link);
        Harness {
            dir,
            board,
            proxy,
            serve,
            client,
            rng: StdRng::seed_from_u64(seed),
            t: Tally::default(),
            offset: [None; 2],
            home_offset: [None; 2],
        }
    }

    /// The mechanics' commanded counts (STEPs taken while energized, by DIR).
    fn commanded(&mut self) -> [i64; 2] {
        self.board.send("state");
        let line = self.board.read_line();
        let v: serde_json::Value =
            serde_json::from_str(&line).unwrap_or_else(|e| panic!("state: {e}: {line}"));
        [0, 1].map(|a| v["axes"][a]["commanded"].as_i64().expect("commanded"))
    }

    /// One command; its answer (an I/O error of the TCP connection to `serve` panics:
    /// the service must survive everything the link does).
    fn req(&mut self, line: &str) -> Result<Vec<String>, u16> {
        self.t.commands += 1;
        match self.client.request(line) {
            Ok(d) => Ok(d),
            Err(ClientError::Refused(r)) => {
                self.t.answered_error += 1;
                Err(r.code)
            }
            Err(e) => panic!("{line}: {e}"),
        }
    }

    fn status(&mut self) -> Vec<AxisStatus> {
        self.client
            .status()
            .unwrap_or_else(|e| panic!("status: {e}"))
    }

    fn pause(&mut self, max_ms: u64) {
        let ms = self.rng.gen_range(0..=max_ms);
        std::thread::sleep(Duration::from_millis(ms));
    }

    /// A relative distance that takes the axis's mechanics to a random place in [`AIM`].
    fn distance(&mut self, commanded: i64) -> i64 {
        let d = self.rng.gen_range(AIM) - commanded;
        if d == 0 {
            1
        } else {
            d
        }
    }

    fn family(&mut self) -> &'static str {
        FAMILIES[self.rng.gen_range(0..FAMILIES.len())]
    }

    /// A move of axis `a` (its mechanics at `before`) by a random distance, family random.
    fn one_move(&mut self, a: usize, before: i64, rest: &[AxisStatus]) -> Asked {
        let d = self.distance(before);
        let f = self.family();
        let r = self.req(&format!("move {} {d} profile={f}", AXES[a]));
        self.note_busy(&r, rest, &[a]);
        Asked {
            axis: a,
            distance: d,
            before,
            answered_ok: r.is_ok(),
        }
    }

    /// One random step; returns the moves to check and the axes it homed.
    fn step(&mut self, rest: &[AxisStatus]) -> (Vec<Asked>, [bool; 2]) {
        let before = self.commanded();
        let a = self.rng.gen_range(0..2);
        let name = AXES[a];
        let mut asked = Vec::new();
        let mut homed = [false; 2];
        match self.rng.gen_range(0..100) {
            0..=39 => asked.push(self.one_move(a, before[a], rest)),
            40..=54 => {
                let d = [0, 1].map(|i| self.distance(before[i]));
                let f = self.family();
                let sync = if self.rng.gen_bool(0.5) { " sync" } else { "" };
                let r = self.req(&format!(
                    "group move X={} Y={}{sync} profile={f}",
                    d[0], d[1]
                ));
                self.note_busy(&r, rest, &[0, 1]);
                for (i, &d) in d.iter().enumerate() {
                    asked.push(Asked {
                        axis: i,
                        distance: d,
                        before: before[i],
                        answered_ok: r.is_ok(),
                    });
                }
            }
            55..=66 => {
                let r = self.req(&format!("home {name}"));
                self.note_busy(&r, rest, &[a]);
                homed[a] = true;
            }
            67..=76 => {
                let rate = self.rng.gen_range(200..3000) * if before[a] > 1250 { -1 } else { 1 };
                let r = self.req(&format!("track {name} {rate}"));
                self.note_busy(&r, rest, &[a]);
                self.pause(400);
                let _ = self.req(&format!("track {name} {}", -rate / 2));
                self.pause(200);
                let _ = self.req(&format!("stop {name}"));
            }
            77..=86 => {
                // a move stopped, or e-stopped, part way
                let m = self.one_move(a, before[a], rest);
                asked.push(Asked {
                    answered_ok: false,
                    ..m
                });
                self.pause(300);
                if self.rng.gen_bool(0.7) {
                    let _ = self.req(&format!("stop {name}"));
                } else {
                    let _ = self.req("estop");
                    let _ = self.req("reset");
                }
            }
            _ => {
                // a move under way when the board or the service goes down
                let m = self.one_move(a, before[a], rest);
                asked.push(Asked {
                    answered_ok: false,
                    ..m
                });
                self.pause(300);
                match self.rng.gen_range(0..3) {
                    0 => {
                        self.board.send("reset");
                        self.t.board_resets += 1;
                    }
                    1 => {
                        self.board.send("power-cycle");
                        self.t.power_cycles += 1;
                    }
                    _ => {
                        self.serve.kill9();
                        self.t.serve_kills += 1;
                        self.restart_serve();
                    }
                }
            }
        }
        (asked, homed)
    }

    /// `serve` started again on the damaged link; one that cannot reach the board at start
    /// ends with one error line, by design (counted), and is started on a clean link.
    fn restart_serve(&mut self) {
        let link = format!("serial:{},timeout={LINK_TIMEOUT}", self.proxy.path);
        loop {
            match common::try_serve_on_link(&bin(), self.dir.path(), &link) {
                Ok(s) => {
                    (self.serve, self.client) = s;
                    return;
                }
                Err(e) => {
                    eprintln!("serve did not start on the damaged link: {e}");
                    self.t.refused_starts += 1;
                    assert!(self.t.refused_starts < 1000, "serve never starts");
                    self.proxy.set_rate(0.0);
                }
            }
        }
    }

    /// `error:6` for an axis that was at rest is an axis stuck busy.
    fn note_busy(&mut self, r: &Result<Vec<String>, u16>, rest: &[AxisStatus], axes: &[usize]) {
        if *r == Err(6) && axes.iter().all(|&a| at_rest(&rest[a])) {
            eprintln!("busy at rest: {rest:?}");
            self.t.busy_at_rest += 1;
        }
    }

    /// With the link clean: waits until both axes are at rest (stopping a tracking axis
    /// left running, e.g. by a lost `stop`), counting those that never get there.
    fn settle(&mut self) -> Vec<AxisStatus> {
        self.proxy.set_rate(0.0);
        let t0 = Instant::now();
        let mut stopped = false;
        loop {
            let s = self.status();
            if s.iter().all(at_rest) {
                self.t.recovery.push(t0.elapsed());
                return s;
            }
            if !stopped && t0.elapsed() > Duration::from_secs(5) {
                // a `stop` the link lost leaves a tracking axis tracking, as asked
                for st in s.iter().filter(|s| s.state == AxisState::Tracking) {
                    let _ = self.req(&format!("stop {}", st.axis));
                }
                stopped = true;
            }
            if t0.elapsed() > SETTLE {
                eprintln!("stuck: {s:?}");
                self.t.stuck += s.iter().filter(|s| !at_rest(s)).count() as u64;
                let _ = self.req("estop");
                let _ = self.req("reset");
                return self.status();
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// The invariants, at rest.
    /// `homed`: the axes a homing was asked of (answered or not).
    fn check(&mut self, s: &[AxisStatus], asked: &[Asked], homed: [bool; 2]) {
        let cmd = self.commanded();
        for (a, st) in s.iter().enumerate() {
            if !st.trusted {
                continue;
            }
            let off = st.position - cmd[a];
            if homed[a] {
                // a homing sets the offset: the same edge every time
                match self.home_offset[a] {
                    None => self.home_offset[a] = Some(off),
                    Some(h) if (off - h).abs() > 4 => {
                        eprintln!("{}: homed at offset {off}, first homing {h}", st.axis);
                        self.t.wrong_trusted += 1;
                    }
                    Some(_) => {}
                }
                self.offset[a] = Some(off);
            } else if self.offset[a] != Some(off) {
                eprintln!(
                    "{}: trusted at {} but the mechanics say {} (offset {:?}): {st:?}",
                    st.axis,
                    st.position,
                    cmd[a] + self.offset[a].unwrap_or(0),
                    self.offset[a]
                );
                self.t.wrong_trusted += 1;
                self.offset[a] = Some(off);
            }
        }
        for m in asked {
            let moved = cmd[m.axis] - m.before;
            let (lo, hi) = (m.distance.min(0), m.distance.max(0));
            if !(lo..=hi).contains(&moved) {
                eprintln!(
                    "{}: asked {} moved {moved}: {:?}",
                    AXES[m.axis], m.distance, s[m.axis]
                );
                self.t.double_moves += 1;
            } else if m.answered_ok && moved != m.distance && s[m.axis].fault.is_none() {
                eprintln!(
                    "{}: answered ok for {}, moved {moved} with no fault: {:?}",
                    AXES[m.axis], m.distance, s[m.axis]
                );
                self.t.short_without_fault += 1;
            }
        }
    }

    fn run(&mut self, steps: u64, rates: &[f64]) {
        let mut rest = self.settle();
        for _ in 0..steps {
            let rate = rates[self.rng.gen_range(0..rates.len())];
            self.proxy.set_rate(rate);
            let (asked, homed) = self.step(&rest);
            // the damage goes on while the motion does (bulk writes, polls, the end)
            self.pause(3000);
            rest = self.settle();
            self.t.steps += 1;
            self.check(&rest, &asked, homed);
            if self.t.steps.is_multiple_of(25) {
                eprintln!("fault harness: {}", self.report());
            }
        }
    }

    fn report(&self) -> String {
        let c = self.proxy.counts();
        let mut r = self.t.recovery.clone();
        r.sort();
        let q = |p: f64| r.get(((r.len() as f64 - 1.0) * p) as usize).copied();
        let ms = |d: Option<Duration>| d.map_or(f64::NAN, |d| d.as_secs_f64() * 1e3);
        let kinds: Vec<String> = FaultKind::ALL
            .iter()
            .map(|&k| format!("{}={}", k.name(), c.of(k)))
            .collect();
        format!(
            "faults={} ({}) board_resets={} power_cycles={} serve_kills={} refused_starts={} steps={} \
             commands={} answered_error={} recovery_p50_ms={:.0} recovery_p99_ms={:.0} \
             wrong_trusted={} double_moves={} short_without_fault={} stuck={} busy_at_rest={} \
             link_bytes={:?}",
            c.total(),
            kinds.join(" "),
            self.t.board_resets,
            self.t.power_cycles,
            self.t.serve_kills,
            self.t.refused_starts,
            self.t.steps,
            self.t.commands,
            self.t.answered_error,
            ms(q(0.5)),
            ms(q(0.99)),
            self.t.wrong_trusted,
            self.t.double_moves,
            self.t.short_without_fault,
            self.t.stuck,
            self.t.busy_at_rest,
            self.proxy.bytes(),
        )
    }
}

/// Idle, or a fault with the board's count: not with the link down (whose axis may still
/// be moving on the board; an error a command met is kept on an axis at rest).
fn at_rest(s: &AxisStatus) -> bool {
    match s.state {
        AxisState::Idle => true,
        AxisState::Fault => s.link != Some(Link::Down),
        _ => false,
    }
}

fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
fn faults_on_the_link_never_give_a_wrong_trusted_position_a_double_move_or_a_stuck_axis() {
    let seed = env_u64("MULTISTEP_FAULT_SEED", 7);
    let steps = env_u64("MULTISTEP_FAULT_STEPS", 8);
    let mut h = Harness::new(seed);
    // both axes homed first, so positions are trusted and checked from the start
    for a in AXES {
        h.req(&format!("home {a}")).expect("homing on a clean link");
        let s = h.settle();
        let homed = [a == "X", a == "Y"];
        h.check(&s, &[], homed);
    }
    // per byte: a clean step, some damage, and heavy damage
    h.run(steps, &[0.0, 1e-3, 1e-2, 3e-2, 0.1, 0.3]);
    let report = h.report();
    eprintln!("fault harness (seed {seed}): {report}");
    if let Ok(path) = std::env::var("MULTISTEP_FAULT_REPORT") {
        std::fs::write(path, format!("{report}\n")).unwrap();
    }
    let t = &h.t;
    assert!(
        h.proxy.counts().total() > 0,
        "no fault was injected: {report}"
    );
    assert_eq!(
        (
            t.wrong_trusted,
            t.double_moves,
            t.short_without_fault,
            t.stuck,
            t.busy_at_rest
        ),
        (0, 0, 0, 0, 0),
        "{report}"
    );
}
