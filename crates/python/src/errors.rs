//! The exception classes and how each Rust error becomes one. Messages are the library
//! errors' own text, the same the command line prints after `error: `.

use multistep_controller::client::Refused;
use multistep_core::{PlanError, TrackError};
use multistep_sim::SimError;
use pyo3::exceptions::{PyConnectionError, PyException, PyTimeoutError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

/// One exception class of the module: its name, its bases and its docstring.
struct Class {
    cell: PyOnceLock<Py<PyType>>,
    name: &'static str,
    doc: &'static str,
}

impl Class {
    const fn new(name: &'static str, doc: &'static str) -> Class {
        Class {
            cell: PyOnceLock::new(),
            name,
            doc,
        }
    }

    /// The class (plain `Exception` if the module's init has not made it yet).
    fn get<'py>(&'static self, py: Python<'py>) -> Bound<'py, PyType> {
        match self.cell.get(py) {
            Some(t) => t.bind(py).clone(),
            None => py.get_type::<PyException>(),
        }
    }
}

static MULTISTEP_ERROR: Class = Class::new(
    "MultistepError",
    "Base class of every error multistep raises itself.",
);
static PLAN_ERROR: Class = Class::new(
    "PlanError",
    "A move that is malformed or cannot be done (also a ValueError).",
);
static SIMULATION_ERROR: Class = Class::new(
    "SimulationError",
    "A bad motor, driver setting or simulation input (also a ValueError).",
);
static BOARD_ERROR: Class = Class::new(
    "BoardError",
    "A board session failed: base of ProtocolError, BoardConnectionError and \
     BoardTimeoutError.",
);
static PROTOCOL_ERROR: Class = Class::new(
    "ProtocolError",
    "The board answered `error:<code> <message>`; `.code` is the protocol's stable number \
     (docs/PROTOCOL.md) and `.message` its text.",
);
static CONNECTION_ERROR: Class = Class::new(
    "BoardConnectionError",
    "The connection to the board failed or closed (also a ConnectionError).",
);

static TIMEOUT_ERROR: Class = Class::new(
    "BoardTimeoutError",
    "The board did not answer within the Board's timeout, or an axis was not idle within \
     wait's (also a TimeoutError).",
);

/// Makes the classes with `type(name, bases, ns)` (several bases, which
/// `create_exception!` cannot give) and adds them to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let exception = py.get_type::<PyException>().into_any();
    let value = py.get_type::<PyValueError>().into_any();
    let connection = py.get_type::<PyConnectionError>().into_any();
    let timeout = py.get_type::<PyTimeoutError>().into_any();
    let base = make(m, &MULTISTEP_ERROR, vec![exception])?;
    make(m, &PLAN_ERROR, vec![base.clone(), value.clone()])?;
    make(m, &SIMULATION_ERROR, vec![base.clone(), value])?;
    let board = make(m, &BOARD_ERROR, vec![base])?;
    make(m, &PROTOCOL_ERROR, vec![board.clone()])?;
    make(m, &CONNECTION_ERROR, vec![board.clone(), connection])?;
    make(m, &TIMEOUT_ERROR, vec![board, timeout])?;
    Ok(())
}

fn make<'py>(
    m: &Bound<'py, PyModule>,
    class: &'static Class,
    bases: Vec<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let py = m.py();
    let ns = PyDict::new(py);
    ns.set_item("__module__", "multistep")?;
    ns.set_item("__doc__", class.doc)?;
    let ty = py
        .get_type::<PyType>()
        .call1((class.name, PyTuple::new(py, bases)?, ns))?
        .cast_into::<PyType>()?;
    m.add(class.name, &ty)?;
    let _ = class.cell.set(py, ty.clone().unbind());
    Ok(ty.into_any())
}

fn new_err(py: Python<'_>, class: &'static Class, msg: String) -> PyErr {
    match class.get(py).call1((msg,)) {
        Ok(e) => PyErr::from_value(e),
        Err(e) => e,
    }
}

pub fn plan_err(py: Python<'_>, e: PlanError) -> PyErr {
    new_err(py, &PLAN_ERROR, e.to_string())
}

/// A refused rate or tracking limit is a `PlanError`, with the command line's message.
pub fn track_err(py: Python<'_>, e: TrackError) -> PyErr {
    match e {
        TrackError::Ramp(p) => plan_err(py, p),
        other => new_err(py, &PLAN_ERROR, other.to_string()),
    }
}

pub fn sim_err(py: Python<'_>, e: SimError) -> PyErr {
    match e {
        SimError::Plan(p) => plan_err(py, p),
        other => new_err(py, &SIMULATION_ERROR, other.to_string()),
    }
}

/// A refusal keeps its code.
pub fn refused_err(py: Python<'_>, r: Refused) -> PyErr {
    let text = format!("error:{} {}", r.code, r.message);
    match PROTOCOL_ERROR.get(py).call1((text,)) {
        Ok(err) => {
            let set = err
                .setattr("code", r.code)
                .and_then(|_| err.setattr("message", r.message));
            match set {
                Ok(()) => PyErr::from_value(err),
                Err(e) => e,
            }
        }
        Err(e) => e,
    }
}

pub fn board_err(py: Python<'_>, msg: String) -> PyErr {
    new_err(py, &BOARD_ERROR, msg)
}

pub fn connection_err(py: Python<'_>, msg: String) -> PyErr {
    new_err(py, &CONNECTION_ERROR, msg)
}

pub fn timeout_err(py: Python<'_>, msg: String) -> PyErr {
    new_err(py, &TIMEOUT_ERROR, msg)
}

pub fn value_err(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

pub fn type_err(msg: impl Into<String>) -> PyErr {
    PyTypeError::new_err(msg.into())
}

/// A call on a closed `Board`.
pub fn closed_err(py: Python<'_>) -> PyErr {
    connection_err(py, "the board connection is closed".into())
}
