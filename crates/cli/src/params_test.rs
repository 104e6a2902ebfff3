//! Every move value of the core's list reaches every front end: the `plan`, `simulate` and
//! `ctl` flags, the TDM config's keys and the protocol's words (the Python keywords are
//! checked by the Python package's tests). A value added to `MoveParams` without being
//! wired somewhere fails here.

use crate::{Cli, Cmd};
use clap::{CommandFactory, FromArgMatches};
use multistep_controller::protocol::{self, word_of_param, Command};
use multistep_core::{MoveParams, PARAMS};

pub(crate) fn cli(args: &[&str]) -> Cli {
    let m = crate::allow_negative_numbers(Cli::command())
        .try_get_matches_from(args)
        .unwrap_or_else(|e| panic!("{args:?}: {e}"));
    Cli::from_arg_matches(&m).unwrap()
}

fn flag(name: &str) -> String {
    format!("--{}", name.replace('_', "-"))
}

/// The options a protocol line carries.
fn line_params(line: &str) -> MoveParams {
    match protocol::parse(line).unwrap_or_else(|e| panic!("'{line}': {e}")) {
        Command::Move { opts, .. } | Command::Group { opts, .. } => opts.params,
        other => panic!("'{line}' is {other:?}"),
    }
}

#[test]
fn every_move_value_is_a_flag_a_toml_key_and_a_protocol_word() {
    for (k, p) in PARAMS.iter().enumerate() {
        let x = 0.125 * (k + 1) as f64;
        let given = |params: &MoveParams| p.get(params) == Some(x);
        let value = x.to_string();
        let f = flag(p.name);

        let Cmd::Plan(a) = cli(&["multistep", "plan", &f, &value]).cmd else {
            unreachable!()
        };
        assert!(given(&a.mv.shape.params), "plan {f}");
        let Cmd::Simulate(a) = cli(&["multistep", "simulate", "--motor", "42mm", &f, &value]).cmd
        else {
            unreachable!()
        };
        assert!(given(&a.mv.shape.params), "simulate {f}");

        let toml = format!("[[axis]]\n{} = {value}", p.name);
        let cfg = crate::tdm::config::ConfigFile::parse(&toml).unwrap();
        assert!(given(&cfg.axis[0].params), "TOML key {}", p.name);

        for word in [p.name, word_of_param(p)] {
            assert!(
                given(&line_params(&format!("move X 10 {word}={value}"))),
                "{word}="
            );
        }
        let help = protocol::help();
        let opts_line = help.iter().find(|l| l.starts_with("opts:")).unwrap();
        let shown = format!(" {}=", word_of_param(p));
        assert!(opts_line.contains(&shown), "help lacks{shown}");

        let ctl = [
            "multistep",
            "ctl",
            "--board",
            "b=tcp://h:1",
            "move",
            "X",
            "10",
        ];
        let Cmd::Ctl(a) = cli(&[&ctl[..], &[&f, &value]].concat()).cmd else {
            unreachable!()
        };
        let crate::ctl::CtlCmd::Move { m, preset, .. } = &a.cmd else {
            unreachable!()
        };
        let line = format!("move X 10 {}", crate::ctl::move_words(m, preset).unwrap());
        assert!(given(&line_params(&line)), "ctl {f}: '{line}'");
    }
}
