//! `multistep`: the command line over the multistep libraries. Each subcommand lives in its
//! own module and only parses, calls a library and prints.

use clap::{Command, CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

mod bench;
mod board_sim;
mod ctl;
mod demo;
mod experiment;
mod hdl;
mod moveargs;
mod output;
#[cfg(test)]
mod params_test;
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

// `defer`: a subcommand's arguments are built only when it runs or its help is shown
// (building all of them was ~40 % of a short command's instructions)
#[derive(Subcommand, Debug)]
#[command(defer = true)]
enum Cmd {
    /// Seed 000's two-axis run end to end: plan, TDM engine, simulated motors, plots
    Demo(demo::DemoArgs),
    /// Plan one move: the exact tick of every step edge
    Plan(plan::PlanArgs),
    /// Run a controller board, simulated or the FPGA board on --board-link: line protocol on TCP (and a serial line)
    Serve(serve::ServeArgs),
    /// Talk to controller boards: move, home, stop, status, …
    Ctl(ctl::CtlArgs),
    /// Run several axes through the time-division-multiplexed engine (one shared calculator)
    Tdm(tdm::TdmArgs),
    /// Compare multistep with seed 000's datapath, Austin, Eiderman and ramp-maker
    Bench(bench::BenchArgs),
    /// Run a board's RTL in Verilator behind a pseudo-terminal, with simulated motors and Hall sensors
    BoardSim(board_sim::BoardSimArgs),
    /// The TDM IP core as Verilog: emit it, report its resource use, build a board's bitstream, print its link frames
    Hdl(hdl::HdlArgs),
    /// Simulate one move on a motor and driver: lost steps and following error
    Simulate(Box<simulate::SimulateArgs>),
    /// Reproduce the seed papers' experiments on the simulator
    Experiment(experiment::ExperimentArgs),
}

/// Every option that takes a value accepts a negative number (`--vmax -5`), so the library,
/// not the parser, says what is wrong with it.
fn allow_negative_numbers(cmd: Command) -> Command {
    cmd.mut_args(|a| {
        if a.get_action().takes_values() {
            a.allow_negative_numbers(true)
        } else {
            a
        }
    })
    .mut_subcommands(allow_negative_numbers)
}

/// The subcommand the command line names: `multistep NAME …` or `multistep help NAME`.
fn subcommand_named(command: &Command) -> Option<String> {
    let mut args = std::env::args_os().skip(1).map(|a| a.into_string().ok());
    let first = args.next()??;
    let name = if first == "help" {
        args.next()??
    } else {
        first
    };
    command.find_subcommand(&name).is_some().then_some(name)
}

fn main() -> ExitCode {
    // clap's own rendering: the whole message with its hints (did you mean, usage) on
    // stderr and status 2; help and version on stdout and status 0.
    let mut command = Cli::command();
    // the subcommand that runs (or whose help is asked for) takes negative numbers; the
    // others stay unbuilt
    if let Some(name) = subcommand_named(&command) {
        command = command.mut_subcommand(name, |mut sub| {
            // building it lets a flattened struct's doc comment replace its own `about`
            let (about, long) = (sub.get_about().cloned(), sub.get_long_about().cloned());
            sub.build();
            let sub = match about {
                Some(a) => sub.about(a),
                None => sub.about(None::<&str>),
            };
            let sub = match long {
                Some(a) => sub.long_about(a),
                None => sub.long_about(None::<&str>),
            };
            allow_negative_numbers(sub)
        });
    }
    let matches = command.get_matches_mut();
    // the whole command tree is a sixth of a short run's instructions to free: the
    // process's exit frees it
    std::mem::forget(command);
    let cli =
        Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.format(&mut Cli::command()).exit());
    let result = match &cli.cmd {
        Cmd::Demo(a) => demo::run(a),
        Cmd::Plan(a) => plan::run(a),
        Cmd::Serve(a) => serve::run(a),
        Cmd::Ctl(a) => ctl::run(a),
        Cmd::Tdm(a) => tdm::run(a),
        Cmd::Bench(a) => bench::run_bench(a),
        Cmd::Hdl(a) => hdl::run(a),
        Cmd::BoardSim(a) => board_sim::run(a),
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
