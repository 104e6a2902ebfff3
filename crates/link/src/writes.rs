//! A move as the register writes and request frames that load and start it: a computed
//! move's pieces into the core's staging words, a stop ramp, the start and the arm, and
//! plan's moves as the board's integer moves.

use crate::{
    core_addr, mode_code, AxisMove, AxisReg, BoardReg, CoreParams, LinkError, PieceRegs, RecurRegs,
    Reg, Request, Widths,
};

/// One register write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RegWrite {
    pub reg: Reg,
    pub data: u32,
}

/// The 17 staging words of a piece (`ms_core.v`): y0, dy (4 words each), k (3, two's
/// complement), dv (3), t0, steps, mode.
pub fn staging_words(p: &PieceRegs) -> [u32; 17] {
    let mut w = [0u32; 17];
    let k = &p.kernel;
    for i in 0..4 {
        w[i] = (k.y0 >> (32 * i)) as u32;
        w[4 + i] = (k.dy >> (32 * i)) as u32;
    }
    for i in 0..3 {
        w[8 + i] = (k.k >> (32 * i)) as u32;
        w[11 + i] = (k.dv >> (32 * i)) as u32;
    }
    w[14] = p.t0 as u32;
    w[15] = p.steps as u32;
    w[16] = mode_code(k.mode);
    w
}

/// The staging words of piece `p` on a core of widths `w`: the 17 of [`staging_words`],
/// then the recurrence's 15 ([`RecurRegs`]) when the core has it.
pub fn piece_words(w: &Widths, p: &PieceRegs) -> Vec<u32> {
    let recur = w
        .recur
        .map(|_| RecurRegs::words(RecurRegs::of(p, w).as_ref()));
    staging_words(p)
        .into_iter()
        .chain(recur.into_iter().flatten())
        .collect()
}

/// The writes that load piece `slot` of `axis`: its staging words ([`piece_words`]) and
/// the commit.
pub fn piece_writes(w: &Widths, axis: u32, slot: u32, p: &PieceRegs) -> Vec<RegWrite> {
    let mut out: Vec<RegWrite> = piece_words(w, p)
        .into_iter()
        .enumerate()
        .map(|(i, data)| RegWrite {
            reg: Reg::Core(core_addr(w, false, axis, i as u32)),
            data,
        })
        .collect();
    out.push(RegWrite {
        reg: Reg::Core(core_addr(w, true, axis, 0)),
        data: slot,
    });
    out
}

/// The writes that load `m` into `axis` (every piece from slot 0, then the axis control
/// word: DIR and the last slot). The move is checked against the core first; with a
/// fixed pulse width (`pulse_width` > 0) every period must be longer than it.
pub fn move_writes(
    p: &CoreParams,
    axis: u32,
    m: &AxisMove,
    pulse_width: u32,
) -> Result<Vec<RegWrite>, LinkError> {
    if axis >= p.axes {
        return Err(LinkError::Axis { axis, axes: p.axes });
    }
    m.check(p)?;
    check_pulse(m, pulse_width)?;
    let w = p.widths()?;
    let mut out = Vec::new();
    for (slot, pc) in m.pieces.iter().enumerate() {
        out.extend(piece_writes(&w, axis, slot as u32, pc));
    }
    out.push(RegWrite {
        reg: Reg::Core(core_addr(&w, true, axis, 1)),
        data: (u32::from(m.dir) << 31) | (m.pieces.len() as u32 - 1),
    });
    Ok(out)
}

/// With a fixed pulse width (`pulse_width` > 0) every period of `m` must be longer.
fn check_pulse(m: &AxisMove, pulse_width: u32) -> Result<(), LinkError> {
    if pulse_width > 0 {
        let edges = m.edges();
        let short = edges.windows(2).map(|e| e[1] - e[0]).min();
        if let Some(s) = short.filter(|&s| s <= u64::from(pulse_width)) {
            return Err(LinkError::Move(format!(
                "a period of {s} ticks is not longer than the {pulse_width}-tick STEP pulse"
            )));
        }
    }
    Ok(())
}

/// A piece of a move loaded while it runs: `writes` may go once the axis has made `made`
/// steps of the move ([`AxisMove::late_pieces`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LateLoad {
    /// The piece's index in the move.
    pub piece: usize,
    pub made: u64,
    /// The piece into slot i mod slots, then the axis control word naming that slot the
    /// move's last.
    pub writes: Vec<RegWrite>,
}

/// The writes that load `m`, of more pieces than the core's slots, into `axis` as it runs
/// ([`AxisMove::rolling`]): those before the start (its first pieces, the control word
/// naming the last slot the last) and the later ones, each after the steps that free its
/// slot. A move that fits the slots has no later loads. `pulse_width` as for
/// [`move_writes`].
///
/// With a Hall stop `ramp` (a homing search) the ramp takes a slot too: the first S − 1
/// pieces go before the start and the ramp into slot S − 1 ([`stop_ramp_writes`]); piece
/// i (from S − 1 on) goes into slot i mod S, where the ramp was, once the ramp has moved
/// on into slot i + 1 mod S, freed by piece i + 1 − S. So the ramp is always loaded and
/// never in the calculator's way; once the Hall stop has diverted the axis, the board
/// refuses the axis's later loads (status 4) and the ramp ends the move.
pub fn rolling_writes(
    p: &CoreParams,
    axis: u32,
    m: &AxisMove,
    pulse_width: u32,
    ramp: Option<&PieceRegs>,
) -> Result<(Vec<RegWrite>, Vec<LateLoad>), LinkError> {
    if axis >= p.axes {
        return Err(LinkError::Axis { axis, axes: p.axes });
    }
    m.check_rolling(p)?;
    check_pulse(m, pulse_width)?;
    let w = p.widths()?;
    let slots = (p.pieces as usize).max(1);
    // the pieces ahead of the calculator at most: every slot, or all but the ramp's
    let ahead = slots - usize::from(ramp.is_some());
    if ahead == 0 {
        return Err(LinkError::Move(format!(
            "a stop ramp and a move need more than {slots} slot"
        )));
    }
    let control = |last: usize| RegWrite {
        reg: Reg::Core(core_addr(&w, true, axis, 1)),
        data: (u32::from(m.dir) << 31) | (last % slots) as u32,
    };
    let ramp_into = |slot: usize| match ramp {
        Some(r) => stop_ramp_writes(p, axis, slot as u32, r),
        None => Ok(Vec::new()),
    };
    let first = m.pieces.len().min(ahead);
    let mut now: Vec<RegWrite> = (m.pieces[..first].iter().enumerate())
        .flat_map(|(slot, pc)| piece_writes(&w, axis, slot as u32, pc))
        .collect();
    now.push(control(first - 1));
    now.extend(ramp_into(slots - 1)?);
    let mut later = Vec::new();
    for (i, made) in m.late_pieces(ahead) {
        let mut writes = ramp_into((i + 1) % slots)?;
        writes.extend(piece_writes(&w, axis, (i % slots) as u32, &m.pieces[i]));
        writes.push(control(i));
        later.push(LateLoad {
            piece: i,
            made,
            writes,
        });
    }
    Ok((now, later))
}

/// The writes that load a stop ramp (one piece, its t0 counted from the last edge before
/// the Hall edge; `PieceRegs::t0` should be 0) into `slot` of `axis` and select it.
pub fn stop_ramp_writes(
    p: &CoreParams,
    axis: u32,
    slot: u32,
    ramp: &PieceRegs,
) -> Result<Vec<RegWrite>, LinkError> {
    if axis >= p.axes {
        return Err(LinkError::Axis { axis, axes: p.axes });
    }
    if slot >= p.pieces {
        return Err(LinkError::Move(format!(
            "slot {slot} of {} slots",
            p.pieces
        )));
    }
    let probe = AxisMove {
        dir: false,
        pieces: vec![*ramp],
    };
    probe.check(p)?;
    let w = p.widths()?;
    let mut out = piece_writes(&w, axis, slot, ramp);
    out.push(RegWrite {
        reg: Reg::Axis(axis, AxisReg::StopSlot),
        data: slot,
    });
    Ok(out)
}

/// The write that starts `axes` (a mask) as one group.
pub fn start_write(axes: u32) -> RegWrite {
    RegWrite {
        reg: Reg::Board(BoardReg::Start),
        data: axes,
    }
}

/// The write that arms `axes` (a mask) as one group, to start at the next SYNC edge.
pub fn arm_write(axes: u32) -> RegWrite {
    RegWrite {
        reg: Reg::Board(BoardReg::Arm),
        data: axes,
    }
}

/// Numbers the writes as request frames from sequence number `seq` on (wrapping).
pub fn requests(writes: &[RegWrite], seq: u8) -> Vec<Request> {
    writes
        .iter()
        .enumerate()
        .map(|(i, w)| Request::write(seq.wrapping_add(i as u8), w.reg, w.data))
        .collect()
}

/// A planned integer move on one axis as the frames that load it and start it alone.
pub fn move_frames(
    p: &CoreParams,
    axis: u32,
    profile: &multistep_core::int::IntProfile,
    dir: bool,
    pulse_width: u32,
    seq: u8,
) -> Result<Vec<Request>, LinkError> {
    let m = AxisMove::from_profile(profile, dir, p)?;
    let mut w = move_writes(p, axis, &m, pulse_width)?;
    w.push(start_write(1 << axis));
    Ok(requests(&w, seq))
}

/// A move given in plan's units (steps/s, s) as `multistep_core::int`'s integer move on a
/// `clock_hz` clock: trapezoid moves only (phases, segments or limits), every speed a whole
/// number of steps/s and every time a whole number of ticks (to 1e-6), else an error
/// saying which value.
pub fn int_profile(
    mv: &multistep_core::Move<'_>,
    clock_hz: u64,
) -> Result<multistep_core::int::IntProfile, LinkError> {
    use multistep_core::int::{IntClock, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment};
    use multistep_core::{Family, Move, Order};
    let whole = |x: f64, what: &str| -> Result<u64, LinkError> {
        let r = x.round();
        if !x.is_finite() || x < 0.0 || (x - r).abs() > 1e-6 || r >= 2f64.powi(63) {
            return Err(LinkError::Move(format!(
                "{what} {x} is not a whole number (the board's planner is integer)"
            )));
        }
        Ok(r as u64)
    };
    let ticks = |s: f64, what: &str| {
        whole(s * clock_hz as f64, &format!("{what} {s} s is")).map_err(|_| {
            LinkError::Move(format!(
                "{what} {s} s is not a whole number of ticks at {clock_hz} Hz"
            ))
        })
    };
    let clock = IntClock::hz(clock_hz);
    let plan = |r: Result<IntProfile, multistep_core::int::IntError>| {
        r.map_err(|e| LinkError::Move(format!("the integer planner: {e}")))
    };
    match mv {
        Move::Phase(m) => {
            if m.family != Family::Trapezoid {
                return Err(LinkError::Move(format!(
                    "the board computes trapezoids only, not {:?} (stream it: hdl regs --stream)",
                    m.family
                )));
            }
            plan(IntProfile::phase(
                &IntPhaseMove {
                    steps: m.steps,
                    accel_ticks: ticks(m.accel_time, "accel time")?,
                    cruise_ticks: ticks(m.cruise_time, "cruise time")?,
                    decel_ticks: ticks(m.decel_time, "decel time")?,
                    start_speed: whole(m.start_speed, "start speed")?,
                    end_speed: whole(m.end_speed, "end speed")?,
                },
                clock,
            ))
        }
        Move::Segments(segs) => {
            let v: Result<Vec<IntSegment>, LinkError> = segs
                .iter()
                .map(|g| {
                    Ok(IntSegment {
                        v0: whole(g.v0, "segment start speed")?,
                        ticks: ticks(g.duration, "segment time")?,
                        steps: g.steps,
                    })
                })
                .collect();
            plan(IntProfile::segments(&v?, clock))
        }
        Move::Limits(m) => {
            if m.order != Order::Trapezoid || m.jmax.is_some() || m.smax.is_some() {
                return Err(LinkError::Move(
                    "the board computes trapezoids only, no jerk or snap limit (stream it: hdl regs --stream)".into(),
                ));
            }
            plan(IntProfile::limits(
                &IntLimitsMove {
                    steps: m.steps,
                    vmax: whole(m.vmax, "vmax")?,
                    amax: whole(m.amax, "amax")?,
                    start_speed: whole(m.start_speed, "start speed")?,
                    end_speed: whole(m.end_speed, "end speed")?,
                },
                clock,
            ))
        }
    }
}
