//! The text of `help`.

use super::word_of_param;
use multistep_core::PARAMS;

/// The commands of `help` ([`help`] adds the move options).
pub const HELP: &[&str] = &[
    "commands (AXIS is an axis name or number; N is microsteps or a number with 'u' for user units):",
    "  move AXIS N [opts]           relative move",
    "  moveto AXIS N [opts]         absolute move (periodic axes: shortest way)",
    "  group move|moveto A=N B=N… [sync] [opts]   same start tick; sync: same finish",
    "  arm move|moveto A=N B=N… [sync] [opts]     a group that starts at the SYNC line's fall",
    "  fire  synctick               pull SYNC low; the line's state and the count at its fall",
    "  stop [AXIS|all]  estop  reset  home AXIS",
    "  status [json] [AXIS…]  get AXIS [KEY]  set AXIS KEY VALUE",
    "  save NAME [AXIS…]  goto NAME  positions  forget NAME",
    "  preset NAME opts  presets  version  info  devices  auth TOKEN",
    "  mount [slew RA DEC|sync RA DEC|track on|off [RATE]|park|unpark|setpark|abort|pulse n|s|e|w MS]",
    "  track AXIS RATE|NAME [amax=A] [lease=S]    run at RATE steps/s (or units/s with 'u'; negative",
    "                               reverses) until stop; again while tracking: change the rate",
    "  rate NAME RATE  rates  release AXIS  energize AXIS",
    "  setpos AXIS N                an idle axis's position becomes N, nothing moves",
    "  sim AXIS slip N              simulated boards only: lose N steps",
];

/// The text of `help`: [`HELP`], then the move options, every value of the core's list
/// by the word the protocol prints for it.
pub fn help() -> Vec<String> {
    let mut opts = String::from("opts: preset=P profile=F");
    for p in PARAMS {
        opts.push_str(&format!(" {}=", word_of_param(p)));
    }
    let mut lines: Vec<String> = HELP.iter().map(|s| s.to_string()).collect();
    lines.push(opts);
    lines
}
