//! `estop` and `stop` under load on the simulated board, in real time: 32 line-protocol
//! clients poll `status`, 12 threads preview a long group of X and Y without pause, axes U
//! and V run a group and Z tracks at 20 000 steps/s. Each trial asks for an `estop` (or a `stop Z`) over
//! the line protocol and measures, host side, the time to its answer and to its
//! application to the board, and on the board the steps Z took after it was asked for,
//! against what the stop rule allows. Previews refused as busy (`error:23`, the timing
//! pool's queue full) are counted.
//!
//! `cargo run --release -p multistep-controller --example estop_load -- [TRIALS]`; with
//! `ESTOP_LOAD_RAW=FILE` each e-stop trial's answer (ms), application (ms) and steps after
//! are appended to FILE, one line each, to pool interleaved runs.

use multistep_controller::config::{AxisConfig, BoardConfig, BoardSection};
use multistep_controller::protocol::{Amount, MoveOpts};
use multistep_controller::service;
use multistep_controller::{AxisSettings, AxisStatus, Controller};
use std::io::{BufRead, BufReader, Write};
use std::net::TcpStream;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

const POLLERS: usize = 32;
const PREVIEWERS: usize = 12;
/// Z's tracking rate (steps/s) and acceleration (steps/s²).
const RATE: f64 = 20_000.0;
const AMAX: f64 = 200_000.0;
/// The latch bound the e-stop is held to.
const LATCH_BOUND_S: f64 = 0.005;
const CLOCK_HZ: f64 = 50e6;

fn config() -> BoardConfig {
    let axis = |name: &str| AxisConfig {
        name: name.into(),
        settings: AxisSettings {
            vmax: 100_000.0,
            amax: AMAX,
            ..AxisSettings::default()
        },
    };
    BoardConfig {
        board: BoardSection {
            name: "load".into(),
            clock_hz: CLOCK_HZ,
            fifo_depth: 4,
            link: None,
            sync_line: None,
        },
        axes: ["X", "Y", "U", "V", "Z"].map(axis).to_vec(),
        alpaca: None,
    }
}

/// A line-protocol client.
struct Client(BufReader<TcpStream>);

impl Client {
    fn connect(addr: &str) -> Client {
        Client(BufReader::new(service::connect(addr).expect("connect")))
    }

    /// Sends one line and reads its reply up to the status line, which it returns.
    fn ask(&mut self, line: &str) -> String {
        self.0
            .get_mut()
            .write_all(format!("{line}\n").as_bytes())
            .expect("send");
        let mut l = String::new();
        loop {
            l.clear();
            if self.0.read_line(&mut l).expect("reply") == 0 {
                panic!("connection closed");
            }
            let t = l.trim_end();
            if t == "ok" || t.starts_with("error:") {
                return t.to_string();
            }
        }
    }
}

fn z(ctl: &Controller) -> AxisStatus {
    ctl.status(&["Z".to_string()]).expect("status").remove(0)
}

/// Z's count and the board's tick, from one advance.
fn z_now(ctl: &Controller) -> (i64, u64) {
    ctl.with_board(|b, now| {
        let s = b.status(&["Z".to_string()], now).expect("status").remove(0);
        (s.position, b.now())
    })
}

fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn summary(name: &str, unit: &str, v: &mut [f64]) {
    println!(
        "{name:<44} p50 {:>9.3}  p99 {:>9.3}  max {:>9.3} {unit}",
        percentile(v, 0.5),
        percentile(v, 0.99),
        percentile(v, 1.0)
    );
}

/// Starts the trial's motion: U and V in a group (back and forth), Z tracking at RATE,
/// and waits until Z cruises.
fn start_motion(c: &mut Client, ctl: &Controller, k: usize) {
    let d = if k.is_multiple_of(2) {
        2_000_000
    } else {
        -2_000_000
    };
    assert_eq!(c.ask(&format!("group move U={d} V={d}")), "ok");
    assert_eq!(c.ask(&format!("track Z {RATE}")), "ok");
    while z(ctl).speed < RATE * (1.0 - 1e-9) {
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn main() {
    let trials: usize = std::env::args()
        .nth(1)
        .map_or(60, |s| s.parse().expect("TRIALS"));
    let dir = tempfile::tempdir().expect("temp dir");
    let ctl = Arc::new(Controller::open(&config(), dir.path(), 1.0).expect("open"));
    let listener = service::bind("127.0.0.1:0").expect("bind");
    let addr = listener.local_addr().expect("addr").to_string();
    {
        let ctl = ctl.clone();
        std::thread::spawn(move || service::serve_tcp(ctl, listener));
    }
    let quit = Arc::new(AtomicBool::new(false));
    let polls = Arc::new(AtomicU64::new(0));
    let mut threads = Vec::new();
    for _ in 0..POLLERS {
        let (quit, polls, addr) = (quit.clone(), polls.clone(), addr.clone());
        threads.push(std::thread::spawn(move || {
            let mut c = Client::connect(&addr);
            while !quit.load(Ordering::Relaxed) {
                c.ask("status");
                polls.fetch_add(1, Ordering::Relaxed);
            }
        }));
    }
    let previews = Arc::new(AtomicU64::new(0));
    let refused = Arc::new(AtomicU64::new(0));
    let preview_ns = Arc::new(AtomicU64::new(0));
    let group = vec![
        ("X".to_string(), Amount::Steps(5_000_000)),
        ("Y".to_string(), Amount::Steps(4_000_000)),
    ];
    for _ in 0..PREVIEWERS {
        let (ctl, quit, group) = (ctl.clone(), quit.clone(), group.clone());
        let (previews, preview_ns) = (previews.clone(), preview_ns.clone());
        let refused = refused.clone();
        threads.push(std::thread::spawn(move || {
            while !quit.load(Ordering::Relaxed) {
                let t = Instant::now();
                // Refused after an e-stop until the reset: only the timed ones count.
                match ctl.preview(&group, false, false, &MoveOpts::default()) {
                    Ok(_) => {
                        previews.fetch_add(1, Ordering::Relaxed);
                        preview_ns.fetch_add(t.elapsed().as_nanos() as u64, Ordering::Relaxed);
                    }
                    Err(e) if e.code() == 23 => {
                        refused.fetch_add(1, Ordering::Relaxed);
                    }
                    Err(_) => {}
                }
            }
        }));
    }
    let mut c = Client::connect(&addr);
    let (mut estop_ms, mut latch_ms, mut estop_steps) = (Vec::new(), Vec::new(), Vec::new());
    let mut applied_ms = Vec::new();
    let (mut stop_ms, mut stop_over) = (Vec::new(), Vec::new());
    let started = Instant::now();
    for k in 0..trials {
        let estop = k.is_multiple_of(2);
        start_motion(&mut c, &ctl, k);
        // A different phase of the ticker and the previews each time.
        std::thread::sleep(Duration::from_micros(20_000 + (k as u64 * 7919) % 30_000));
        let (p1, t1) = z_now(&ctl);
        let asked = ctl.now();
        let t = Instant::now();
        let reply = c.ask(if estop { "estop" } else { "stop Z" });
        let answer = t.elapsed().as_secs_f64() * 1e3;
        assert_eq!(reply, "ok");
        // Z cruises at RATE: its count at the tick the halt was asked at.
        let p_asked = p1 as f64 + RATE * asked.saturating_sub(t1) as f64 / CLOCK_HZ;
        if estop {
            let s = z(&ctl);
            let latched = s.move_end.expect("halted");
            let applied = ctl.last_estop_applied().expect("applied");
            applied_ms.push(applied.saturating_duration_since(t).as_secs_f64() * 1e3);
            estop_ms.push(answer);
            latch_ms.push((latched as f64 - asked as f64) / CLOCK_HZ * 1e3);
            estop_steps.push(s.position as f64 - p_asked);
            assert_eq!(c.ask("reset"), "ok");
        } else {
            stop_ms.push(answer);
            while z(&ctl).speed != 0.0 {
                std::thread::sleep(Duration::from_millis(2));
            }
            // Past what a ramp at amax from RATE, started at the ask, covers.
            let rule = RATE * RATE / (2.0 * AMAX);
            stop_over.push(z(&ctl).position as f64 - p_asked - rule);
            assert_eq!(c.ask("stop"), "ok");
            while ctl.with_board(|b, _| b.busy()) {
                std::thread::sleep(Duration::from_millis(2));
            }
        }
    }
    let secs = started.elapsed().as_secs_f64();
    quit.store(true, Ordering::Relaxed);
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let n = previews.load(Ordering::Relaxed);
    println!(
        "{trials} trials in {secs:.1} s; {} status replies, {n} previews timed (mean {:.0} ms), {} refused as busy; loadavg {}",
        polls.load(Ordering::Relaxed),
        preview_ns.load(Ordering::Relaxed) as f64 / n.max(1) as f64 / 1e6,
        refused.load(Ordering::Relaxed),
        load.trim()
    );
    // every e-stop trial's samples, for pooling runs (`ESTOP_LOAD_RAW=FILE`, appended)
    if let Ok(path) = std::env::var("ESTOP_LOAD_RAW") {
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .expect("ESTOP_LOAD_RAW");
        for i in 0..estop_ms.len() {
            writeln!(f, "{} {} {}", estop_ms[i], applied_ms[i], estop_steps[i]).expect("write");
        }
    }
    summary("estop answer, host side", "ms", &mut estop_ms);
    summary(
        "estop applied to the board, host side",
        "ms",
        &mut applied_ms,
    );
    summary(
        "estop latched after it was asked (board)",
        "ms",
        &mut latch_ms,
    );
    summary(
        &format!(
            "Z steps after the estop was asked (bound {:.0})",
            RATE * LATCH_BOUND_S
        ),
        "steps",
        &mut estop_steps,
    );
    summary("stop Z answer, host side", "ms", &mut stop_ms);
    summary(
        "Z steps past the stop rule's ramp from the ask",
        "steps",
        &mut stop_over,
    );
    for t in threads {
        let _ = t.join();
    }
}
