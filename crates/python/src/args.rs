//! Keyword arguments to Rust values: a move's keywords (the command line's move flags by
//! their long names) and the checks that turn a wrong Python type into a `TypeError` and
//! a wrong value into a `ValueError`, never a panic.

use crate::errors::{type_err, value_err};
use multistep_core::{MoveParams, MoveSpec, Param, Segment};
use pyo3::exceptions::{PyOverflowError, PyValueError};
use pyo3::prelude::*;
use pyo3::pybacked::PyBackedStr;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};

/// A move as given by keywords; `None` values count as not given.
#[derive(Default, Debug)]
pub struct MoveKw {
    pub profile: Option<String>,
    pub steps: Option<u64>,
    pub params: MoveParams,
    pub segments: Vec<Segment>,
}

impl MoveKw {
    /// Reads one keyword; `Ok(false)` if it is not a move keyword.
    pub fn set(&mut self, key: &str, v: &Bound<'_, PyAny>) -> PyResult<bool> {
        if v.is_none() {
            return Ok(
                matches!(key, "profile" | "steps" | "segments") || Param::named(key).is_some()
            );
        }
        let slot = match key {
            "profile" => {
                self.profile = Some(string(key, v)?);
                return Ok(true);
            }
            "steps" => {
                self.steps = Some(whole(key, v)?);
                return Ok(true);
            }
            "segments" => {
                self.segments = segment_list(v)?;
                return Ok(true);
            }
            _ => match Param::named(key) {
                Some(p) => (p.slot)(&mut self.params),
                None => return Ok(false),
            },
        };
        *slot = Some(number(key, v)?);
        Ok(true)
    }

    pub fn spec(&self) -> MoveSpec<'_> {
        MoveSpec {
            profile: self.profile.as_deref(),
            steps: self.steps,
            params: self.params,
            segments: &self.segments,
        }
    }
}

/// Goes through `kwargs`, giving each keyword to `take`; one it does not know is a
/// `TypeError` worded as Python's own.
pub fn each_kw(
    func: &str,
    kwargs: Option<&Bound<'_, PyDict>>,
    mut take: impl FnMut(&str, &Bound<'_, PyAny>) -> PyResult<bool>,
) -> PyResult<()> {
    let Some(kw) = kwargs else { return Ok(()) };
    for (k, v) in kw.iter() {
        let key: String = k.extract()?;
        if !take(&key, &v)? {
            return Err(type_err(format!(
                "{func}() got an unexpected keyword argument '{key}'"
            )));
        }
    }
    Ok(())
}

pub fn type_name(v: &Bound<'_, PyAny>) -> String {
    v.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// A real number (int or float); NaN and infinities pass through to the library's checks.
/// An int beyond a float's range is a `ValueError`.
pub fn number(name: &str, v: &Bound<'_, PyAny>) -> PyResult<f64> {
    // a float as is (the common case: no str or bool to rule out)
    if let Ok(f) = v.cast_exact::<PyFloat>() {
        return Ok(f.value());
    }
    if v.is_instance_of::<PyString>() || v.is_instance_of::<PyBool>() {
        return Err(type_err(format!(
            "{name} must be a number, not {}",
            type_name(v)
        )));
    }
    v.extract::<f64>().map_err(|e| {
        if e.is_instance_of::<PyOverflowError>(v.py()) {
            value_err(format!(
                "{name} must be a number within ±{:e} (got an int too large for a float)",
                f64::MAX
            ))
        } else {
            type_err(format!("{name} must be a number, not {}", type_name(v)))
        }
    })
}

/// A whole number ≥ 0 that fits in 64 bits.
pub fn whole(name: &str, v: &Bound<'_, PyAny>) -> PyResult<u64> {
    if v.is_instance_of::<PyBool>() {
        return Err(type_err(format!("{name} must be an int, not bool")));
    }
    match v.extract::<u64>() {
        Ok(n) => Ok(n),
        Err(_) if v.is_instance_of::<PyInt>() || v.hasattr("__index__").unwrap_or(false) => {
            Err(value_err(format!(
                "{name} must be a whole number from 0 to 2^64 − 1 (got {})",
                v.str().map(|s| s.to_string()).unwrap_or_default()
            )))
        }
        Err(_) => Err(type_err(format!(
            "{name} must be an int, not {}",
            type_name(v)
        ))),
    }
}

/// A whole number from `lo` to `hi`; any other int is a `ValueError` that says so.
pub fn whole_in(name: &str, v: &Bound<'_, PyAny>, lo: u64, hi: u64) -> PyResult<u64> {
    let range = || {
        let got = v.str().map(|s| s.to_string()).unwrap_or_default();
        value_err(format!(
            "{name} must be a whole number from {lo} to {hi} (got {got})"
        ))
    };
    match whole(name, v) {
        Ok(n) if (lo..=hi).contains(&n) => Ok(n),
        Ok(_) => Err(range()),
        Err(e) if e.is_instance_of::<PyValueError>(v.py()) => Err(range()),
        Err(e) => Err(e),
    }
}

/// A whole number from −2^63 to 2^63 − 1.
pub fn signed(name: &str, v: &Bound<'_, PyAny>) -> PyResult<i64> {
    if v.is_instance_of::<PyBool>() {
        return Err(type_err(format!("{name} must be an int, not bool")));
    }
    match v.extract::<i64>() {
        Ok(n) => Ok(n),
        Err(_) if v.is_instance_of::<PyInt>() => Err(value_err(format!(
            "{name} must be a whole number from −2^63 to 2^63 − 1 (got {})",
            v.str().map(|s| s.to_string()).unwrap_or_default()
        ))),
        Err(_) => Err(type_err(format!(
            "{name} must be an int, not {}",
            type_name(v)
        ))),
    }
}

pub fn string(name: &str, v: &Bound<'_, PyAny>) -> PyResult<String> {
    Ok(str_arg(name, v)?.to_string())
}

/// A str, borrowed from Python (no copy).
pub fn str_arg<'py>(name: &str, v: &Bound<'py, PyAny>) -> PyResult<PyBackedStr> {
    v.extract::<PyBackedStr>()
        .map_err(|_| type_err(format!("{name} must be a str, not {}", type_name(v))))
}

pub fn boolean(name: &str, v: &Bound<'_, PyAny>) -> PyResult<bool> {
    v.extract::<bool>()
        .map_err(|_| type_err(format!("{name} must be a bool, not {}", type_name(v))))
}

/// `[(v0, T, n), …]`: start speed (steps/s), duration (s), steps of each segment.
pub fn segment_list(v: &Bound<'_, PyAny>) -> PyResult<Vec<Segment>> {
    if v.is_instance_of::<PyString>() {
        return Err(type_err(
            "segments must be a sequence of (v0, T, n) tuples, not str",
        ));
    }
    let iter = v.try_iter().map_err(|_| {
        type_err(format!(
            "segments must be a sequence of (v0, T, n) tuples, not {}",
            type_name(v)
        ))
    })?;
    let mut out = Vec::new();
    for (i, item) in iter.enumerate() {
        let item = item?;
        let parts: Vec<Bound<'_, PyAny>> = match item.try_iter() {
            Ok(it) if !item.is_instance_of::<PyString>() => it.collect::<PyResult<_>>()?,
            _ => {
                return Err(type_err(format!(
                    "segment {i} must be a (v0, T, n) tuple, not {}",
                    type_name(&item)
                )))
            }
        };
        if parts.len() != 3 {
            return Err(value_err(format!(
                "segment {i} has {} values; a segment is (v0, T, n): start speed (steps/s), time (s), steps",
                parts.len()
            )));
        }
        out.push(Segment {
            v0: number(&format!("segment {i} start speed"), &parts[0])?,
            duration: number(&format!("segment {i} time"), &parts[1])?,
            steps: whole(&format!("segment {i} steps"), &parts[2])?,
        });
    }
    Ok(out)
}
