//! The protocol's commands run on the board: the single place where protocol words meet
//! the board.

use super::*;

impl Controller {
    /// The reply to `line` as a connection sends it, appended to `out`: the text of
    /// [`Controller::execute_bytes`], with a text `status` written straight into `out`
    /// (its lines hold no line break and never read as a status line, so they need no
    /// `String` each).
    pub fn answer_bytes(&self, line: &[u8], out: &mut String) {
        match protocol::parse_bytes(line) {
            Ok(Command::Status { axes, json: false }) => match self.status(&axes) {
                Ok(st) => {
                    for s in &st {
                        s.write_line(out);
                        out.push('\n');
                    }
                    out.push_str("ok\n");
                }
                Err(e) => Reply::err(e).write_text(out),
            },
            Ok(cmd) => self.execute(&cmd).write_text(out),
            Err(e) => Reply::err(e).write_text(out),
        }
    }

    pub(super) fn run(&self, cmd: &Command) -> Result<Vec<String>, CtlError> {
        let target_line = |axes: &[String], t: &[i64]| -> Vec<String> {
            axes.iter()
                .zip(t)
                .map(|(a, t)| format!("{a} target={t}"))
                .collect()
        };
        Ok(match cmd {
            Command::Nop => vec![],
            Command::Help => protocol::help(),
            Command::Version => vec![format!(
                "multistep-controller {}",
                env!("CARGO_PKG_VERSION")
            )],
            Command::Info => self.with_board(|b, now| {
                let mut v = vec![
                    format!("board={}", b.name()),
                    format!("version={}", env!("CARGO_PKG_VERSION")),
                    format!("axes={}", b.axis_names().join(",")),
                    format!("clock_hz={}", b.clock_hz()),
                    format!("time_scale={}", self.time_scale),
                    format!("tick={now}"),
                    format!("estop={}", b.is_estopped() as u8),
                    format!("estop_input={}", b.estop_input() as u8),
                    format!("backend={}", b.backend()),
                    format!("store={}", b.store_health()),
                ];
                v.extend(b.warnings().iter().map(|w| format!("warning={w}")));
                v
            }),
            Command::Status { axes, json } => {
                let st = self.status(axes)?;
                if *json {
                    vec![serde_json::to_string(&st)?]
                } else {
                    st.iter().map(|s| s.line()).collect()
                }
            }
            Command::Move { axis, by, opts } => {
                let t = self.move_axis(axis, *by, false, opts)?;
                target_line(std::slice::from_ref(axis), &[t])
            }
            Command::MoveTo { axis, to, opts } => {
                let t = self.move_axis(axis, *to, true, opts)?;
                target_line(std::slice::from_ref(axis), &[t])
            }
            Command::Group {
                absolute,
                targets,
                sync,
                opts,
            } => {
                let t = self.group_move(targets, *absolute, *sync, opts)?;
                let names: Vec<String> = targets.iter().map(|x| x.0.clone()).collect();
                target_line(&names, &t)
            }
            Command::Arm {
                absolute,
                targets,
                sync,
                opts,
            } => {
                let t = self.group_move_or_arm(targets, *absolute, *sync, opts, true)?;
                let names: Vec<String> = targets.iter().map(|x| x.0.clone()).collect();
                target_line(&names, &t)
            }
            Command::Fire => {
                self.with_board(|b, now| b.fire(now))?;
                vec![]
            }
            Command::SyncTick => {
                let s = self.with_board(|b, now| b.sync_state(now))?;
                vec![format!(
                    "synctick={} armed={} ready={} late={} line={}",
                    s.tick, s.armed as u8, s.ready as u8, s.late as u8, s.line as u8
                )]
            }
            Command::Stop { axis } => {
                self.stop(axis.as_deref())?;
                vec![]
            }
            Command::EStop => {
                self.estop();
                vec![]
            }
            Command::Reset => {
                self.reset();
                vec![]
            }
            Command::Home { axis } => {
                self.home(axis)?;
                vec![]
            }
            Command::Get { axis, key } => self.with_board(|b, _| -> Result<_, CtlError> {
                let s = b.settings(axis)?;
                Ok(match key {
                    Some(k) => vec![format!("{k}={}", s.get(k)?)],
                    None => s.list(),
                })
            })?,
            Command::Set { axis, key, value } => {
                self.with_board(|b, now| b.set(axis, key, value, now))?;
                vec![]
            }
            Command::Save { name, axes } => {
                let p = self.with_board(|b, now| b.save_position(name, axes, now))?;
                vec![named_line(name, &p)]
            }
            Command::Goto { name, opts } => {
                let targets = self.with_board(|b, _| b.goto_targets(name))?;
                self.group_move(&targets, true, false, opts)?;
                vec![]
            }
            Command::Positions => {
                let all = self.with_board(|b, _| b.named_positions())?;
                all.iter().map(|(n, p)| named_line(n, p)).collect()
            }
            Command::Devices => vec![self.devices.clone()],
            Command::Mount(cmd) => crate::mount::line::run(self.mounts(), self, cmd)?,
            Command::Forget { name } => {
                self.with_board(|b, _| b.forget(name))?;
                vec![]
            }
            Command::Preset { name, opts } => {
                self.with_board(|b, _| b.set_preset(name, opts))?;
                vec![]
            }
            Command::Presets => {
                let all = self.with_board(|b, _| b.presets())?;
                all.iter()
                    .map(|(n, o)| format!("{n} {}", o.words().join(" ")))
                    .collect()
            }
            Command::SimSlip { axis, steps } => {
                self.with_board(|b, now| b.sim_slip(axis, *steps, now))?;
                vec![]
            }
            Command::Track { axis, rate, opts } => {
                // a lease is wall-clock seconds: board ticks at this time scale
                let lease = opts
                    .lease
                    .map(|s| (s * self.clock.ticks_per_s).ceil().min(1e18) as u64);
                let r = self.with_board(|b, now| b.track(axis, rate, opts, lease, now))?;
                vec![format!("{axis} rate={r}")]
            }
            Command::RatePreset { name, rate } => {
                self.with_board(|b, _| b.set_rate_preset(name, rate))?;
                vec![]
            }
            Command::Rates => {
                let all = self.with_board(|b, _| b.rate_presets())?;
                all.iter().map(|(n, r)| format!("{n} {r}")).collect()
            }
            Command::Release { axis } => {
                self.with_board(|b, now| b.release(axis, now))?;
                vec![]
            }
            Command::Energize { axis } => {
                self.with_board(|b, now| b.energize(axis, now))?;
                vec![]
            }
            Command::SetPos { axis, to } => {
                let p = self.with_board(|b, now| b.set_position(axis, *to, now))?;
                vec![format!("{axis} pos={p}")]
            }
        })
    }
}

fn named_line(name: &str, p: &crate::store::NamedPosition) -> String {
    let parts: Vec<String> = p.iter().map(|(a, x)| format!("{a}={x}")).collect();
    format!("{name} {}", parts.join(" "))
}
