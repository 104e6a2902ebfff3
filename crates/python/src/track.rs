//! `multistep.track(...)`: the edges of open-ended motion, as `multistep plan --track`
//! prints them, from the core's tracker (float ramps, or integer ones with `integer=True`).

use crate::args::{boolean, number, type_name};
use crate::errors::{track_err, type_err, value_err};
use crate::plan::{MAX_EDGES, SLICE_EDGES};
use multistep_core::int::IntRamp;
use multistep_core::track::{RampEdges, TrackerOf};
use multistep_core::{EdgeGenerator, Rate, TrackError, TrackRun, DEFAULT_CLOCK_HZ};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyFloat, PyInt, PyString};

/// A rate as the protocol and the command line read it (a str: decimal or `NUM/DEN`), an
/// int, an exact fraction (anything with int `numerator` and `denominator`, such as
/// `fractions.Fraction`) or a float (its exact binary value).
pub fn rate(py: Python<'_>, v: &Bound<'_, PyAny>) -> PyResult<Rate> {
    let r = if v.is_instance_of::<PyString>() {
        Rate::parse(&v.extract::<String>()?)
    } else if v.is_instance_of::<PyBool>() {
        return Err(type_err(
            "rate must be a str, int, Fraction or float, not bool",
        ));
    } else if v.is_instance_of::<PyFloat>() {
        Rate::from_f64(v.extract()?)
    } else if v.is_instance_of::<PyInt>() || v.hasattr("denominator")? {
        let part = |name: &str| -> PyResult<Bound<'_, PyAny>> {
            let p = v.getattr(name)?;
            if p.is_instance_of::<PyInt>() {
                Ok(p)
            } else {
                Err(type_err(format!("rate's {name} must be an int")))
            }
        };
        let (n, d) = (part("numerator")?, part("denominator")?);
        let sign = n.lt(0)? != d.lt(0)?;
        match (n.abs()?.extract::<u128>(), d.abs()?.extract::<u128>()) {
            (Ok(_), Ok(_)) if sign => Err(TrackError::NegativeRate),
            (Ok(n), Ok(d)) => Rate::new(n, d),
            _ => Err(TrackError::RateTooFine),
        }
    } else {
        return Err(type_err(format!(
            "rate must be a str, int, Fraction or float, not {}",
            type_name(v)
        )));
    };
    r.map_err(|e| track_err(py, e))
}

/// Most edges `run` can give: the ramp's position at the end of the run (or of the ramp),
/// then at most `rate·t + 1` in the `t` seconds of cruise after it, and two for rounding.
fn most_edges<R: RampEdges>(tr: &TrackerOf<R>, run: &TrackRun) -> f64 {
    let (ramp, ramp_s) = tr.ramp_profile().map_or((0.0, 0.0), |p| {
        let t = run.duration.min(p.duration());
        (p.position(t).ceil(), t)
    });
    ramp + (run.rate.to_f64() * (run.duration - ramp_s)).ceil() + 3.0
}

/// Every edge of `run` up to its last tick, from a tracker whose ramps `R` runs; a run
/// that could give more than `MAX_EDGES` is refused before any is made.
fn edges<R: RampEdges + Send>(py: Python<'_>, run: &TrackRun, clock: f64) -> PyResult<Vec<u64>> {
    let (tr, end) = run.start::<R>(clock).map_err(|e| track_err(py, e))?;
    let most = most_edges(&tr, run);
    if most > MAX_EDGES as f64 {
        return Err(value_err(format!(
            "track returns at most {MAX_EDGES} edges (multistep.MAX_EDGES); this run \
             could give {most:.0} (up to {} steps/s for {} s): ask for a shorter duration",
            run.rate.to_f64().max(run.start_speed),
            run.duration
        )));
    }
    let mut out = Vec::with_capacity(most as usize);
    let mut tr = tr;
    // a slice at a time without the GIL, letting Ctrl-C in between
    loop {
        let before = out.len();
        py.detach(|| out.extend(tr.by_ref().take_while(|&e| e <= end).take(SLICE_EDGES)));
        if out.len() - before < SLICE_EDGES {
            return Ok(out);
        }
        if out.len() as u64 > MAX_EDGES {
            return Err(value_err(format!(
                "track returns at most {MAX_EDGES} edges (multistep.MAX_EDGES)"
            )));
        }
        py.check_signals()?;
    }
}

/// The edges of open-ended motion, exactly as `multistep plan --track RATE --duration S`
/// prints them: a ramp from `start_speed` to `rate` within `amax` (S-curve with `jmax`),
/// then a cruise at exactly `rate`; every edge (ticks at `clock` Hz) up to `duration` s.
///
/// `rate` is steps/s: a str (`"46.4228"`, `"15041/324"`), an int, a `fractions.Fraction`,
/// or a float (its exact binary value). `amax` is needed unless `start_speed` is the rate.
/// `integer=True` runs the integer tracker (trapezoid and S-curve ramps): the same edges.
///
/// Raises `PlanError` (a `ValueError`) with the command line's message for a rate or limit
/// it refuses, `TypeError` for a value of the wrong type.
#[pyfunction]
#[pyo3(signature = (rate, duration, *, amax = None, start_speed = None, jmax = None, clock = None, integer = None))]
#[pyo3(
    text_signature = "(rate, duration, *, amax=None, start_speed=0.0, jmax=None, clock=50e6, \
    integer=False)"
)]
#[allow(clippy::too_many_arguments)]
pub fn track<'py>(
    py: Python<'py>,
    rate: &Bound<'py, PyAny>,
    duration: &Bound<'py, PyAny>,
    amax: Option<&Bound<'py, PyAny>>,
    start_speed: Option<&Bound<'py, PyAny>>,
    jmax: Option<&Bound<'py, PyAny>>,
    clock: Option<&Bound<'py, PyAny>>,
    integer: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<u64>>> {
    let opt = |name: &str, v: Option<&Bound<'py, PyAny>>| -> PyResult<Option<f64>> {
        v.filter(|v| !v.is_none())
            .map(|v| number(name, v))
            .transpose()
    };
    let run = TrackRun {
        rate: self::rate(py, rate)?,
        duration: number("duration", duration)?,
        start_speed: opt("start_speed", start_speed)?.unwrap_or(0.0),
        amax: opt("amax", amax)?,
        jmax: opt("jmax", jmax)?,
    };
    let clock = opt("clock", clock)?.unwrap_or(DEFAULT_CLOCK_HZ);
    let integer = integer.filter(|v| !v.is_none());
    let edges = if integer.map(|v| boolean("integer", v)).transpose()? == Some(true) {
        edges::<IntRamp>(py, &run, clock)?
    } else {
        edges::<EdgeGenerator>(py, &run, clock)?
    };
    Ok(PyArray1::from_vec(py, edges))
}
