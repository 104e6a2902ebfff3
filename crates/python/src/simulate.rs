//! `multistep.simulate(...)`: one move on a simulated motor and driver, as
//! `multistep simulate` runs it; the result has the fields of `--format json`.

use crate::args::{boolean, each_kw, number, string, whole_in, MoveKw};
use crate::errors::{plan_err, sim_err, value_err};
use crate::link::wait_for;
use multistep_core::{EdgeGenerator, Profile, DEFAULT_CLOCK_HZ};
use multistep_sim::integrate::{check_work, run_planned};
use multistep_sim::{DriverMode, Motor, SimConfig, DEFAULT_DT};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;

/// The trace interval of `multistep simulate --trace` (s).
const TRACE_INTERVAL: f64 = 10e-6;

#[derive(Default)]
struct Overrides {
    clock: Option<f64>,
    reverse: bool,
    microsteps: Option<u32>,
    supply: Option<f64>,
    mode: Option<String>,
    load_inertia: Option<f64>,
    load_torque: Option<f64>,
    damping_ratio: Option<f64>,
    dt: Option<f64>,
    trace: bool,
    trace_interval: Option<f64>,
}

impl Overrides {
    fn set(&mut self, k: &str, v: &Bound<'_, PyAny>) -> PyResult<bool> {
        if v.is_none() {
            return Ok(matches!(
                k,
                "clock"
                    | "reverse"
                    | "microsteps"
                    | "supply"
                    | "mode"
                    | "load_inertia"
                    | "load_torque"
                    | "damping_ratio"
                    | "dt"
                    | "trace"
                    | "trace_interval"
            ));
        }
        match k {
            "clock" => self.clock = Some(number(k, v)?),
            "reverse" => self.reverse = boolean(k, v)?,
            "microsteps" => {
                self.microsteps = Some(whole_in(k, v, 0, u32::MAX.into())? as u32);
            }
            "supply" => self.supply = Some(number(k, v)?),
            "mode" => self.mode = Some(string(k, v)?),
            "load_inertia" => self.load_inertia = Some(number(k, v)?),
            "load_torque" => self.load_torque = Some(number(k, v)?),
            "damping_ratio" => self.damping_ratio = Some(number(k, v)?),
            "dt" => self.dt = Some(number(k, v)?),
            "trace" => self.trace = boolean(k, v)?,
            "trace_interval" => self.trace_interval = Some(number(k, v)?),
            _ => return Ok(false),
        }
        Ok(true)
    }
}

/// Most trace rows one simulation returns (eight float64 columns: 640 MB).
pub const MAX_TRACE_ROWS: u64 = 10_000_000;

/// Refuses a trace of more than `MAX_TRACE_ROWS` rows before the run: one row every
/// `trace_interval` (at least every RK4 step) up to the end of the longest settling.
fn check_trace(motor: &Motor, cfg: &SimConfig, profile: &Profile) -> PyResult<()> {
    let edges = profile.steps();
    // a run the simulator refuses is left to say so itself
    let Ok(work) = check_work(motor, cfg, profile.duration(), edges) else {
        return Ok(());
    };
    let every = cfg
        .trace_interval
        .map_or(1.0, |ti| (ti / cfg.dt).round().max(1.0));
    let rows = ((work - edges as f64) / every).ceil() + 1.0;
    if rows > MAX_TRACE_ROWS as f64 {
        return Err(value_err(format!(
            "the trace would have up to {rows:.0} rows; a simulation returns at most \
             {MAX_TRACE_ROWS} (multistep.MAX_TRACE_ROWS): give a longer trace_interval"
        )));
    }
    Ok(())
}

/// Runs `f` on a thread of its own while this one, without the GIL, runs Python's signal
/// handlers; on Ctrl-C, `f`'s `stop` is set and, once `f` returns, the interrupt raised.
fn interruptible<T: Send>(py: Python<'_>, f: impl FnOnce(&AtomicBool) -> T + Send) -> PyResult<T> {
    let stop = AtomicBool::new(false);
    std::thread::scope(|s| {
        let (tx, rx) = mpsc::channel();
        let stop = &stop;
        s.spawn(move || tx.send(f(stop)));
        // no deadline: always a value (or the thread's panic, which the scope passes on)
        wait_for(py, rx, Some(stop), None)?.ok_or_else(|| value_err("no simulation result"))
    })
}

/// Simulates one move on a motor and driver, as `multistep simulate` does.
///
/// `motor` is a library name (57mm, 42mm, 20mm) or a path to a TOML motor file; the move
/// keywords are those of `plan`. `microsteps` per full step, `supply` (V), `mode` "rl" (PI
/// current loop, voltage clamped to the supply) or "ideal", `load_inertia` (kg·m²),
/// `load_torque` (N·m), `damping_ratio`, `dt` the RK4 step (s), `reverse`; unset ones come
/// from the motor file.
///
/// Returns a dict with the fields of `simulate --format json` (lost_steps, lost,
/// first_loss_s, following errors in °, move_time_s, …); with `trace=True` also "trace", a
/// dict of numpy arrays (t_s, commanded_deg, actual_deg, commanded_speed_deg_s,
/// actual_speed_deg_s, error_deg, ia_a, ib_a) sampled every `trace_interval` s (10 µs).
#[pyfunction]
#[pyo3(signature = (motor, **kwargs))]
#[pyo3(
    text_signature = "(motor, *, profile=None, steps=None, accel_time=None, cruise_time=None, \
    decel_time=None, start_speed=None, end_speed=None, rho=None, phi=None, psi=None, \
    segments=None, vmax=None, amax=None, jmax=None, smax=None, clock=50e6, reverse=False, \
    microsteps=None, supply=None, mode='rl', load_inertia=None, load_torque=None, \
    damping_ratio=None, dt=1e-6, trace=False, trace_interval=1e-5)"
)]
pub fn simulate(
    py: Python<'_>,
    motor: &Bound<'_, PyAny>,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<Py<PyAny>> {
    let mut mv = MoveKw::default();
    let mut o = Overrides::default();
    each_kw("simulate", kwargs, |k, v| Ok(o.set(k, v)? || mv.set(k, v)?))?;
    let name: PathBuf = motor.extract().map_err(|_| {
        crate::errors::type_err(
            "motor must be a library name (57mm, 42mm, 20mm) or a path to a TOML file",
        )
    })?;
    let name = name
        .to_str()
        .ok_or_else(|| value_err("the motor file's path is not valid UTF-8"))?
        .to_string();
    let mut motor = Motor::load(&name).map_err(|e| sim_err(py, e))?;
    if let Some(j) = o.load_inertia {
        motor.load_inertia = j;
    }
    if let Some(t) = o.load_torque {
        motor.load_torque = t;
    }
    if let Some(z) = o.damping_ratio {
        motor.damping_ratio = z;
    }
    motor.validate().map_err(|e| sim_err(py, e))?;
    let mut cfg = SimConfig::for_motor(&motor);
    if let Some(m) = &o.mode {
        cfg.driver.mode = m.parse::<DriverMode>().map_err(value_err)?;
    }
    cfg.dt = o.dt.unwrap_or(DEFAULT_DT);
    if let Some(m) = o.microsteps {
        cfg.driver.microsteps = m;
    }
    if let Some(v) = o.supply {
        cfg.driver.supply_voltage = v;
    }
    if o.trace {
        let iv = o.trace_interval.unwrap_or(TRACE_INTERVAL);
        if !(iv.is_finite() && iv > 0.0) {
            return Err(value_err(format!(
                "trace_interval must be a number of seconds > 0 (got {iv})"
            )));
        }
        cfg.trace_interval = Some(iv);
    }
    let clock = o.clock.unwrap_or(DEFAULT_CLOCK_HZ);
    let profile = Profile::plan_on_clock(&mv.spec().resolve().map_err(|e| plan_err(py, e))?, clock)
        .map_err(|e| plan_err(py, e))?;
    let dir = if o.reverse { -1.0 } else { 1.0 };
    if o.trace {
        check_trace(&motor, &cfg, &profile)?;
    }
    // as `simulate_profile`, with an edge stream that Ctrl-C can end
    if cfg.peak_speed_hint.is_none() {
        let micro = motor.microstep_angle(cfg.driver.microsteps);
        cfg.peak_speed_hint = Some(profile.peak_speed() * micro);
    }
    let work = (profile.duration(), profile.steps());
    let gen = EdgeGenerator::new(profile, clock).map_err(|e| plan_err(py, e))?;
    let r = interruptible(py, |stop| {
        let edges = gen.take_while(|_| !stop.load(Ordering::Relaxed));
        run_planned(&motor, &cfg, edges, clock, dir, work)
    })?
    .map_err(|e| sim_err(py, e))?;
    let text = serde_json::to_string(&r).map_err(|e| value_err(e.to_string()))?;
    let out = py.import("json")?.call_method1("loads", (text,))?;
    if o.trace {
        let t = PyDict::new(py);
        let col = |f: fn(&multistep_sim::TraceRow) -> f64| -> Vec<f64> {
            r.trace.iter().map(f).collect()
        };
        t.set_item("t_s", PyArray1::from_vec(py, col(|r| r.t)))?;
        t.set_item(
            "commanded_deg",
            PyArray1::from_vec(py, col(|r| r.commanded_deg)),
        )?;
        t.set_item("actual_deg", PyArray1::from_vec(py, col(|r| r.actual_deg)))?;
        t.set_item(
            "commanded_speed_deg_s",
            PyArray1::from_vec(py, col(|r| r.commanded_speed_deg_s)),
        )?;
        t.set_item(
            "actual_speed_deg_s",
            PyArray1::from_vec(py, col(|r| r.actual_speed_deg_s)),
        )?;
        t.set_item("error_deg", PyArray1::from_vec(py, col(|r| r.error_deg)))?;
        t.set_item("ia_a", PyArray1::from_vec(py, col(|r| r.ia)))?;
        t.set_item("ib_a", PyArray1::from_vec(py, col(|r| r.ib)))?;
        out.set_item("trace", t)?;
    }
    Ok(out.unbind())
}
