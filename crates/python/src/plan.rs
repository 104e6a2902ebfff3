//! `multistep.plan(...)` and the `Plan` it returns: the core's edge generator writing
//! straight into numpy arrays, whole or in chunks.

use crate::args::{number, segment_list, str_arg, whole, whole_in};
use crate::errors::{plan_err, value_err};
use multistep_core::{
    ClockCheck, EdgeGenerator, LimitsMove, Move, MoveName, MoveParams, MoveSpec, PhaseMove,
    PlanSummary, Profile, Segment, DEFAULT_CLOCK_HZ,
};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use std::borrow::Borrow;
use std::sync::{Mutex, OnceLock};

/// Plans one move, exactly as `multistep plan` does, and returns a `Plan`.
///
/// Give the keywords of one mode:
///
/// - phase mode: `steps` with `accel_time`, `cruise_time`, `decel_time` (s);
/// - limits mode: `steps` with `vmax` (steps/s), `amax` (steps/s²), and `jmax` (steps/s³)
///   for `scurve`, `jmax` and `smax` (steps/s⁴) for `scurve4`;
/// - segment mode: `segments=[(v0, T, n), …]` (steps/s, s, steps) and nothing else.
///
/// `profile` is the family (trapezoid, parabolic, exponential, sine, scurve, scurve4;
/// default trapezoid), `start_speed` and `end_speed` in steps/s (default 0), `rho` the
/// exponential time constant as a fraction of the phase time (0.25), `phi` and `psi` the
/// S-curve jerk and snap fractions in (0, 0.5] (0.5), `clock` the tick rate in Hz (50e6).
///
/// Raises `PlanError` (a `ValueError`) with the command line's message for a move that
/// cannot be planned, `TypeError` for a wrong type or an unknown keyword.
#[pyfunction]
// keywords are matched by name in this order, one comparison each: the limits mode's
// first (what a host planning a move per command gives)
#[pyo3(signature = (
    *, steps=None, vmax=None, amax=None, profile=None, jmax=None, smax=None,
    accel_time=None, cruise_time=None, decel_time=None, start_speed=None, end_speed=None,
    rho=None, phi=None, psi=None, segments=None, clock=None
))]
#[pyo3(
    text_signature = "(*, steps=None, vmax=None, amax=None, profile=None, jmax=None, \
    smax=None, accel_time=None, cruise_time=None, decel_time=None, start_speed=None, \
    end_speed=None, rho=None, phi=None, psi=None, segments=None, clock=50e6)"
)]
#[allow(clippy::too_many_arguments)]
pub fn plan(
    py: Python<'_>,
    steps: Option<&Bound<'_, PyAny>>,
    vmax: Option<&Bound<'_, PyAny>>,
    amax: Option<&Bound<'_, PyAny>>,
    profile: Option<&Bound<'_, PyAny>>,
    jmax: Option<&Bound<'_, PyAny>>,
    smax: Option<&Bound<'_, PyAny>>,
    accel_time: Option<&Bound<'_, PyAny>>,
    cruise_time: Option<&Bound<'_, PyAny>>,
    decel_time: Option<&Bound<'_, PyAny>>,
    start_speed: Option<&Bound<'_, PyAny>>,
    end_speed: Option<&Bound<'_, PyAny>>,
    rho: Option<&Bound<'_, PyAny>>,
    phi: Option<&Bound<'_, PyAny>>,
    psi: Option<&Bound<'_, PyAny>>,
    segments: Option<&Bound<'_, PyAny>>,
    clock: Option<&Bound<'_, PyAny>>,
) -> PyResult<Plan> {
    // named parameters: Python matches the keywords (no dict of them is made), and an
    // unknown one is its own TypeError; read in this order, the first wrong one raises
    let family = given(profile).map(|v| str_arg("profile", v)).transpose()?;
    let steps = given(steps).map(|v| whole("steps", v)).transpose()?;
    let mut params = MoveParams {
        accel_time: opt_number("accel_time", accel_time)?,
        cruise_time: opt_number("cruise_time", cruise_time)?,
        decel_time: opt_number("decel_time", decel_time)?,
        start_speed: opt_number("start_speed", start_speed)?,
        end_speed: opt_number("end_speed", end_speed)?,
        rho: opt_number("rho", rho)?,
        phi: opt_number("phi", phi)?,
        psi: opt_number("psi", psi)?,
        ..MoveParams::default()
    };
    let segments = given(segments).map(segment_list).transpose()?;
    params.vmax = opt_number("vmax", vmax)?;
    params.amax = opt_number("amax", amax)?;
    params.jmax = opt_number("jmax", jmax)?;
    params.smax = opt_number("smax", smax)?;
    let clock = opt_number("clock", clock)?.unwrap_or(DEFAULT_CLOCK_HZ);
    let spec = MoveSpec {
        profile: family.as_ref().map(|s| s.as_ref()),
        steps,
        params,
        segments: segments.as_deref().unwrap_or_default(),
    };
    let m = spec.resolve().map_err(|e| plan_err(py, e))?;
    // every error planning and playing raise, here; the pieces are made when first read
    let check = Profile::check_on_clock(&m, clock).map_err(|e| plan_err(py, e))?;
    let mode = MoveName::of(&m);
    let mv = match m {
        Move::Phase(p) => Planned::Phase(p),
        Move::Limits(l) => Planned::Limits(l),
        Move::Segments(_) => Planned::Segments(segments.unwrap_or_default()),
    };
    Ok(Plan {
        mv,
        clock,
        check,
        mode,
        profile: OnceLock::new(),
        edges: PyOnceLock::new(),
        periods: PyOnceLock::new(),
        summary: PyOnceLock::new(),
    })
}

/// A keyword's value; Python's `None` is not giving it.
#[inline(always)]
fn given<'a, 'py>(v: Option<&'a Bound<'py, PyAny>>) -> Option<&'a Bound<'py, PyAny>> {
    v.filter(|v| !v.is_none())
}

/// A number keyword, if given (inline: most keywords of a call are not).
#[inline(always)]
fn opt_number(name: &str, v: Option<&Bound<'_, PyAny>>) -> PyResult<Option<f64>> {
    match given(v) {
        Some(v) => number(name, v).map(Some),
        None => Ok(None),
    }
}

/// The move `plan` checked, kept to be planned again when first read: its pieces, bit for
/// bit (a segment move owns its segments).
enum Planned {
    Phase(PhaseMove),
    Limits(LimitsMove),
    Segments(Vec<Segment>),
}

impl Planned {
    fn as_move(&self) -> Move<'_> {
        match self {
            Planned::Phase(p) => Move::Phase(*p),
            Planned::Limits(l) => Move::Limits(*l),
            Planned::Segments(s) => Move::Segments(s),
        }
    }
}

/// A planned move. Edges are clock ticks (at `clock_hz`) from the start of the move.
#[pyclass(module = "multistep", frozen)]
pub struct Plan {
    /// The move, planned again (the same pieces, bit for bit) when first read.
    mv: Planned,
    clock: f64,
    check: ClockCheck,
    mode: MoveName,
    /// Boxed: the profile is kilobytes, which Python would zero and Rust copy on every
    /// call; a read makes its generator from it (edges are only made when read).
    profile: OnceLock<Box<Profile>>,
    edges: PyOnceLock<Py<PyArray1<u64>>>,
    periods: PyOnceLock<Py<PyArray1<u64>>>,
    summary: PyOnceLock<Py<PyAny>>,
}

/// Most edges one array holds (800 MB of uint64): `Plan.edges`, `Plan.periods`, a chunk
/// and `track` give no more, so no call fills memory until the process is killed; longer
/// moves stream through `Plan.chunks`.
pub const MAX_EDGES: u64 = 100_000_000;

/// A new uint64 array of `n` elements (at most `MAX_EDGES`) from numpy itself, so that
/// running out of memory is numpy's `MemoryError`, not a failed allocation in Rust.
fn empty_u64(py: Python<'_>, n: u64) -> PyResult<Bound<'_, PyArray1<u64>>> {
    if n > MAX_EDGES {
        return Err(value_err(format!(
            "the move has {n} steps; one array holds at most {MAX_EDGES} edges \
             (multistep.MAX_EDGES): read them with chunks()"
        )));
    }
    let n = usize::try_from(n).map_err(|_| value_err("the move has too many steps to hold"))?;
    let np = py.import("numpy")?;
    Ok(np
        .call_method1("empty", (n, "uint64"))?
        .cast_into::<PyArray1<u64>>()?)
}

/// Edges made between two runs of Python's signal handlers: about 25 ms of the slowest
/// family (exponential, 11 M edges/s), so Ctrl-C is seen within that.
pub const SLICE_EDGES: usize = 1 << 18;

/// Fills `out` with the next edges of `gen` (or their periods after `last`, updating it);
/// returns how many were written. Runs without the GIL, a slice at a time, and lets
/// Ctrl-C in between slices (then `gen` and `last` are part way: the caller drops them).
fn fill<P: Borrow<Profile> + Send>(
    py: Python<'_>,
    gen: &mut EdgeGenerator<P>,
    out: &mut [u64],
    mut periods: Option<&mut u64>,
) -> PyResult<usize> {
    let mut written = 0;
    for part in out.chunks_mut(SLICE_EDGES) {
        let last = periods.as_deref_mut();
        let k = py.detach(|| {
            let k = gen.fill(part);
            if let Some(last) = last {
                for x in &mut part[..k] {
                    let e = *x;
                    *x = e - *last;
                    *last = e;
                }
            }
            k
        });
        written += k;
        if k < part.len() {
            break;
        }
        py.check_signals()?;
    }
    Ok(written)
}

/// `PlanSummary::run`'s summary, its edges a slice at a time without the GIL and Python's
/// signal handlers between slices (a summary of 10¹² steps takes minutes).
fn summarise(
    py: Python<'_>,
    mode: MoveName,
    mut gen: EdgeGenerator<&Profile>,
) -> PyResult<PlanSummary> {
    let (mut min_p, mut max_p, mut last) = (u64::MAX, 0, 0);
    let part = SLICE_EDGES as u64;
    while let Some((lo, hi, l)) = py.detach(|| gen.period_extremes_for(last, part)) {
        (min_p, max_p, last) = (min_p.min(lo), max_p.max(hi), l);
        py.check_signals()?;
    }
    let p = gen.profile();
    let (vpk, apk) = p.peaks();
    Ok(PlanSummary {
        mode,
        steps: p.steps(),
        clock_hz: gen.clock(),
        duration_s: p.duration(),
        last_edge_tick: last,
        peak_speed_steps_per_s: vpk,
        peak_accel_steps_per_s2: apk,
        min_period_ticks: min_p,
        max_period_ticks: max_p,
        settled_edges: gen.settled_count(),
    })
}

fn read_only(a: &Bound<'_, PyArray1<u64>>) -> PyResult<()> {
    a.call_method(
        "setflags",
        (),
        Some(&[("write", false)].into_py_dict(a.py())?),
    )?;
    Ok(())
}

use pyo3::types::IntoPyDict;

impl Plan {
    /// The move's profile, planned on first use as `plan` checked it.
    fn profile(&self) -> PyResult<&Profile> {
        if let Some(p) = self.profile.get() {
            return Ok(p);
        }
        let p = Profile::plan_on_clock(&self.mv.as_move(), self.clock)
            .map_err(|e| value_err(e.to_string()))?;
        Ok(self.profile.get_or_init(|| Box::new(p)))
    }

    /// A generator at step 1 on the plan's profile.
    fn gen(&self) -> PyResult<EdgeGenerator<&Profile>> {
        EdgeGenerator::new(self.profile()?, self.clock).map_err(|e| value_err(e.to_string()))
    }

    fn whole(&self, py: Python<'_>, periods: bool) -> PyResult<Py<PyArray1<u64>>> {
        let mut gen = self.gen()?;
        let n = gen.remaining();
        let arr = empty_u64(py, n)?;
        {
            let mut rw = arr.try_readwrite()?;
            let out = rw.as_slice_mut()?;
            let mut last = 0u64;
            let k = fill(py, &mut gen, out, periods.then_some(&mut last))?;
            if k != out.len() {
                return Err(value_err(format!(
                    "the generator gave {k} edges for {} steps",
                    out.len()
                )));
            }
        }
        read_only(&arr)?;
        Ok(arr.unbind())
    }
}

#[pymethods]
impl Plan {
    /// Edge tick of every step (uint64, read-only, length `steps`): step i's edge is the
    /// tick nearest to its exact time, `floor(clock·t_i + ½)`.
    #[getter]
    fn edges(&self, py: Python<'_>) -> PyResult<Py<PyArray1<u64>>> {
        self.edges
            .get_or_try_init(py, || self.whole(py, false))
            .map(|a| a.clone_ref(py))
    }

    /// Ticks between consecutive edges (uint64, read-only); the first is the first edge.
    #[getter]
    fn periods(&self, py: Python<'_>) -> PyResult<Py<PyArray1<u64>>> {
        self.periods
            .get_or_try_init(py, || self.whole(py, true))
            .map(|a| a.clone_ref(py))
    }

    /// Edges (or periods) in arrays of at most `size` elements (1 to `MAX_EDGES`), for
    /// moves too large to hold: memory stays at one chunk however long the move.
    #[pyo3(signature = (size = None, periods = false))]
    #[pyo3(text_signature = "($self, size=1048576, periods=False)")]
    fn chunks(&self, size: Option<&Bound<'_, PyAny>>, periods: bool) -> PyResult<Chunks> {
        let size = match size {
            Some(v) => whole_in("chunk size", v, 1, MAX_EDGES)?,
            None => 1 << 20,
        };
        let size = size as usize;
        let gen = EdgeGenerator::new(Profile::clone(self.profile()?), self.clock)
            .map_err(|e| value_err(e.to_string()))?;
        Ok(Chunks {
            state: Mutex::new((gen, 0)),
            size,
            periods,
        })
    }

    /// The move's summary: the same fields as `multistep plan --format json`.
    #[getter]
    fn summary(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let s = self
            .summary
            .get_or_try_init(py, || -> PyResult<Py<PyAny>> {
                let s = summarise(py, self.mode, self.gen()?)?;
                let text = serde_json::to_string(&s).map_err(|e| value_err(e.to_string()))?;
                Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
            })?;
        // a copy: the cached dict stays as computed
        Ok(s.bind(py).call_method0("copy")?.unbind())
    }

    /// Duration T of the move (s): the last step happens at T.
    #[getter]
    fn duration_s(&self) -> f64 {
        self.check.duration
    }

    /// Number of steps (edges).
    #[getter]
    fn steps(&self) -> u64 {
        self.check.steps
    }

    /// Clock the edges are counted in (Hz).
    #[getter]
    fn clock_hz(&self) -> f64 {
        self.clock
    }

    /// Mode and family, as in the summary: `trapezoid (phases)`, `scurve (limits)`, …
    #[getter]
    fn mode(&self) -> String {
        self.mode.to_string()
    }

    /// Tick of the last edge, `round(clock·T)`.
    #[getter]
    fn last_edge_tick(&self) -> u64 {
        self.check.last_edge_tick
    }

    /// Commanded speed at time `t` (steps/s; 0 outside the move).
    fn velocity(&self, t: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.profile()?.velocity(number("t", t)?))
    }

    /// Commanded position at time `t` (steps; 0 before the move, `steps` after it).
    fn position(&self, t: &Bound<'_, PyAny>) -> PyResult<f64> {
        Ok(self.profile()?.position(number("t", t)?))
    }

    fn __len__(&self) -> usize {
        usize::try_from(self.check.steps).unwrap_or(usize::MAX)
    }

    fn __repr__(&self) -> String {
        format!(
            "Plan({}, steps={}, duration_s={}, clock_hz={})",
            self.mode, self.check.steps, self.check.duration, self.clock
        )
    }
}

/// Iterator over a plan's edges (or periods) in uint64 arrays of at most `size`.
#[pyclass(module = "multistep")]
pub struct Chunks {
    /// The generator and the last edge so far (for periods).
    state: Mutex<(EdgeGenerator, u64)>,
    size: usize,
    periods: bool,
}

#[pymethods]
impl Chunks {
    fn __iter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    fn __next__<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray1<u64>>>> {
        let mut st = self
            .state
            .lock()
            .map_err(|_| value_err("the chunk iterator was poisoned by an earlier error"))?;
        let n = st.0.remaining().min(self.size as u64);
        if n == 0 {
            return Ok(None);
        }
        let arr = empty_u64(py, n)?;
        // on a copy: a chunk cut short by Ctrl-C leaves the iterator where it was
        let (mut gen, mut last) = st.clone();
        {
            let mut rw = arr.try_readwrite()?;
            let out = rw.as_slice_mut()?;
            fill(py, &mut gen, out, self.periods.then_some(&mut last))?;
        }
        *st = (gen, last);
        Ok(Some(arr))
    }

    /// Edges not yet returned.
    #[getter]
    fn remaining(&self) -> u64 {
        self.state.lock().map(|s| s.0.remaining()).unwrap_or(0)
    }

    fn __repr__(&self) -> String {
        format!(
            "Chunks(size={}, periods={}, remaining={})",
            self.size,
            if self.periods { "True" } else { "False" },
            self.remaining()
        )
    }
}
