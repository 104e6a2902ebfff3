//! The simulator's errors: one typed error per bad input, each naming what is wrong.

use multistep_core::Num;
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
    #[error("motor '{motor}': field `{field}` = {} is invalid: {why}", Num(*.value))]
    BadField {
        motor: String,
        field: &'static str,
        value: f64,
        why: String,
    },
    #[error("setting `{field}` = {} is invalid: {why}", Num(*.value))]
    BadSetting {
        field: &'static str,
        value: f64,
        why: String,
    },
    #[error(
        "the simulation needs about {steps:.3e} RK4 steps ({:.3} s simulated at dt = {dt:e} s, \
         plus one per edge), more than the {max:e} allowed (about a minute of work): simulate \
         a shorter move or use a larger dt",
        Num(*.simulated_s)
    )]
    TooMuchWork {
        steps: f64,
        simulated_s: f64,
        dt: f64,
        max: f64,
    },
    #[error(
        "the simulation reached the limit of {max:e} RK4 steps at t = {:.6} s (about a minute \
         of work): the edge stream is too long for dt = {dt:e} s",
        Num(*.t)
    )]
    WorkLimit { t: f64, dt: f64, max: f64 },
    #[error("the simulation diverged at t = {:.6} s: {what}", Num(*.t))]
    Diverged { t: f64, what: String },
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
