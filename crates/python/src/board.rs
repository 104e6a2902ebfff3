//! `multistep.Board`: a session with one controller board. Each method builds a protocol
//! `Command`, written as the protocol writes it, so the words on the line are the
//! protocol's own; the link sends it with a deadline and lets Ctrl-C in.

use crate::args::{each_kw, number, signed, string};
use crate::errors::{board_err, closed_err, refused_err, timeout_err, type_err, value_err};
use crate::link::Link;
use multistep_controller::client::Endpoint;
use multistep_controller::protocol::{
    parse_amount, Amount, RateArg, SignedRate, TrackOpts, MAX_LEASE,
};
use multistep_controller::{AxisState, AxisStatus, Command, MoveOpts};
use multistep_core::Param;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyInt, PyList, PyString};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard, TryLockError};
use std::time::{Duration, Instant};

/// How long one call may wait for the board's reply unless the Board is given another
/// timeout (s), and the range it may be given.
pub const DEFAULT_TIMEOUT: f64 = 10.0;
pub const MIN_TIMEOUT: f64 = 0.001;
pub const MAX_TIMEOUT: f64 = 3600.0;

/// How often `wait` asks the board for its axes' states (shorter than the link's slice, so
/// Ctrl-C is seen as soon).
const POLL: Duration = Duration::from_millis(20);

/// Move keywords to the protocol's move options.
fn move_opts(func: &str, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<MoveOpts> {
    let mut o = MoveOpts::default();
    each_kw(func, kwargs, |k, v| {
        if v.is_none() {
            return Ok(matches!(k, "preset" | "profile") || Param::named(k).is_some());
        }
        match k {
            "preset" => o.preset = Some(string(k, v)?),
            "profile" => o.profile = Some(string(k, v)?),
            _ => match Param::named(k) {
                Some(p) => *(p.slot)(&mut o.params) = Some(number(k, v)?),
                None => return Ok(false),
            },
        }
        Ok(true)
    })?;
    Ok(o)
}

/// An int is microsteps; a str is read as the protocol reads it (`"-400"`, `"12.5u"`).
fn amount(name: &str, v: &Bound<'_, PyAny>) -> PyResult<Amount> {
    if v.is_instance_of::<PyString>() {
        let s: String = v.extract()?;
        return parse_amount(s.trim()).map_err(|e| value_err(e.to_string()));
    }
    if v.is_instance_of::<PyInt>() && !v.is_instance_of::<PyBool>() {
        return signed(name, v).map(Amount::Steps);
    }
    Err(type_err(format!(
        "{name} is microsteps as an int, or user units as a str such as '12.5u'"
    )))
}

/// A str as the protocol reads it (a rate, or a stored rate's name); a number or an exact
/// fraction by its sign and exact magnitude.
fn rate_arg(py: Python<'_>, v: &Bound<'_, PyAny>) -> PyResult<RateArg> {
    if v.is_instance_of::<PyString>() {
        let s: String = v.extract()?;
        let s = s.trim();
        return match SignedRate::parse(s) {
            Some(r) => r.map(RateArg::Value).map_err(|e| value_err(e.to_string())),
            None => Ok(RateArg::Preset(s.to_string())),
        };
    }
    let negative = !v.is_instance_of::<PyBool>() && v.lt(0).unwrap_or(false);
    let mag = if negative { v.neg()? } else { v.clone() };
    Ok(RateArg::Value(SignedRate {
        negative,
        rate: crate::track::rate(py, &mag)?,
        units: false,
    }))
}

fn lines(py: Python<'_>, data: Vec<String>) -> PyResult<Py<PyAny>> {
    Ok(PyList::new(py, data)?.into_any().unbind())
}

/// `key=value` data lines as a dict of str.
fn pairs(py: Python<'_>, data: &[String]) -> PyResult<Py<PyAny>> {
    let d = PyDict::new(py);
    for l in data {
        match l.split_once('=') {
            Some((k, v)) => d.set_item(k, v)?,
            None => d.set_item(l, "")?,
        }
    }
    Ok(d.into_any().unbind())
}

/// A Board's timeout from Python: seconds from `MIN_TIMEOUT` to `MAX_TIMEOUT`.
fn timeout_arg(v: &Bound<'_, PyAny>) -> PyResult<f64> {
    let t = number("timeout", v)?;
    if !(MIN_TIMEOUT..=MAX_TIMEOUT).contains(&t) {
        return Err(value_err(format!(
            "timeout must be a number of seconds from {MIN_TIMEOUT} to {MAX_TIMEOUT} (got {t})"
        )));
    }
    Ok(t)
}

/// A positive, finite number of `unit`, at most `max`.
fn positive(
    name: &str,
    unit: &str,
    v: Option<&Bound<'_, PyAny>>,
    max: f64,
) -> PyResult<Option<f64>> {
    let Some(v) = v.filter(|v| !v.is_none()) else {
        return Ok(None);
    };
    let x = number(name, v)?;
    if !(x > 0.0 && x.is_finite() && x <= max) {
        let range = if max.is_finite() {
            format!("> 0 and at most {max}")
        } else {
            "> 0 and finite".to_string()
        };
        return Err(value_err(format!(
            "{name} must be a number of {unit} {range} (got {x})"
        )));
    }
    Ok(Some(x))
}

/// A connection to one board (`multistep serve`, or a real one) over TCP or a serial line.
#[pyclass(module = "multistep")]
pub struct Board {
    link: Mutex<Option<Link>>,
    endpoint: String,
    /// Seconds, as f64 bits: set from any thread while another waits in a call.
    timeout: AtomicU64,
}

impl Board {
    fn timeout(&self) -> Duration {
        Duration::from_secs_f64(f64::from_bits(self.timeout.load(Ordering::Relaxed)))
    }

    /// The link, once no other thread's call holds it; the GIL is released meanwhile (the
    /// holder needs it between its slices) and Ctrl-C ends the wait.
    fn lock(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, Option<Link>>> {
        loop {
            match self.link.try_lock() {
                Ok(g) => return Ok(g),
                Err(TryLockError::Poisoned(p)) => return Ok(p.into_inner()),
                Err(TryLockError::WouldBlock) => {
                    py.detach(|| std::thread::sleep(Duration::from_millis(1)));
                    py.check_signals()?;
                }
            }
        }
    }

    fn send(&self, py: Python<'_>, cmd: Command) -> PyResult<Vec<String>> {
        let mut g = self.lock(py)?;
        let link = g.as_mut().ok_or_else(|| closed_err(py))?;
        link.send(py, &cmd, self.timeout())?
            .map_err(|r| refused_err(py, r))
    }

    /// `status json AXIS…` (every axis when `axes` is empty), parsed.
    fn status_of(&self, py: Python<'_>, axes: &[String]) -> PyResult<Vec<AxisStatus>> {
        let data = self.send(
            py,
            Command::Status {
                axes: axes.to_vec(),
                json: true,
            },
        )?;
        let line = data
            .first()
            .ok_or_else(|| board_err(py, "status json gave no data".into()))?;
        serde_json::from_str(line).map_err(|e| board_err(py, format!("bad status json: {e}")))
    }

    fn axes(names: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<Vec<String>> {
        names
            .iter()
            .map(|a| string("axis", &a))
            .collect::<PyResult<_>>()
    }
}

#[pymethods]
impl Board {
    /// Connects to `endpoint`: `"tcp://HOST:PORT"` or `"serial:DEVICE"` (115200 8N1).
    /// `timeout` (s, 0.001 to 3600, default 10) bounds the connection and each call's
    /// wait for the board's reply; past it a call raises `BoardTimeoutError`.
    #[new]
    #[pyo3(signature = (endpoint, timeout = None))]
    #[pyo3(text_signature = "(endpoint, timeout=10.0)")]
    fn new(py: Python<'_>, endpoint: &str, timeout: Option<&Bound<'_, PyAny>>) -> PyResult<Board> {
        let t = match timeout.filter(|v| !v.is_none()) {
            Some(v) => timeout_arg(v)?,
            None => DEFAULT_TIMEOUT,
        };
        let ep: Endpoint = endpoint
            .parse()
            .map_err(|e: multistep_controller::CtlError| value_err(e.to_string()))?;
        let link = Link::connect(py, &ep, Duration::from_secs_f64(t))?;
        Ok(Board {
            link: Mutex::new(Some(link)),
            endpoint: endpoint.to_string(),
            timeout: AtomicU64::new(t.to_bits()),
        })
    }

    /// Longest wait for the board's reply to one call (s, 0.001 to 3600).
    #[getter(timeout)]
    fn get_timeout(&self) -> f64 {
        f64::from_bits(self.timeout.load(Ordering::Relaxed))
    }

    #[setter(timeout)]
    fn set_timeout(&self, v: &Bound<'_, PyAny>) -> PyResult<()> {
        let t = timeout_arg(v)?;
        self.timeout.store(t.to_bits(), Ordering::Relaxed);
        Ok(())
    }

    /// Relative move of `axis` by `distance`: microsteps (int) or user units (`"12.5u"`).
    /// Keywords: preset, profile, vmax (steps/s), amax (steps/s²), jmax (steps/s³),
    /// smax (steps/s⁴), accel_time, cruise_time, decel_time (s), start_speed, end_speed
    /// (steps/s), rho, phi, psi. Returns the board's data lines (`X target=…`).
    #[pyo3(signature = (axis, distance, **opts))]
    fn r#move(
        &self,
        py: Python<'_>,
        axis: &str,
        distance: &Bound<'_, PyAny>,
        opts: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<PyAny>> {
        let cmd = Command::Move {
            axis: axis.to_string(),
            by: amount("distance", distance)?,
            opts: move_opts("move", opts)?,
        };
        lines(py, self.send(py, cmd)?)
    }

    /// Absolute move of `axis` to `position` (microsteps, or `"12.5u"`); keywords as `move`.
    #[pyo3(signature = (axis, position, **opts))]
    fn moveto(
        &self,
        py: Python<'_>,
        axis: &str,
        position: &Bound<'_, PyAny>,
        opts: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<PyAny>> {
        let cmd = Command::MoveTo {
            axis: axis.to_string(),
            to: amount("position", position)?,
            opts: move_opts("moveto", opts)?,
        };
        lines(py, self.send(py, cmd)?)
    }

    /// Moves several axes together from the same tick: `targets` maps axis to distance
    /// (or position with `absolute=True`); `sync=True` also ends them on the same tick.
    #[pyo3(signature = (targets, *, absolute = false, sync = false, **opts))]
    fn group(
        &self,
        py: Python<'_>,
        targets: &Bound<'_, PyDict>,
        absolute: bool,
        sync: bool,
        opts: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<PyAny>> {
        let mut t = Vec::new();
        for (k, v) in targets.iter() {
            let axis = string("axis", &k)?;
            let a = amount(&format!("target of {axis}"), &v)?;
            t.push((axis, a));
        }
        let cmd = Command::Group {
            absolute,
            targets: t,
            sync,
            opts: move_opts("group", opts)?,
        };
        lines(py, self.send(py, cmd)?)
    }

    /// Homes `axis` on its Hall sensor (returns when the board accepted it; `wait` for it).
    fn home(&self, py: Python<'_>, axis: &str) -> PyResult<()> {
        self.send(
            py,
            Command::Home {
                axis: axis.to_string(),
            },
        )
        .map(drop)
    }

    /// Controlled stop of `axis`, or of every axis without one.
    #[pyo3(signature = (axis = None))]
    fn stop(&self, py: Python<'_>, axis: Option<&str>) -> PyResult<()> {
        self.send(
            py,
            Command::Stop {
                axis: axis.map(str::to_string),
            },
        )
        .map(drop)
    }

    /// Emergency stop: every axis halts on the spot; motion is refused until `reset`.
    fn estop(&self, py: Python<'_>) -> PyResult<()> {
        self.send(py, Command::EStop).map(drop)
    }

    /// Clears an emergency stop and faults.
    fn reset(&self, py: Python<'_>) -> PyResult<()> {
        self.send(py, Command::Reset).map(drop)
    }

    /// Waits until the axes (every axis without any) are idle; an axis in fault raises
    /// `BoardError`, the `timeout` (s, ≥ 0; inf: none) `BoardTimeoutError`.
    #[pyo3(signature = (*axes, timeout = None))]
    #[pyo3(text_signature = "($self, *axes, timeout=600.0)")]
    fn wait(
        &self,
        py: Python<'_>,
        axes: &Bound<'_, pyo3::types::PyTuple>,
        timeout: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let axes = Self::axes(axes)?;
        let timeout = match timeout.filter(|v| !v.is_none()) {
            Some(v) => number("timeout", v)?,
            None => 600.0,
        };
        if timeout.is_nan() || timeout < 0.0 {
            return Err(value_err(format!(
                "timeout must be a number of seconds ≥ 0 (got {timeout})"
            )));
        }
        // beyond what the clock can add (inf included): no deadline
        let deadline = Duration::try_from_secs_f64(timeout)
            .ok()
            .and_then(|t| Instant::now().checked_add(t));
        loop {
            let st = self.status_of(py, &axes)?;
            if let Some(s) = st.iter().find(|s| s.state == AxisState::Fault) {
                return Err(board_err(
                    py,
                    format!(
                        "axis {} is in fault: {}",
                        s.axis,
                        s.fault.as_deref().unwrap_or("?")
                    ),
                ));
            }
            if st.iter().all(|s| s.state == AxisState::Idle) {
                return Ok(());
            }
            if deadline.is_some_and(|d| Instant::now() > d) {
                let busy: Vec<&str> = st
                    .iter()
                    .filter(|s| s.state != AxisState::Idle)
                    .map(|s| s.axis.as_str())
                    .collect();
                return Err(timeout_err(
                    py,
                    format!("timed out waiting for {}", busy.join(", ")),
                ));
            }
            py.detach(|| std::thread::sleep(POLL));
            py.check_signals()?;
        }
    }

    /// Status of the axes (every axis without any): a list of dicts with the fields of
    /// `status json` (position in microsteps, speed in steps/s, state, homed, trusted, …).
    #[pyo3(signature = (*axes))]
    fn status(
        &self,
        py: Python<'_>,
        axes: &Bound<'_, pyo3::types::PyTuple>,
    ) -> PyResult<Py<PyAny>> {
        let axes = Self::axes(axes)?;
        let st = self.status_of(py, &axes)?;
        let text = serde_json::to_string(&st).map_err(|e| value_err(e.to_string()))?;
        Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
    }

    /// One setting of `axis` as a str, or every setting as a dict without `key`.
    #[pyo3(signature = (axis, key = None))]
    fn get(&self, py: Python<'_>, axis: &str, key: Option<&str>) -> PyResult<Py<PyAny>> {
        let data = self.send(
            py,
            Command::Get {
                axis: axis.to_string(),
                key: key.map(str::to_string),
            },
        )?;
        match key {
            None => pairs(py, &data),
            Some(k) => {
                let v = data
                    .iter()
                    .find_map(|l| l.split_once('=').filter(|p| p.0 == k).map(|p| p.1))
                    .or_else(|| data.first().map(|l| l.as_str()))
                    .unwrap_or("");
                Ok(PyString::new(py, v).into_any().unbind())
            }
        }
    }

    /// Changes one setting (stored on the board); `None` clears an optional one.
    fn set(&self, py: Python<'_>, axis: &str, key: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let value = if value.is_none() {
            "none".to_string()
        } else if value.is_instance_of::<PyBool>() {
            (if value.extract::<bool>()? {
                "true"
            } else {
                "false"
            })
            .to_string()
        } else {
            value.str()?.to_string()
        };
        self.send(
            py,
            Command::Set {
                axis: axis.to_string(),
                key: key.to_string(),
                value,
            },
        )
        .map(drop)
    }

    /// Stores the current positions of `axes` (every axis without any) under `name`.
    #[pyo3(signature = (name, *axes))]
    fn save(
        &self,
        py: Python<'_>,
        name: &str,
        axes: &Bound<'_, pyo3::types::PyTuple>,
    ) -> PyResult<Py<PyAny>> {
        let axes = Self::axes(axes)?;
        let data = self.send(
            py,
            Command::Save {
                name: name.to_string(),
                axes,
            },
        )?;
        lines(py, data)
    }

    /// Group move to the named position `name`; keywords as `move`.
    #[pyo3(signature = (name, **opts))]
    fn goto(
        &self,
        py: Python<'_>,
        name: &str,
        opts: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<PyAny>> {
        let cmd = Command::Goto {
            name: name.to_string(),
            opts: move_opts("goto", opts)?,
        };
        lines(py, self.send(py, cmd)?)
    }

    /// The named positions, one line each (`NAME X=… Y=…`).
    fn positions(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        lines(py, self.send(py, Command::Positions)?)
    }

    /// Deletes the named position `name`.
    fn forget(&self, py: Python<'_>, name: &str) -> PyResult<()> {
        self.send(
            py,
            Command::Forget {
                name: name.to_string(),
            },
        )
        .map(drop)
    }

    /// Stores a speed preset `name` from move keywords (profile, vmax, amax, …).
    #[pyo3(signature = (name, **opts))]
    fn preset(&self, py: Python<'_>, name: &str, opts: Option<&Bound<'_, PyDict>>) -> PyResult<()> {
        let cmd = Command::Preset {
            name: name.to_string(),
            opts: move_opts("preset", opts)?,
        };
        self.send(py, cmd).map(drop)
    }

    /// The presets, one line each (`NAME vmax=… …`).
    fn presets(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        lines(py, self.send(py, Command::Presets)?)
    }

    /// Board facts (`board`, `version`, `axes`, `clock_hz`, `tick`, `estop`, …) as a dict.
    fn info(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let data = self.send(py, Command::Info)?;
        pairs(py, &data)
    }

    /// The board's firmware version line.
    fn version(&self, py: Python<'_>) -> PyResult<String> {
        Ok(self.send(py, Command::Version)?.join("\n"))
    }

    /// Simulation only: the mechanics of `axis` lose `steps` steps the count does not see.
    fn sim_slip(&self, py: Python<'_>, axis: &str, steps: &Bound<'_, PyAny>) -> PyResult<()> {
        let steps = signed("steps", steps)?;
        self.send(
            py,
            Command::SimSlip {
                axis: axis.to_string(),
                steps,
            },
        )
        .map(drop)
    }

    /// Open-ended motion: ramps `axis` to `rate` and runs at exactly that rate until
    /// `stop` (or a new `track`, which changes the rate; 0 stops). `rate` is steps/s as a
    /// str (`"15041/324"`, `"-46.4228"`, `"0.5u"` in user units/s, or a stored rate's
    /// name), an int, a `fractions.Fraction` or a float (its exact binary value); negative
    /// runs backwards. `amax` (steps/s²) sets the ramps' acceleration, `lease` (s, at most
    /// 60) stops the axis unless the command comes again within it. Returns the board's
    /// data lines.
    #[pyo3(signature = (axis, rate, *, amax = None, lease = None))]
    fn track(
        &self,
        py: Python<'_>,
        axis: &str,
        rate: &Bound<'_, PyAny>,
        amax: Option<&Bound<'_, PyAny>>,
        lease: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        let opts = TrackOpts {
            amax: positive("amax", "steps/s²", amax, f64::INFINITY)?,
            lease: positive("lease", "seconds", lease, MAX_LEASE)?,
        };
        let cmd = Command::Track {
            axis: axis.to_string(),
            rate: rate_arg(py, rate)?,
            opts,
        };
        lines(py, self.send(py, cmd)?)
    }

    /// Stores the named rate `name` (kept with the board), for `track(axis, name)`.
    fn rate(&self, py: Python<'_>, name: &str, rate: &Bound<'_, PyAny>) -> PyResult<()> {
        let RateArg::Value(rate) = rate_arg(py, rate)? else {
            return Err(value_err(format!("'{}' is not a rate", rate.str()?)));
        };
        let cmd = Command::RatePreset {
            name: name.to_string(),
            rate,
        };
        self.send(py, cmd).map(drop)
    }

    /// The named rates, one line each (`NAME RATE`).
    fn rates(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        lines(py, self.send(py, Command::Rates)?)
    }

    /// Releases (de-energizes) the driver of idle `axis`; a released axis may be turned by
    /// hand and becomes untrusted unless the board keeps its position.
    fn release(&self, py: Python<'_>, axis: &str) -> PyResult<()> {
        let axis = axis.to_string();
        self.send(py, Command::Release { axis }).map(drop)
    }

    /// Energizes the driver of `axis`.
    fn energize(&self, py: Python<'_>, axis: &str) -> PyResult<()> {
        let axis = axis.to_string();
        self.send(py, Command::Energize { axis }).map(drop)
    }

    /// Sends one raw protocol line; returns its data lines.
    fn raw(&self, py: Python<'_>, line: &str) -> PyResult<Py<PyAny>> {
        let mut g = self.lock(py)?;
        let link = g.as_mut().ok_or_else(|| closed_err(py))?;
        let data = link
            .request(py, line, self.timeout())?
            .map_err(|r| refused_err(py, r))?;
        drop(g);
        lines(py, data)
    }

    /// Closes the connection (further calls raise `BoardConnectionError`).
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        self.lock(py)?.take();
        Ok(())
    }

    fn __enter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    #[pyo3(signature = (*_exc))]
    fn __exit__(&self, py: Python<'_>, _exc: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.close(py)?;
        Ok(false)
    }

    /// The endpoint given to the constructor.
    #[getter]
    fn endpoint(&self) -> String {
        self.endpoint.clone()
    }

    fn __repr__(&self) -> String {
        format!("Board('{}')", self.endpoint)
    }
}
