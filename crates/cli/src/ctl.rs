//! `multistep ctl`: the host client. Sends protocol lines to one or more boards; axes are
//! `BOARD:AXIS` (a bare `AXIS` when there is one board).

use crate::moveargs::ShapeArgs;
use anyhow::{anyhow, bail, Context};
use clap::{Args, Subcommand};
use multistep_controller::client::{Client, ClientError, Endpoint};
use multistep_controller::{group, AxisState, MoveOpts};
use std::time::{Duration, Instant};

#[derive(Args, Debug)]
pub struct CtlArgs {
    /// A board: NAME=tcp://HOST:PORT or NAME=serial:DEVICE (repeat for several boards)
    #[arg(long = "board", value_name = "NAME=ENDPOINT", required = true)]
    pub boards: Vec<String>,
    /// Access token for boards on TCP that want one (`serve --listen-token`); falls back to
    /// the MULTISTEP_LISTEN_TOKEN environment variable
    #[arg(
        long,
        value_name = "TOKEN",
        env = "MULTISTEP_LISTEN_TOKEN",
        hide_env_values = true
    )]
    pub token: Option<String>,
    #[command(subcommand)]
    pub cmd: CtlCmd,
}

#[derive(Subcommand, Debug)]
pub enum CtlCmd {
    /// Relative move by STEPS microsteps (or a number with 'u' for user units)
    Move {
        axis: String,
        #[arg(allow_hyphen_values = true, value_name = "STEPS")]
        distance: String,
        #[command(flatten)]
        m: ShapeArgs,
        /// Use a stored speed preset
        #[arg(long)]
        preset: Option<String>,
    },
    /// Absolute move to POSITION (periodic axes take the shortest way)
    Moveto {
        axis: String,
        #[arg(allow_hyphen_values = true)]
        position: String,
        #[command(flatten)]
        m: ShapeArgs,
        /// Use a stored speed preset
        #[arg(long)]
        preset: Option<String>,
    },
    /// Move axes together: same start tick (--sync: same finish tick too); axes of several
    /// boards are armed on each and started by one fall of the boards' SYNC line
    Group {
        /// AXIS=N targets (BOARD:AXIS=N with several boards)
        #[arg(required = true)]
        targets: Vec<String>,
        /// Targets are absolute positions (default: relative distances)
        #[arg(long)]
        absolute: bool,
        /// Finish on the same tick as well
        #[arg(long)]
        sync: bool,
        #[command(flatten)]
        m: ShapeArgs,
        /// Use a stored speed preset
        #[arg(long)]
        preset: Option<String>,
    },
    /// Home an axis on its Hall sensor
    Home { axis: String },
    /// Run an axis at RATE steps/s until stopped (a number with 'u' for user units/s,
    /// negative reverses, a fraction NUM/DEN is exact, or the name of a stored rate); on a
    /// tracking axis, change its rate
    Track {
        axis: String,
        #[arg(allow_hyphen_values = true)]
        rate: String,
        /// Acceleration of the ramps: the move value amax (steps/s², at most the axis's amax)
        #[arg(long)]
        amax: Option<f64>,
        /// Stop by itself this many seconds after the last such command
        #[arg(long)]
        lease: Option<f64>,
    },
    /// Store a named rate on a board (seed 002's constant, fast and slow motion)
    Rate {
        /// Board name (may be left out with one board)
        #[arg(long = "to")]
        to: Option<String>,
        name: String,
        #[arg(allow_hyphen_values = true)]
        rate: String,
    },
    /// De-energize an idle axis's driver (it becomes untrusted unless
    /// release_keeps_position)
    Release { axis: String },
    /// Energize an axis's driver
    Energize { axis: String },
    /// Controlled stop of an axis (all axes of all boards without one)
    Stop { axis: Option<String> },
    /// Emergency stop on every board
    Estop,
    /// Clear an emergency stop on every board
    Reset,
    /// Wait until the axes are idle (fails if one faults)
    Wait {
        #[arg(required = true)]
        axes: Vec<String>,
        /// Give up after this many seconds (`inf`: wait for ever)
        #[arg(long, default_value_t = 600.0, value_parser = seconds_or_inf)]
        timeout: f64,
    },
    /// Status of every axis of every board
    Status {
        /// An array of objects: axis (BOARD:AXIS), position, state, homed, trusted, …
        #[arg(long)]
        json: bool,
    },
    /// Send one raw protocol line to a board and print its data lines
    Raw {
        /// Board name (may be left out with one board)
        #[arg(long = "to")]
        to: Option<String>,
        /// The line's words; every word from the first on is sent, so options such as
        /// --to go before it
        #[arg(required = true, allow_hyphen_values = true)]
        line: Vec<String>,
    },
}

/// How long `ctl` keeps retrying a TCP board that refuses the connection: long enough for a
/// `multistep serve … &` started just before to open its database and listen.
const CONNECT_PATIENCE: Duration = Duration::from_secs(5);

/// Connects; a refused TCP connection is retried every 50 ms for [`CONNECT_PATIENCE`].
fn connect_patiently(ep: &Endpoint) -> anyhow::Result<Client> {
    let start = Instant::now();
    loop {
        match Client::connect(ep) {
            Ok(c) => return Ok(c),
            Err(ClientError::Io(e)) if e.kind() == std::io::ErrorKind::ConnectionRefused => {
                if start.elapsed() >= CONNECT_PATIENCE {
                    bail!(
                        "{e} (retried for {} s: is `multistep serve` running there?)",
                        CONNECT_PATIENCE.as_secs()
                    );
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            Err(ClientError::Io(e)) => bail!("cannot connect: {e}"),
            Err(e) => return Err(e.into()),
        }
    }
}

struct Boards {
    list: Vec<(String, Client)>,
}

impl Boards {
    fn connect(specs: &[String], token: Option<&str>) -> anyhow::Result<Boards> {
        let mut list: Vec<(String, Client)> = Vec::new();
        for s in specs {
            let (name, ep) = s.split_once('=').ok_or_else(|| {
                anyhow!("--board '{s}' is not NAME=tcp://HOST:PORT or NAME=serial:DEVICE")
            })?;
            if name.is_empty() || name.contains(':') || list.iter().any(|b| b.0 == name) {
                bail!("board name '{name}' is empty, has ':' or is given twice");
            }
            let endpoint: Endpoint = ep.parse()?;
            let mut c =
                connect_patiently(&endpoint).map_err(|e| anyhow!("board {name} ({ep}): {e}"))?;
            if let (Some(t), Endpoint::Tcp(_)) = (token, &endpoint) {
                c.authenticate(t)
                    .with_context(|| format!("board {name}: authentication"))?;
            }
            list.push((name.to_string(), c));
        }
        Ok(Boards { list })
    }

    /// `BOARD:AXIS` (or a bare axis with one board) → (board index, axis).
    fn axis(&self, s: &str) -> anyhow::Result<(usize, String)> {
        match s.split_once(':') {
            Some((b, a)) => {
                let i = self.board(Some(b))?;
                Ok((i, a.to_string()))
            }
            None if self.list.len() == 1 => Ok((0, s.to_string())),
            None => bail!("with several boards, name the axis as BOARD:AXIS (got '{s}')"),
        }
    }

    fn board(&self, name: Option<&str>) -> anyhow::Result<usize> {
        match name {
            Some(b) => self
                .list
                .iter()
                .position(|x| x.0 == b)
                .ok_or_else(|| anyhow!("no board named '{b}'")),
            None if self.list.len() == 1 => Ok(0),
            None => bail!("with several boards, say which one (--to NAME)"),
        }
    }

    fn send(&mut self, i: usize, line: &str) -> anyhow::Result<Vec<String>> {
        let (name, c) = &mut self.list[i];
        c.request(line)
            .with_context(|| format!("board {name}: '{line}'"))
    }
}

pub(crate) fn move_words(m: &ShapeArgs, preset: &Option<String>) -> anyhow::Result<String> {
    let opts = MoveOpts {
        preset: preset.clone(),
        profile: m.profile.clone(),
        params: m.params,
    };
    Ok(opts.words().join(" "))
}

fn print_lines(lines: &[String]) {
    for l in lines {
        println!("{l}");
    }
}

pub fn run(a: &CtlArgs) -> anyhow::Result<()> {
    let mut boards = Boards::connect(&a.boards, a.token.as_deref())?;
    match &a.cmd {
        CtlCmd::Move {
            axis,
            distance: steps,
            m,
            preset,
        }
        | CtlCmd::Moveto {
            axis,
            position: steps,
            m,
            preset,
        } => {
            let verb = if matches!(a.cmd, CtlCmd::Move { .. }) {
                "move"
            } else {
                "moveto"
            };
            let (i, ax) = boards.axis(axis)?;
            let line = format!("{verb} {ax} {steps} {}", move_words(m, preset)?);
            print_lines(&boards.send(i, line.trim_end())?);
        }
        CtlCmd::Group {
            targets,
            absolute,
            sync,
            m,
            preset,
        } => {
            // Each board's share of the group, boards in the order of their first axis.
            let mut shares: Vec<(usize, Vec<String>)> = Vec::new();
            for t in targets {
                let (a, n) = t
                    .rsplit_once('=')
                    .ok_or_else(|| anyhow!("'{t}' is not AXIS=N"))?;
                let (i, ax) = boards.axis(a)?;
                let w = format!("{ax}={n}");
                match shares.iter_mut().find(|s| s.0 == i) {
                    Some(s) => s.1.push(w),
                    None => shares.push((i, vec![w])),
                }
            }
            let verb = if *absolute { "moveto" } else { "move" };
            let sync = if *sync { " sync" } else { "" };
            let opts = move_words(m, preset)?;
            let line = |head: &str, words: &[String]| {
                let l = format!("{head} {verb} {}{sync} {opts}", words.join(" "));
                l.trim_end().to_string()
            };
            if let [(i, words)] = shares.as_slice() {
                print_lines(&boards.send(*i, &line("group", words))?);
            } else {
                let shares: Vec<group::Share> = shares
                    .iter()
                    .map(|(i, w)| group::Share {
                        board: *i,
                        axes: w
                            .iter()
                            .filter_map(|t| t.split_once('='))
                            .map(|t| t.0.into())
                            .collect(),
                        line: line("arm", w),
                    })
                    .collect();
                sync_group(&mut boards, &shares)?;
            }
        }
        CtlCmd::Home { axis } => {
            let (i, ax) = boards.axis(axis)?;
            boards.send(i, &format!("home {ax}"))?;
        }
        CtlCmd::Track {
            axis,
            rate,
            amax,
            lease,
        } => {
            let (i, ax) = boards.axis(axis)?;
            let mut line = format!("track {ax} {rate}");
            if let Some(a) = amax {
                line += &format!(" amax={a}");
            }
            if let Some(l) = lease {
                line += &format!(" lease={l}");
            }
            print_lines(&boards.send(i, &line)?);
        }
        CtlCmd::Rate { to, name, rate } => {
            let i = boards.board(to.as_deref())?;
            boards.send(i, &format!("rate {name} {rate}"))?;
        }
        CtlCmd::Release { axis } | CtlCmd::Energize { axis } => {
            let verb = if matches!(a.cmd, CtlCmd::Release { .. }) {
                "release"
            } else {
                "energize"
            };
            let (i, ax) = boards.axis(axis)?;
            boards.send(i, &format!("{verb} {ax}"))?;
        }
        CtlCmd::Stop { axis: Some(axis) } => {
            let (i, ax) = boards.axis(axis)?;
            boards.send(i, &format!("stop {ax}"))?;
        }
        CtlCmd::Stop { axis: None } | CtlCmd::Estop | CtlCmd::Reset => {
            let line = match a.cmd {
                CtlCmd::Estop => "estop",
                CtlCmd::Reset => "reset",
                _ => "stop all",
            };
            // Every board, even if one fails.
            let mut first_err = None;
            for i in 0..boards.list.len() {
                if let Err(e) = boards.send(i, line) {
                    eprintln!("error: {e:#}");
                    first_err.get_or_insert(e);
                }
            }
            if let Some(e) = first_err {
                return Err(e);
            }
        }
        CtlCmd::Wait { axes, timeout } => {
            let deadline = deadline_after(*timeout);
            let want: Vec<(usize, String)> = axes
                .iter()
                .map(|x| boards.axis(x))
                .collect::<Result<_, _>>()?;
            for (i, ax) in want {
                loop {
                    let line = boards.send(i, &format!("status json {ax}"))?;
                    let st: Vec<multistep_controller::AxisStatus> =
                        serde_json::from_str(line.first().map(|s| s.as_str()).unwrap_or("[]"))?;
                    let s = st.first().ok_or_else(|| anyhow!("no status for {ax}"))?;
                    match s.state {
                        AxisState::Idle => break,
                        AxisState::Fault => bail!(
                            "axis {ax} is in fault: {}",
                            s.fault.as_deref().unwrap_or("?")
                        ),
                        _ if deadline.is_some_and(|d| Instant::now() > d) => {
                            bail!("timed out waiting for {ax}")
                        }
                        _ => std::thread::sleep(Duration::from_millis(20)),
                    }
                }
            }
        }
        CtlCmd::Status { json } => {
            let mut all = Vec::new();
            for i in 0..boards.list.len() {
                let name = boards.list[i].0.clone();
                let st = boards.list[i]
                    .1
                    .status()
                    .with_context(|| format!("board {name}"))?;
                all.extend(st.into_iter().map(|mut s| {
                    s.axis = format!("{name}:{}", s.axis);
                    s
                }));
            }
            if *json {
                println!("{}", serde_json::to_string_pretty(&all)?);
            } else {
                println!(
                    "{:<16} {:>3} {:>12} {:>8} {:>6} {:>7} {:>10} {:>10}",
                    "axis", "num", "position", "state", "homed", "trusted", "speed", "rate"
                );
                for s in &all {
                    println!(
                        "{:<16} {:>3} {:>12} {:>8} {:>6} {:>7} {:>10.1} {:>10}",
                        s.axis,
                        s.number,
                        s.position,
                        s.state.name(),
                        if s.homed { "yes" } else { "no" },
                        if s.trusted { "yes" } else { "no" },
                        s.speed,
                        s.rate.map_or("-".to_string(), |r| format!("{r:.3}"))
                    );
                }
            }
        }
        CtlCmd::Raw { to, line } => {
            let i = boards.board(to.as_deref())?;
            print_lines(&boards.send(i, &line.join(" "))?);
        }
    }
    Ok(())
}

impl group::GroupBoards for Boards {
    fn name(&self, board: usize) -> String {
        self.list[board].0.clone()
    }
    fn send(&mut self, board: usize, line: &str) -> Result<Vec<String>, group::SendError> {
        Boards::send(self, board, line).map_err(|e| group::SendError {
            nothing_applied: refused_by_the_service(&e),
            text: format!("{e:#}"),
        })
    }
}

/// The service answered `error:N` for a reason of its own: not 17 (the connection was
/// closed) or 21 (the board's link failed), after which the line may have taken effect.
fn refused_by_the_service(e: &anyhow::Error) -> bool {
    let code = e
        .downcast_ref::<multistep_controller::client::Refused>()
        .or_else(|| match e.downcast_ref::<ClientError>() {
            Some(ClientError::Refused(r)) => Some(r),
            _ => None,
        })
        .map(|r| r.code);
    code.is_some_and(|c| c != 17 && c != 21)
}

/// A group across boards (`multistep_controller::group`): prints each board's answer to
/// its arm, then its count at the SYNC fall and its offset to the first board's clock.
/// A failure anywhere disarms every share first; the error names any share left armed.
fn sync_group(boards: &mut Boards, shares: &[group::Share]) -> anyhow::Result<()> {
    let started = group::start_across(boards, shares, group::ARM_PATIENCE)?;
    for a in &started.answers {
        println!("{a}");
    }
    for (i, tick, off) in started.ticks {
        println!("{} synctick={tick} offset={off}", boards.list[i].0);
    }
    Ok(())
}

/// A `--timeout` in seconds: a number ≥ 0, or `inf`.
fn seconds_or_inf(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v >= 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a number of seconds >= 0 (or inf)")),
    }
}

/// When a wait of `timeout` seconds from now ends; `None` for a wait too long to end
/// (`inf`, or past what the clock can count).
fn deadline_after(timeout: f64) -> Option<Instant> {
    Duration::try_from_secs_f64(timeout)
        .ok()
        .and_then(|d| Instant::now().checked_add(d))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timeouts_are_seconds_or_inf_and_never_panic() {
        assert_eq!(seconds_or_inf("2.5"), Ok(2.5));
        assert_eq!(seconds_or_inf("inf"), Ok(f64::INFINITY));
        for bad in ["-1", "nan", "NaN", "abc", ""] {
            assert!(seconds_or_inf(bad).is_err(), "{bad}");
        }
        assert!(deadline_after(f64::INFINITY).is_none());
        assert!(deadline_after(1e300).is_none());
        let d = deadline_after(0.0).unwrap();
        assert!(d <= Instant::now());
        assert!(deadline_after(60.0).unwrap() > Instant::now());
    }

    /// The command line a user types: options may follow a group's targets, and a
    /// negative distance is a target, not an option; `move` has no `--steps`.
    #[test]
    fn group_options_may_follow_the_targets() {
        let ctl = |words: &[&str]| {
            let args = [
                &["multistep", "ctl", "--board", "a=tcp://127.0.0.1:1"],
                words,
            ]
            .concat();
            match crate::params_test::cli(&args).cmd {
                crate::Cmd::Ctl(a) => a.cmd,
                _ => unreachable!(),
            }
        };
        let CtlCmd::Group {
            targets, sync, m, ..
        } = ctl(&["group", "X=100", "Y=-50", "--sync", "--vmax", "1000"])
        else {
            panic!("not a group")
        };
        assert_eq!(targets, ["X=100", "Y=-50"]);
        assert!(sync);
        assert_eq!(m.params.vmax, Some(1000.0));
        let CtlCmd::Raw { to, line } = ctl(&["raw", "--to", "a", "move", "X", "-5"]) else {
            panic!("not raw")
        };
        assert_eq!(
            (to.as_deref(), line.join(" ").as_str()),
            (Some("a"), "move X -5")
        );
        let args = [
            "multistep",
            "ctl",
            "--board",
            "a=tcp://h:1",
            "move",
            "X",
            "5",
            "--steps",
            "5",
        ];
        assert!(
            crate::allow_negative_numbers(<crate::Cli as clap::CommandFactory>::command())
                .try_get_matches_from(args)
                .is_err()
        );
    }
}
