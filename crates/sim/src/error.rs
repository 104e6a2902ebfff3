//! The simulator's errors: one typed error per bad input, each naming what is wrong.

use thiserror::Error;

#[derive(Debug, Error)]
pub enum SimError {
    #[error("no motor named '{name}' in the library ({known}) and no file of that name: {io}")]
    UnknownMotor {
        name: String,
        known: String,
        io: String,
    },
    #[error("motor file {file}: {msg}")]
    MotorFile { file: String, msg: String },
    #[error("motor '{motor}': field `{field}` = {value} is invalid: {why}")]
    BadField {
        motor: String,
        field: &'static str,
        value: f64,
        why: &'static str,
    },
    #[error("driver setting `{field}` = {value} is invalid: {why}")]
    BadSetting {
        field: &'static str,
        value: f64,
        why: &'static str,
    },
    #[error(
        "time step dt = {dt:e} s is unstable for this motor and driver: the fastest mode \
         ({mode}) has rate {rate:.4e} 1/s and fixed-step RK4 needs dt·rate ≤ {limit}; \
         use dt ≤ {max_dt:.3e} s"
    )]
    UnstableStep {
        dt: f64,
        mode: &'static str,
        rate: f64,
        limit: f64,
        max_dt: f64,
    },
    #[error(
        "edge ticks go backwards ({prev} then {next}); the edge stream must be non-decreasing"
    )]
    EdgesBackwards { prev: u64, next: u64 },
    #[error(transparent)]
    Plan(#[from] multistep_core::PlanError),
    #[error("plot {file}: {msg}")]
    Plot { file: String, msg: String },
    #[error("trace {file}: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
}
