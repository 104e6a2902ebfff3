//! Hardware-in-the-loop speed: simulated seconds per wall second on a board with every
//! axis moving (each a one-second trapezoid of four 0.25 s segments, driving its motor),
//! through the pty as a host drives it.
//! `cargo run --release -p multistep-hil --example hil_speed -- [BOARD] [AXES]`

use multistep_core::int::{IntClock, IntProfile, IntSegment};
use multistep_hdl::link::{move_writes, start_write, BoardReg, HostLink, Reg};
use multistep_hdl::AxisMove;
use multistep_hil::{BoardSim, Options};
use std::time::{Duration, Instant};

/// CPU seconds used by this process so far (every thread).
fn cpu_s() -> f64 {
    // SAFETY: getrusage fills the struct it is given.
    let mut r: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut r) };
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    tv(r.ru_utime) + tv(r.ru_stime)
}

/// The 1, 5 and 15 minute load averages (`/proc/loadavg`), or "?" off Linux.
fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let board = args.get(1).cloned().unwrap_or_else(|| "ulx3s-25f".into());
    let axes: u32 = args.get(2).map_or(Ok(4), |s| s.parse())?;
    let t0 = Instant::now();
    let sim = BoardSim::start(&Options {
        board,
        axes: Some(axes),
        ..Options::default()
    })?;
    println!(
        "model built or loaded in {:.1} s ({}); a cycle: {}",
        t0.elapsed().as_secs_f64(),
        if sim.trained {
            "profile-guided"
        } else {
            "without a profile"
        },
        if sim.direct {
            "the NBA region directly"
        } else {
            "eval on both edges"
        }
    );
    let p = sim.board.core.clone();
    let port = serialport::new(&sim.pty_path, sim.board.baud)
        .timeout(Duration::from_secs(2))
        .open()?;
    let mut l = HostLink::new(port);
    l.write(Reg::Board(BoardReg::Enable), (1 << axes) - 1)?;
    let clock = IntClock::hz(p.clock_hz as u64);
    let ticks = (p.clock_hz * 0.25) as u64;
    let mut w = Vec::new();
    let mut steps = 0u64;
    for a in 0..axes {
        let v = 12_000 + 4_000 * u64::from(a % 4);
        let q = v / 4; // steps in a quarter second at v
        let segs = [(0, q / 2), (v, q), (v, q), (v, q / 2)].map(|(v0, s)| IntSegment {
            v0,
            ticks,
            steps: s,
        });
        let prof = IntProfile::segments(&segs, clock)?;
        steps += 3 * q;
        w.extend(move_writes(
            &p,
            a,
            &AxisMove::from_profile(&prof, true, &p)?,
            0,
        )?);
    }
    w.push(start_write((1 << axes) - 1));
    l.write_all(&w)?;
    let load0 = load();
    let (s0, c0, t0) = (sim.state()?.seconds, cpu_s(), Instant::now());
    while l.read(Reg::Board(BoardReg::Busy))? != 0 {
        std::thread::sleep(Duration::from_millis(100));
    }
    let (sim_s, cpu, wall) = (
        sim.state()?.seconds - s0,
        cpu_s() - c0,
        t0.elapsed().as_secs_f64(),
    );
    println!(
        "{axes} axes, {steps} steps: {sim_s:.3} simulated s in {wall:.1} wall s ({cpu:.1} CPU s): \
         {:.1} wall s and {:.1} CPU s per simulated second (load average {load0} before, {} after)",
        wall / sim_s,
        cpu / sim_s,
        load()
    );
    sim.quit()?;
    Ok(())
}
