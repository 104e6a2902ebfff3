//! `multistep simulate`: one move on a simulated motor and driver; lost steps and following error.

use crate::moveargs::MoveArgs;
use crate::output::ReportFormat;
use clap::Args;
use multistep_core::DEFAULT_CLOCK_HZ;
use multistep_sim::{plot, simulate_profile, trace, DriverMode, Motor, SimConfig, DEFAULT_DT};
use std::io::Write;

#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// Motor: a library name (57mm, 42mm, 20mm) or a TOML file
    #[arg(long, value_name = "NAME|FILE")]
    pub motor: String,
    #[command(flatten)]
    pub mv: MoveArgs,
    /// Clock frequency (Hz) the edges are counted in
    #[arg(long, value_name = "HZ", default_value_t = DEFAULT_CLOCK_HZ)]
    pub clock: f64,
    /// Move in the negative direction
    #[arg(long)]
    pub reverse: bool,
    /// Microsteps per full step (default: the motor file's)
    #[arg(long, value_name = "M")]
    pub microsteps: Option<u32>,
    /// Driver supply voltage (V, up to 1000; default: the motor file's)
    #[arg(long, value_name = "V")]
    pub supply: Option<f64>,
    /// Driver: rl (PI current loop, voltage clamped to the supply) or ideal (i = i*)
    #[arg(long, value_name = "MODE", default_value = "rl")]
    pub mode: DriverMode,
    /// Load inertia on the shaft (kg·m²; default: the motor file's)
    #[arg(long, value_name = "J")]
    pub load_inertia: Option<f64>,
    /// Load torque opposing the move (N·m, 0 to 10 × holding torque; default: the motor file's)
    #[arg(long, value_name = "T")]
    pub load_torque: Option<f64>,
    /// Damping ratio ζ of the rotor oscillation (default: the motor file's)
    #[arg(long, value_name = "Z")]
    pub damping_ratio: Option<f64>,
    /// RK4 time step (s): at least 1e-9 and small enough to be stable for the motor
    #[arg(long, value_name = "S", default_value_t = DEFAULT_DT)]
    pub dt: f64,
    /// Write the trace (every 10 µs) as CSV
    #[arg(long, value_name = "FILE.csv")]
    pub trace: Option<String>,
    /// Plot commanded/actual speed and following error (.svg or .png)
    #[arg(long, value_name = "FILE")]
    pub plot: Option<String>,
    #[arg(long, value_enum, default_value_t = ReportFormat::Table)]
    pub format: ReportFormat,
}

pub fn run(a: &SimulateArgs) -> anyhow::Result<()> {
    let mut motor = Motor::load(&a.motor)?;
    if let Some(j) = a.load_inertia {
        motor.load_inertia = j;
    }
    if let Some(t) = a.load_torque {
        motor.load_torque = t;
    }
    if let Some(z) = a.damping_ratio {
        motor.damping_ratio = z;
    }
    motor.validate()?;
    let mut cfg = SimConfig::for_motor(&motor);
    cfg.driver.mode = a.mode;
    cfg.dt = a.dt;
    if let Some(m) = a.microsteps {
        cfg.driver.microsteps = m;
    }
    if let Some(v) = a.supply {
        cfg.driver.supply_voltage = v;
    }
    // a run of more than a few seconds shows a bar on stderr (when it is a terminal)
    cfg.progress = true;
    if a.trace.is_some() || a.plot.is_some() {
        cfg.trace_interval = Some(10e-6);
    }
    let profile = a.mv.plan(a.clock)?;
    let dir = if a.reverse { -1.0 } else { 1.0 };
    let r = simulate_profile(&motor, &cfg, profile, a.clock, dir)?;
    if let Some(path) = &a.trace {
        trace::write_csv(path, &r.trace)?;
    }
    if let Some(path) = &a.plot {
        let title = format!(
            "{} on {}, {} microsteps, {} driver",
            a.mv.describe(),
            motor.name,
            r.microsteps,
            a.mode_name()
        );
        plot::plot_trace(path, &title, &r.trace, plot::ErrorUnit::Degrees)?;
    }
    let mut out = std::io::stdout().lock();
    match a.format {
        ReportFormat::Json => writeln!(out, "{}", serde_json::to_string_pretty(&r)?)?,
        ReportFormat::Table => {
            writeln!(
                out,
                "motor               {} ({} driver, {} microsteps, {} V)",
                motor.name,
                a.mode_name(),
                r.microsteps,
                cfg.driver.supply_voltage
            )?;
            writeln!(
                out,
                "move                {}, {} steps, {:.6} s",
                a.mv.describe(),
                r.steps,
                r.move_time_s
            )?;
            writeln!(
                out,
                "damping ratio ζ     {:.3} (rotor oscillation {:.1} Hz)",
                r.damping_ratio, r.natural_frequency_hz
            )?;
            writeln!(out, "lost steps          {}", r.lost_steps)?;
            match r.first_loss_s {
                Some(t) => writeln!(out, "first loss at       {:.6} s", t)?,
                None => writeln!(out, "first loss at       never")?,
            }
            writeln!(
                out,
                "following error     {:.3}° … {:.3}° (peak {:.3}°, {:.2} microsteps)",
                r.min_following_error_deg,
                r.max_following_error_deg,
                r.peak_following_error_deg,
                r.peak_following_error_steps
            )?;
            writeln!(out, "final error         {:.3}°", r.final_error_deg)?;
            writeln!(out, "peak speed          {:.1}°/s", r.peak_speed_deg_s)?;
            writeln!(
                out,
                "simulated           {:.6} s at dt = {:e} s",
                r.simulated_s, r.dt_s
            )?;
        }
    }
    Ok(())
}

impl SimulateArgs {
    fn mode_name(&self) -> &'static str {
        match self.mode {
            DriverMode::Rl => "rl",
            DriverMode::Ideal => "ideal",
        }
    }
}
