//! `multistep`: the command line over the multistep libraries. Each subcommand lives in its
//! own module and only parses, calls a library and prints.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod bench;
mod ctl;
mod demo;
mod experiment;
mod hdl;
mod moveargs;
mod output;
mod plan;
mod serve;
mod simulate;
mod tdm;
mod track;

#[derive(Parser, Debug)]
#[command(
    name = "multistep",
    version,
    about = "Exact step timing for multi-axis stepper motors"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Seed 000's two-axis run end to end: plan, TDM engine, simulated motors, plots
    Demo(demo::DemoArgs),
    /// Plan one move: the exact tick of every step edge
    Plan(plan::PlanArgs),
    /// Run a simulated controller board: line protocol on TCP (and a serial line)
    Serve(serve::ServeArgs),
    /// Talk to controller boards: move, home, stop, status, …
    Ctl(ctl::CtlArgs),
    /// Run several axes through the time-division-multiplexed engine (one shared calculator)
    Tdm(tdm::TdmArgs),
    /// Compare multistep with seed 000's datapath, Austin, Eiderman and ramp-maker
    Bench(bench::BenchArgs),
    /// The TDM IP core as Verilog: emit it, and report its FPGA resource use (yosys)
    Hdl(hdl::HdlArgs),
    /// Simulate one move on a motor and driver: lost steps and following error
    Simulate(Box<simulate::SimulateArgs>),
    /// Reproduce the seed papers' experiments on the simulator
    Experiment(experiment::ExperimentArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => match e.kind() {
            clap::error::ErrorKind::DisplayHelp
            | clap::error::ErrorKind::DisplayVersion
            | clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => e.exit(),
            _ => {
                // One line, as scripts expect: clap's first line already starts with "error:".
                let text = e.render().to_string();
                eprintln!("{}", text.lines().next().unwrap_or("error: bad arguments"));
                return ExitCode::from(2);
            }
        },
    };
    let result = match &cli.cmd {
        Cmd::Demo(a) => demo::run(a),
        Cmd::Plan(a) => plan::run(a),
        Cmd::Serve(a) => serve::run(a),
        Cmd::Ctl(a) => ctl::run(a),
        Cmd::Tdm(a) => tdm::run(a),
        Cmd::Bench(a) => bench::run_bench(a),
        Cmd::Hdl(a) => hdl::run(a),
        Cmd::Simulate(a) => simulate::run(a),
        Cmd::Experiment(a) => experiment::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed pipe (`multistep plan … | head`) is not an error.
            if let Some(io) = e.downcast_ref::<std::io::Error>() {
                if io.kind() == std::io::ErrorKind::BrokenPipe {
                    return ExitCode::SUCCESS;
                }
            }
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
