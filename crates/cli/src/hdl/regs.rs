//! `multistep hdl regs`: the link frames and register writes that load a move into one
//! axis of a board and start it (docs/HDL.md, "hdl regs"). The move flags are plan's.

use crate::moveargs::MoveArgs;
use clap::Args;
use multistep_hdl::boards::Board;
use multistep_hdl::link::{
    int_profile, move_writes, requests, start_write, BoardReg, Reg, RegWrite,
};
use multistep_hdl::{AxisMove, BoardTop};
use std::io::Write;

#[derive(Args, Debug)]
pub struct RegsArgs {
    /// Board name (see `multistep hdl boards`)
    #[arg(long)]
    board: String,
    /// Axes the board is built with (default: the board's default)
    #[arg(long)]
    axes: Option<u32>,
    /// The axis to load (0-based)
    #[arg(long, default_value_t = 0)]
    axis: u32,
    /// Move in the negative direction (DIR bit 0; the default is positive, DIR bit 1)
    #[arg(long)]
    reverse: bool,
    /// Also write the STEP pulse width (ticks; 0 = 50 % duty)
    #[arg(long, value_name = "TICKS")]
    pulse_width: Option<u32>,
    /// Also write the DIR setup time (ticks)
    #[arg(long, value_name = "TICKS")]
    dir_setup: Option<u32>,
    /// Sequence number of the first frame
    #[arg(long, default_value_t = 0)]
    seq: u8,
    #[command(flatten)]
    mv: MoveArgs,
}

/// The register's name in the listing.
fn reg_name(top: &BoardTop, reg: Reg) -> String {
    match reg {
        Reg::Board(r) => format!("{r:?}"),
        Reg::Axis(a, r) => format!("axis{a}.{r:?}"),
        Reg::Core(addr) => {
            let aw = top.widths().map(|w| w.aw).unwrap_or(7);
            let cmd = addr >> (aw - 1) & 1 == 1;
            let axis = (addr >> 5) & ((1 << (aw - 6)) - 1);
            let word = addr & 0x1F;
            if cmd {
                match word {
                    0 => format!("core.commit(axis {axis})"),
                    1 => format!("core.control(axis {axis})"),
                    _ => format!("core.cmd{word}"),
                }
            } else {
                const NAMES: [&str; 17] = [
                    "y0[0]", "y0[1]", "y0[2]", "y0[3]", "dy[0]", "dy[1]", "dy[2]", "dy[3]", "k[0]",
                    "k[1]", "k[2]", "dv[0]", "dv[1]", "dv[2]", "t0", "steps", "mode",
                ];
                format!("core.stage.{}", NAMES.get(word as usize).unwrap_or(&"?"))
            }
        }
    }
}

pub fn run(a: &RegsArgs) -> anyhow::Result<()> {
    let board = Board::by_name(&a.board)?;
    let axes = a.axes.unwrap_or(board.default_axes);
    let p = board.params(axes)?;
    let top = BoardTop::new(p.clone(), board.baud);
    top.widths()?;
    let clock = p.clock_hz as u64;
    let profile = int_profile(&a.mv.spec().resolve()?, clock)?;
    let m = AxisMove::from_profile(&profile, !a.reverse, &p)?;
    let mut writes = Vec::new();
    if let Some(w) = a.pulse_width {
        writes.push(RegWrite {
            reg: Reg::Board(BoardReg::PulseWidth),
            data: w,
        });
    }
    if let Some(d) = a.dir_setup {
        writes.push(RegWrite {
            reg: Reg::Board(BoardReg::DirSetup),
            data: d,
        });
    }
    writes.extend(move_writes(&p, a.axis, &m, a.pulse_width.unwrap_or(0))?);
    writes.push(start_write(1 << a.axis));
    let reqs = requests(&writes, a.seq);
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "# multistep hdl regs: board {}, K = {axes}, axis {}, {} Hz, {} baud 8N1",
        board.name, a.axis, clock, board.baud
    )?;
    writeln!(
        out,
        "# move: {}, {} steps in {} pieces, last edge at tick {}",
        a.mv.describe(),
        m.steps(),
        m.pieces.len(),
        m.edges().last().copied().unwrap_or(0)
    )?;
    writeln!(
        out,
        "# seq addr data     frame (request, 11 bytes hex)  register"
    )?;
    for (r, w) in reqs.iter().zip(&writes) {
        let frame: String = r.encode().iter().map(|b| format!("{b:02x}")).collect();
        writeln!(
            out,
            "{:03} {:04x} {:08x} {frame} {}",
            r.seq,
            r.addr,
            r.data,
            reg_name(&top, w.reg)
        )?;
    }
    Ok(())
}
