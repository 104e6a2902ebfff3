//! The `multistep` Python module: the core's exact step edges as numpy arrays, the motor
//! simulator and the controller board client. Every result comes from the Rust crates —
//! nothing is planned, simulated or spoken on the wire here — so Python sees the same
//! edges, reports and protocol as the command line.

mod args;
mod board;
mod errors;
mod link;
mod plan;
mod simulate;
mod track;

use pyo3::prelude::*;

#[pymodule]
fn multistep(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_function(wrap_pyfunction!(plan::plan, m)?)?;
    m.add_function(wrap_pyfunction!(simulate::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(track::track, m)?)?;
    m.add_class::<plan::Plan>()?;
    m.add_class::<plan::Chunks>()?;
    m.add_class::<board::Board>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("DEFAULT_CLOCK_HZ", multistep_core::DEFAULT_CLOCK_HZ)?;
    m.add("MAX_EDGES", plan::MAX_EDGES)?;
    m.add("MAX_TRACE_ROWS", simulate::MAX_TRACE_ROWS)?;
    m.add("DEFAULT_TIMEOUT", board::DEFAULT_TIMEOUT)?;
    m.add(
        "MOTORS",
        multistep_sim::motor::LIBRARY
            .iter()
            .map(|(n, _)| *n)
            .collect::<Vec<_>>(),
    )?;
    m.add("PROFILES", multistep_core::Family::NAMES.to_vec())?;
    m.add(
        "MOVE_PARAMS",
        multistep_core::PARAMS
            .iter()
            .map(|p| p.name)
            .collect::<Vec<_>>(),
    )?;
    Ok(())
}
