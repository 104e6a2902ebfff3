//! Loading moves onto the board: computed moves into its slots, streamed ones armed and
//! preloaded, the Hall stop ramp, and one `Start` for them all.

use super::roll;
use super::*;

impl FpgaBackend {
    /// The stop ramp of a Hall stop from `speed` (steps/s) at `amax`: one constant
    /// deceleration segment, its duration rounded down so it ends at or above zero speed.
    pub(super) fn stop_ramp(&self, speed: f64, amax: f64) -> Result<(IntProfile, u64), CtlError> {
        let clock = self.params.clock_hz as u64;
        let v = speed.round().max(1.0);
        let steps = multistep_core::stop_distance(v, amax, None).ceil().max(1.0) as u64;
        let ticks = (2.0 * steps as f64 * clock as f64 / v).floor() as u64;
        let p = IntProfile::segments(
            &[IntSegment {
                v0: v as u64,
                ticks,
                steps,
            }],
            IntClock::hz(clock),
        )
        .map_err(|e| CtlError::Setting(format!("the Hall stop ramp: {e}")))?;
        Ok((p, steps))
    }

    /// The writes that set an axis's DIR and arm its replay unit (`arm`: `StreamSteps`, or
    /// `ChainSteps` for chain records) for `steps` steps (its buffer emptied), the Hall and
    /// stopped flags cleared.
    pub(super) fn arm_writes(
        &self,
        axis: usize,
        dir: i64,
        arm: AxisReg,
        steps: u32,
    ) -> Result<Vec<link::RegWrite>, CtlError> {
        let a = axis as u32;
        let w = self
            .params
            .widths()
            .map_err(|e| CtlError::Setting(format!("the board's widths: {e}")))?;
        Ok(vec![
            link::RegWrite {
                reg: Reg::Board(BoardReg::Clear),
                data: 1 << a,
            },
            // DIR through the core's control word (bit 31), as for computed moves
            link::RegWrite {
                reg: Reg::Core(core_addr(&w, true, a, 1)),
                data: u32::from(dir > 0) << 31,
            },
            link::RegWrite {
                reg: Reg::Axis(a, arm),
                data: steps,
            },
        ])
    }

    /// A move the datapath cannot compute, streamed: `plan`'s exact edges at the board's
    /// clock, coded as the buffer makes room.
    pub(super) fn load_streamed(
        &mut self,
        l: &Launch,
        now: u64,
    ) -> Result<(Vec<link::RegWrite>, Running, Option<Feed>), CtlError> {
        if !self.streams {
            return Err(CtlError::Setting(NO_REPLAY.into()));
        }
        // A Hall stop on a streamed axis: the board halts it at the edge when that stays
        // within amax (there is no ramp piece to divert to); faster, the stream is coded
        // only a lead ahead and the host codes the stop ramp when it sees the edge.
        let host_ramp = l.stop_on_sensor == Some(true)
            && !halts_within_amax(l.profile.peak_speed(), self.axes[l.axis].settings.amax);
        if l.stop_on_sensor == Some(true) && !host_ramp {
            self.hall_stop |= 1 << l.axis;
        } else {
            self.hall_stop &= !(1 << l.axis);
        }
        let clock = l.clock_hz;
        let steps = l.profile.steps();
        let n = u32::try_from(steps).map_err(|_| {
            CtlError::Setting(format!(
                "a streamed move of {steps} steps: the board counts at most {} a move",
                u32::MAX
            ))
        })?;
        let src = EdgeSource::new(l.profile.clone(), clock, 0)?;
        let run = Running {
            dir: l.dir,
            stop_on_sensor: l.stop_on_sensor,
            stopping: false,
            end_tick: now + (l.profile.duration() * clock).round() as u64,
            ramp_steps: 0,
            wraps: 0,
            roll: None,
        };
        if let Some(c) = self.chained(l) {
            // computed on the board: every record goes before the start
            let steps = c.steps();
            let mut feed = Feed::fixed(Box::new(src), c.bytes, steps, self.params.tick_bits);
            feed.dir = l.dir;
            feed.count0 = self.axes[l.axis].count;
            let w = self.arm_writes(l.axis, l.dir, AxisReg::ChainSteps, n)?;
            return Ok((w, run, Some(feed)));
        }
        let mut feed = Feed::new(Box::new(src), 0, self.params.tick_bits, false);
        feed.dir = l.dir;
        feed.count0 = self.axes[l.axis].count;
        feed.lead_limited = host_ramp;
        let w = self.arm_writes(l.axis, l.dir, AxisReg::StreamSteps, n)?;
        Ok((w, run, Some(feed)))
    }

    /// `l`'s chain records, when the board computes its pieces: chain units whose records
    /// are [`CHAIN_LAYOUT`]'s, a move of polynomial pieces (scurve, scurve4 and trapezoid
    /// pieces) within the units' widths, all its records in the stream buffer at once, a
    /// chain that stays ahead of the pulse unit, and no Hall stop (a homing search
    /// streams, so the host can code its stop ramp).
    pub(super) fn chained(&self, l: &Launch) -> Option<ChainedMove> {
        if self.chains as usize != CHAIN_LAYOUT.record_bytes() || l.stop_on_sensor.is_some() {
            return None;
        }
        let clock = l.clock_hz as u64;
        let bits = self.params.tick_bits;
        ChainedMove::from_profile(&l.profile, clock, bits, &CHAIN_LAYOUT)
            .ok()
            .filter(|c| c.bytes.len() <= self.buffer as usize)
            // a chain walks a tick a clock: a slow tail after a fast stretch can outrun
            // the lead its FIFO holds (multistep_core::tdm::chain), so such a move streams
            .filter(|c| c.keeps_up(self.params.fifo_depth))
    }

    /// Arms the streaming axes' buffers (their free count is the buffer's size) and sends
    /// what fits before the start.
    pub(super) fn preload(&mut self, feeds: &mut [(usize, Feed)]) -> Result<(), LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        for (i, f) in feeds.iter_mut() {
            let a = *i as u32;
            f.buffer = l.read(Reg::Axis(a, AxisReg::StreamFree))?;
            f.free = f.buffer;
            if f.buffer == 0 {
                return Err(LinkError::Move(NO_REPLAY.into()));
            }
            pump(l, f, a, 0, false)?;
        }
        Ok(())
    }

    /// Loads the moves (`writes`) and the Hall stops, preloads the streams, then starts
    /// `mask` as one group.
    pub(super) fn send_start(
        &mut self,
        mut writes: Vec<link::RegWrite>,
        feeds: &mut [(usize, Feed)],
        mask: u32,
    ) -> Result<(), CtlError> {
        self.link()?;
        writes.push(link::RegWrite {
            reg: Reg::Board(BoardReg::HallStop),
            data: self.hall_stop,
        });
        if self.arming {
            writes.push(self.arm_timeout_write());
        }
        // `Start`, or `Arm` for a cross-board start (sync.rs)
        let go = self.go_write(mask);
        let no_link = || LinkError::Io("no link".into());
        let r = self
            .link
            .as_mut()
            .ok_or_else(no_link)
            .and_then(|l| l.write_all(&writes))
            .and_then(|_| self.preload(feeds))
            .and_then(|_| {
                let l = self.link.as_mut().ok_or_else(no_link)?;
                // a go whose reply stays lost after the retransmissions may have started
                l.write(go.reg, go.data).inspect_err(|e| {
                    if e.in_doubt() || matches!(e, LinkError::Io(_)) {
                        self.doubt |= mask;
                    }
                })
            });
        self.tell_retransmits();
        if let (Err(e), Some(l)) = (&r, self.link.as_mut()) {
            let busy = matches!(
                e,
                LinkError::Refused {
                    status: Status::Busy,
                    ..
                }
            );
            if !e.in_doubt() && !busy && !matches!(e, LinkError::Io(_)) {
                // refused: nothing started, so nothing stays armed
                for (i, _) in feeds.iter() {
                    let _ = l.write(Reg::Axis(*i as u32, AxisReg::StreamSteps), 0);
                }
            }
        }
        r.map_err(|e| match e {
            LinkError::Refused {
                status: Status::Busy,
                ..
            } => CtlError::Busy {
                axis: format!("on {}", self.name),
                state: "busy",
            },
            LinkError::Refused {
                status: Status::BadAddress,
                ..
            } if self.arming => crate::backend::no_sync(&self.name),
            e => self.failed(e),
        })
    }

    pub(super) fn load(
        &mut self,
        l: &Launch,
        now: u64,
    ) -> Result<(Vec<link::RegWrite>, Running, Option<Feed>), CtlError> {
        let Some(ip) = l.datapath.as_ref() else {
            return self.load_streamed(l, now);
        };
        let a = l.axis as u32;
        let m = self
            .computed(ip, l.dir > 0, l.stop_on_sensor)
            .map_err(|e| CtlError::Setting(format!("the board cannot run this move: {e}")))?;
        let homing = l.stop_on_sensor == Some(true);
        let slots = self.params.pieces as usize;
        // a homing search's stop ramp takes a slot: the pieces ahead of the calculator
        // have the rest
        let ahead = slots - usize::from(homing);
        if homing && self.streams && m.pieces.len() > ahead {
            // its pieces, split to the tick width, take every slot: stream it
            return self.load_streamed(l, now);
        }
        let mut ramp = None;
        let mut ramp_steps = 0;
        if homing {
            let amax = self.axes[l.axis].settings.amax;
            let (profile, steps) = self.stop_ramp(l.profile.peak_speed(), amax)?;
            let rm = AxisMove::from_profile(&profile, l.dir > 0, &self.params)
                .map_err(|e| CtlError::Setting(format!("the Hall stop ramp: {e}")))?;
            ramp = Some(rm.pieces[0]);
            ramp_steps = steps;
        }
        let mut w = vec![link::RegWrite {
            reg: Reg::Board(BoardReg::Clear),
            data: 1 << a,
        }];
        if self.streams {
            // computed, whatever an earlier start that failed left armed
            w.push(link::RegWrite {
                reg: Reg::Axis(a, AxisReg::StreamSteps),
                data: 0,
            });
        }
        // more pieces than the slots ahead: the first ones now, the rest as the move runs
        let mut roll = None;
        if m.pieces.len() > ahead {
            let (now, later) =
                link::rolling_writes(&self.params, a, &m, 0, ramp.as_ref()).map_err(link_err)?;
            w.extend(now);
            let ax = &self.axes[l.axis];
            let pieces = m.pieces.len();
            roll = Some(roll::Roll::new(later, pieces, m.dir, ax.count, ax.offset));
        } else {
            w.extend(link::move_writes(&self.params, a, &m, 0).map_err(link_err)?);
            if let Some(r) = &ramp {
                let slot = self.params.pieces - 1;
                w.extend(link::stop_ramp_writes(&self.params, a, slot, r).map_err(link_err)?);
            }
        }
        if homing {
            self.hall_stop |= 1 << a;
        } else {
            self.hall_stop &= !(1 << a);
        }
        let run = Running {
            dir: l.dir,
            stop_on_sensor: l.stop_on_sensor,
            stopping: false,
            end_tick: now + ip.end_tick(),
            ramp_steps,
            wraps: 0,
            roll,
        };
        Ok((w, run, None))
    }

    /// `ip` as the board computes it: in its slots, or on a board without replay units
    /// (where it cannot stream) loaded while it runs when it has more pieces than slots
    /// (a homing search: than the slots its stop ramp leaves).
    pub(super) fn computed(
        &self,
        ip: &IntProfile,
        dir: bool,
        stop_on_sensor: Option<bool>,
    ) -> Result<AxisMove, String> {
        let ahead = self.params.pieces as usize - usize::from(stop_on_sensor == Some(true));
        match AxisMove::from_profile(ip, dir, &self.params) {
            Ok(m) if self.streams || m.pieces.len() <= ahead => Ok(m),
            Err(e) if self.streams => Err(e.to_string()),
            _ => roll::rolling(ip, dir, &self.params, ahead),
        }
    }
}

/// The board may halt a streamed search at the Hall edge when halting from `speed` stays
/// within `amax`, i.e. a stop at amax would cover at most one step (`speed² ≤ 2·amax`),
/// which is what the simulated backend's stop ramp then does too (`motion::stop_profile`).
pub(super) fn halts_within_amax(speed: f64, amax: f64) -> bool {
    speed <= (2.0 * amax).sqrt() * (1.0 + 1e-9)
}

/// Why a board refuses what only streaming runs.
pub(super) const NO_REPLAY: &str =
    "the board has no replay units for streamed moves (its build has \
    no stream buffers: a bulk write answers status 7), so it runs only trapezoids of \
    whole-number speeds (those of more pieces than its slots loaded as they run), and no \
    tracking";

/// Checks that every period of `plan`'s edges of `mv` at `clock_hz` fits the replay
/// unit (2 to 2^tick_bits − 1 ticks), before anything starts.
pub(super) fn check_streamable(
    mv: &multistep_core::Move<'_>,
    clock_hz: f64,
    tick_bits: u32,
) -> Result<(), CtlError> {
    let max = (1u64 << tick_bits.min(63)) - 1;
    let mut last = 0;
    for (i, t) in multistep_core::edges(mv, clock_hz)?.enumerate() {
        let p = t.wrapping_sub(last);
        if p < 2 || p > max {
            return Err(CtlError::Setting(format!(
                "the board cannot stream this move: step {} comes {p} ticks after the one \
                 before; its replay unit takes 2 to {max} ticks ({:.3} s at its clock)",
                i + 1,
                max as f64 / clock_hz
            )));
        }
        last = t;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::model::connect;

    /// The Hall stop ramp from `v` at `amax` covers at least the distance a stop at amax
    /// needs, v²/(2·amax), and less than a step more, so it never decelerates harder than
    /// amax.
    #[test]
    fn the_hall_stop_ramp_never_decelerates_harder_than_amax() {
        let (b, _m) = connect();
        for (v, amax) in [
            (1000.0, 3000.0),
            (4000.0, 40_000.0),
            (283.0, 40_000.0),
            (7.0, 2.0),
        ] {
            let (_, steps) = b.stop_ramp(v, amax).unwrap();
            let need = v * v / (2.0 * amax);
            assert!(
                steps as f64 >= need && (steps as f64) < need.max(1.0) + 1.0,
                "from {v} at {amax}: {steps} steps, {need} needed"
            );
        }
    }
}
