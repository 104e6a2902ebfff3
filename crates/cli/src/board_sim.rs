//! `multistep board-sim`: the board's RTL in Verilator behind a pseudo-terminal, driving
//! simulated motors and Hall sensors (hardware in the loop). Prints `pty PATH` first, then
//! takes one control command per line on stdin. With `--boards N`, N boards in one
//! process on one time base, SYNC wired between them: one `pty PATH` line per board.

use anyhow::Context;
use clap::Args;
use multistep_controller::axis::AxisSettings;
use multistep_hil::multi::{MultiBoardSim, MultiOptions};
use multistep_hil::{BoardSim, Options, PinLevels, SensorOptions};
use std::io::{BufRead, Write};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct BoardSimArgs {
    /// Board name (see `multistep hdl boards`)
    #[arg(long)]
    board: String,
    /// Axes (default: the board's `hdl build` default)
    #[arg(long)]
    axes: Option<u32>,
    /// UART baud (default: the board's)
    #[arg(long)]
    baud: Option<u32>,
    /// The core with the per-step recurrence, its multiplier digit in bits (0..=15, 0: full
    /// width; default: the board's choice)
    #[arg(long, value_name = "BITS")]
    recurrence: Option<u32>,
    /// Motor: a built-in name (42mm, …) or a motor file
    #[arg(long, default_value = "42mm")]
    motor: String,
    /// Driver microsteps per full step
    #[arg(long, default_value_t = 16)]
    microsteps: u32,
    /// Every axis's Hall sensor: true position of its edge (microsteps)
    #[arg(long, default_value_t = 0)]
    sensor_at: i64,
    /// Sensor window width (microsteps)
    #[arg(long, default_value_t = 400)]
    sensor_width: u64,
    /// The window lies from sensor_at on in this direction (1 or -1)
    #[arg(long, default_value_t = -1)]
    home_dir: i8,
    /// Up to this many pairs of extra toggles after each real edge (contact bounce)
    #[arg(long, default_value_t = 0)]
    bounce_count: u32,
    /// Bounce time after an edge (s)
    #[arg(long, default_value_t = 0.0002)]
    bounce_time: f64,
    /// Mean rate of noise glitches (1/s)
    #[arg(long, default_value_t = 0.0)]
    glitch_rate: f64,
    /// Longest glitch (s)
    #[arg(long, default_value_t = 0.0005)]
    glitch_max: f64,
    /// Shortest quiet time between glitches (s)
    #[arg(long, default_value_t = 0.005)]
    glitch_gap: f64,
    /// Seed of the glitch and bounce generator (axis a uses seed + a)
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// A board config file (as `serve --board-config`): each axis's sensor from its `sim.*`,
    /// `home_dir` and `period`, its DIR and ENABLE levels from `invert_dir` and
    /// `enable_active_high` (axis a of the board is the file's a-th `[[axis]]`)
    #[arg(long, conflicts_with_all = ["sensor_at", "sensor_width", "home_dir", "bounce_count",
        "bounce_time", "glitch_rate", "glitch_max", "glitch_gap", "seed"])]
    config: Option<PathBuf>,
    /// Log every STEP rise as `AXIS CYCLE` (and each group start as `# go CYCLE`)
    #[arg(long)]
    edges: Option<PathBuf>,
    /// Run no faster than the wall clock
    #[arg(long)]
    realtime: bool,
    /// Where built models are cached (default $XDG_CACHE_HOME/multistep/verilator)
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Run this many boards (alike) on one time base, their SYNC pins wired together; the
    /// edge log of board i is FILE.i, control lines take `@i` for board i
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=16))]
    boards: u32,
    /// Per board: its clock's rate error in ppm (comma-separated; missing: 0)
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    ppm: Vec<f64>,
    /// Per board: the instant its clock starts, µs (comma-separated; missing: 0)
    #[arg(long, value_delimiter = ',')]
    power_up_us: Vec<f64>,
}

fn check(what: &str, x: f64, lo: f64, hi: f64) -> anyhow::Result<()> {
    if !(lo..=hi).contains(&x) {
        anyhow::bail!("--{what} must be in {lo}..={hi}, got {x}");
    }
    Ok(())
}

pub fn run(a: &BoardSimArgs) -> anyhow::Result<()> {
    check("bounce-time", a.bounce_time, 0.0, 1.0)?;
    check("glitch-rate", a.glitch_rate, 0.0, 1e4)?;
    check("glitch-max", a.glitch_max, 0.0, 1.0)?;
    check("glitch-gap", a.glitch_gap, 0.0, 10.0)?;
    check("bounce-count", f64::from(a.bounce_count), 0.0, 100.0)?;
    check("microsteps", f64::from(a.microsteps), 1.0, 256.0)?;
    let (sensors, levels) = match &a.config {
        Some(path) => axes_of(path)?,
        // the controller's default wiring, as `serve` drives an unconfigured axis
        None => (flag_sensors(a), vec![pin_levels(&AxisSettings::default())]),
    };
    let opts = Options {
        board: a.board.clone(),
        axes: a.axes,
        baud: a.baud,
        motor: a.motor.clone(),
        microsteps: a.microsteps,
        sensors,
        levels,
        edges: a.edges.clone(),
        realtime: a.realtime,
        cache_dir: a.cache_dir.clone(),
        recurrence: a.recurrence,
    };
    if a.boards > 1 || !a.ppm.is_empty() || !a.power_up_us.is_empty() {
        if a.realtime {
            anyhow::bail!("--realtime runs one board only");
        }
        let boards = (0..a.boards)
            .map(|i| Options {
                edges: a
                    .edges
                    .as_ref()
                    .map(|p| PathBuf::from(format!("{}.{i}", p.display()))),
                ..opts.clone()
            })
            .collect();
        let sim = MultiBoardSim::start(&MultiOptions {
            boards,
            ppm: a.ppm.clone(),
            power_up_us: a.power_up_us.clone(),
        })?;
        let mut out = std::io::stdout().lock();
        for p in &sim.pty_paths {
            writeln!(out, "pty {p}")?;
        }
        out.flush()?;
        serve_lines(|l| sim.command(l))?;
        return Ok(sim.quit()?);
    }
    let sim = BoardSim::start(&opts)?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "pty {}", sim.pty_path)?;
    out.flush()?;
    drop(out);
    serve_lines(|l| sim.command(l))?;
    Ok(sim.quit()?)
}

/// Control lines from stdin until `quit` (then returns); at the end of stdin, serves
/// until killed.
fn serve_lines(
    command: impl Fn(&str) -> Result<(Option<String>, bool), multistep_hil::HilError>,
) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    for line in std::io::stdin().lock().lines() {
        let line = line.context("reading stdin")?;
        match command(&line) {
            Ok((text, stop)) => {
                if let Some(t) = text {
                    writeln!(out, "{t}")?;
                    out.flush()?;
                }
                if stop {
                    return Ok(());
                }
            }
            Err(e) => eprintln!("error: {e}"),
        }
    }
    // stdin closed (run in the background): serve until killed
    loop {
        std::thread::park();
    }
}

/// Every axis's sensor from the flags (axis a's generator seeded with seed + a).
fn flag_sensors(a: &BoardSimArgs) -> Vec<SensorOptions> {
    (0..multistep_hdl::verilator::MAX_AXES)
        .map(|i| SensorOptions {
            sensor_at: a.sensor_at,
            sensor_width: a.sensor_width,
            home_dir: a.home_dir,
            period: None,
            bounce_count: a.bounce_count,
            bounce_time: a.bounce_time,
            glitch_rate: a.glitch_rate,
            glitch_max: a.glitch_max,
            glitch_gap: a.glitch_gap,
            seed: a.seed.wrapping_add(u64::from(i)),
        })
        .collect()
}

/// How an axis's driver reads its DIR and ENABLE pins.
fn pin_levels(s: &AxisSettings) -> PinLevels {
    PinLevels {
        invert_dir: s.invert_dir,
        enable_active_high: s.enable_active_high,
    }
}

/// Each axis's sensor and pin levels from a board config file (checked as `serve` checks
/// it).
fn axes_of(path: &std::path::Path) -> anyhow::Result<(Vec<SensorOptions>, Vec<PinLevels>)> {
    let c = multistep_controller::config::BoardConfig::load(path)?;
    let levels = c.axes.iter().map(|ax| pin_levels(&ax.settings)).collect();
    let sensors = c
        .axes
        .iter()
        .map(|ax| {
            let (s, sim) = (&ax.settings, &ax.settings.sim);
            SensorOptions {
                sensor_at: sim.sensor_at,
                sensor_width: sim.sensor_width,
                home_dir: s.home_dir,
                period: s.period,
                bounce_count: sim.bounce_count,
                bounce_time: sim.bounce_time,
                glitch_rate: sim.glitch_rate,
                glitch_max: sim.glitch_max,
                glitch_gap: sim.glitch_gap,
                seed: sim.seed,
            }
        })
        .collect();
    Ok((sensors, levels))
}
