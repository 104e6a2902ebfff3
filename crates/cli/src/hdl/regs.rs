//! `multistep hdl regs`: the link frames and register writes that load a move into one
//! axis of a board and start it (docs/HDL.md, "hdl regs"). The move flags are plan's.

use crate::moveargs::MoveArgs;
use clap::Args;
use multistep_hdl::boards::Board;
use multistep_hdl::link::{
    int_profile, requests, rolling_writes, start_write, BoardReg, Reg, RegWrite,
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
    /// Stream the move: plan's edges, coded and sent in bulk writes to the axis's replay
    /// unit (any family and mode; the default computes trapezoids on the board). On a
    /// board with chain units, scurve and scurve4 moves send their chain records instead
    /// (computed on the board), as `serve` does
    #[arg(long)]
    stream: bool,
    /// Data bytes per bulk write when streaming (1-255)
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u16).range(1..=255))]
    frame: u16,
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
    let top = board.board_top(&p);
    top.widths()?;
    let clock = p.clock_hz as u64;
    if a.stream {
        return streamed(a, board, &top, axes);
    }
    let profile = int_profile(&a.mv.spec().resolve()?, clock)?;
    // more pieces than the board's slots: loaded while it runs, as serve does on a board
    // without replay units
    let m = match AxisMove::from_profile(&profile, !a.reverse, &p) {
        Ok(m) => m,
        Err(_) => AxisMove::rolling(&profile, !a.reverse, &p)?,
    };
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
    let (now, later) = rolling_writes(&p, a.axis, &m, a.pulse_width.unwrap_or(0), None)?;
    writes.extend(now);
    writes.push(start_write(1 << a.axis));
    let first = writes.len();
    writes.extend(later.iter().flat_map(|l| l.writes.iter().copied()));
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
    if let Some(l) = later.first() {
        writeln!(
            out,
            "# its {} pieces are more than the board's {} slots: the first {} before the \
             start, each later one once the axis has made the steps that free its slot \
             (Position register), before the calculator needs it",
            m.pieces.len(),
            p.pieces,
            l.piece
        )?;
    }
    writeln!(
        out,
        "# seq addr data     frame (request, 11 bytes hex)  register"
    )?;
    let mut at = first;
    let mut next = later.iter();
    for (i, (r, w)) in reqs.iter().zip(&writes).enumerate() {
        if i == at {
            if let Some(l) = next.next() {
                let ends = |j: usize| m.pieces[j].t0 + m.pieces[j].dur;
                writeln!(
                    out,
                    "# piece {}: once the axis has made {} steps (move tick {}), before move \
                     tick {}",
                    l.piece,
                    l.made,
                    ends(l.piece - p.pieces as usize),
                    ends(l.piece - 1)
                )?;
                at += l.writes.len();
            }
        }
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

/// `--stream`: the control word (DIR), the arm write, the bulk writes that fit the empty
/// buffer, the start, then each later bulk write after the move tick it may go at.
fn streamed(a: &RegsArgs, board: &Board, top: &BoardTop, axes: u32) -> anyhow::Result<()> {
    use multistep_hdl::chain::{ChainedMove, CHAIN_LAYOUT};
    use multistep_hdl::link::{core_addr, Request};
    use multistep_hdl::stream::{Chunk, StreamedMove};
    if a.axis >= axes {
        anyhow::bail!("axis {} out of range (the board has {axes})", a.axis);
    }
    if top.stream_buffer_bits == 0 {
        anyhow::bail!(
            "board {} has no stream buffers: it runs trapezoids only (drop --stream)",
            board.name
        );
    }
    let buffer = 1u64 << top.stream_buffer_bits;
    let p = &top.core;
    let w = top.widths()?;
    let clock = p.clock_hz as u64;
    let mv = a.mv.spec().resolve()?;
    // as serve does: chain records when the board computes the move, all before the start
    let chained = top
        .chains
        .then(|| ChainedMove::plan(&mv, clock, w.wd, &CHAIN_LAYOUT).ok())
        .flatten()
        .filter(|c| c.bytes.len() as u64 <= buffer && c.keeps_up(p.fifo_depth));
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "# multistep hdl regs --stream: board {}, K = {axes}, axis {}, {} Hz, {} baud 8N1",
        board.name, a.axis, clock, board.baud
    )?;
    let (arm, bytes, chunks): (RegWrite, Vec<u8>, Vec<Chunk>) = match chained {
        Some(c) => {
            writeln!(
                out,
                "# move: {}, {} steps, last edge at tick {}, computed on the board: {} chain \
                 records, {} bytes ({:.3} per step)",
                a.mv.describe(),
                c.steps(),
                c.edges.last().copied().unwrap_or(0),
                c.records,
                c.bytes.len(),
                c.bytes_per_step()
            )?;
            let chunks = c
                .frames(usize::from(a.frame))
                .into_iter()
                .map(|range| Chunk {
                    not_before: None,
                    range,
                })
                .collect();
            (c.arm_write(a.axis), c.bytes, chunks)
        }
        None => {
            let m = StreamedMove::plan(&mv, clock, w.wd)?;
            writeln!(
                out,
                "# move: {}, {} steps, last edge at tick {}, {} code bytes ({:.3} per step)",
                a.mv.describe(),
                m.steps(),
                m.edges.last().copied().unwrap_or(0),
                m.bytes.len(),
                m.bytes_per_step()
            )?;
            let chunks = m.chunks(buffer, usize::from(a.frame));
            (m.arm_write(a.axis), m.bytes, chunks)
        }
    };
    writeln!(
        out,
        "# seq addr data     frame (hex; bulk writes: data = length)  register"
    )?;
    let mut seq = a.seq;
    let row = |out: &mut std::io::StdoutLock, r: Request, name: String| {
        let frame: String = r.encode().iter().map(|b| format!("{b:02x}")).collect();
        writeln!(
            out,
            "{:03} {:04x} {:08x} {frame} {name}",
            r.seq, r.addr, r.data
        )
    };
    let mut writes = Vec::new();
    if let Some(d) = a.dir_setup {
        writes.push(RegWrite {
            reg: Reg::Board(BoardReg::DirSetup),
            data: d,
        });
    }
    if let Some(pw) = a.pulse_width {
        writes.push(RegWrite {
            reg: Reg::Board(BoardReg::PulseWidth),
            data: pw,
        });
    }
    writes.push(RegWrite {
        reg: Reg::Core(core_addr(&w, true, a.axis, 1)),
        data: u32::from(!a.reverse) << 31,
    });
    writes.push(arm);
    for wr in &writes {
        let r = Request::write(seq, wr.reg, wr.data);
        row(&mut out, r, reg_name(top, wr.reg))?;
        seq = seq.wrapping_add(1);
    }
    let bulk = |out: &mut std::io::StdoutLock, c: &Chunk, seq: u8| {
        let b = multistep_hdl::link::BulkWrite {
            seq,
            addr: Reg::Axis(a.axis, multistep_hdl::link::AxisReg::StreamData).addr(),
            data: bytes[c.range.clone()].to_vec(),
        };
        let frame: String = b.encode()?.iter().map(|x| format!("{x:02x}")).collect();
        writeln!(
            out,
            "{:03} {:04x} {:08x} {frame} axis{}.StreamData[{}..{}]",
            seq,
            b.addr,
            b.data.len(),
            a.axis,
            c.range.start,
            c.range.end
        )?;
        anyhow::Ok(())
    };
    let mut started = false;
    for c in &chunks {
        if c.not_before.is_some() && !started {
            let s = start_write(1 << a.axis);
            row(
                &mut out,
                Request::write(seq, s.reg, s.data),
                reg_name(top, s.reg),
            )?;
            seq = seq.wrapping_add(1);
            started = true;
        }
        if let Some(t) = c.not_before {
            writeln!(out, "# from move tick {t}")?;
        }
        bulk(&mut out, c, seq)?;
        seq = seq.wrapping_add(1);
    }
    if !started {
        let s = start_write(1 << a.axis);
        row(
            &mut out,
            Request::write(seq, s.reg, s.data),
            reg_name(top, s.reg),
        )?;
    }
    Ok(())
}
