//! A computed move of more pieces than the board's slots, loaded while it runs (on a
//! board without replay units, where it cannot stream): its first pieces before the
//! start, then piece i into slot i mod S once the axis has made the steps of piece i − S
//! (the board's calculator runs ahead of its pulse unit, so it is past that piece), the
//! axis control word then naming that slot the last (`link::rolling_writes`; docs/HDL.md,
//! "Pieces and the calculator"). A homing search keeps one slot for its stop ramp: its
//! pieces take the other S − 1, and before piece i goes to slot i mod S the ramp moves on
//! to slot (i + 1) mod S, so the StopSlot the board diverts to on the Hall edge is always
//! one the calculator has not reached. Pieces are loaded at each poll; if they come too
//! late, the board ends the move after the last piece loaded, and its end says so; once a
//! Hall stop has diverted the axis the board refuses further loads (busy), which ends the
//! roll.

use super::*;

/// The least time between the end of piece i − S, from when piece i may be loaded, and
/// the end of piece i − 1, by when the board needs it (s): a move whose pieces leave less
/// is refused before it starts.
pub(super) const ROLL_LEAD_S: f64 = 0.25;

/// The pieces of a running move still to load.
#[derive(Debug)]
pub(super) struct Roll {
    /// Every piece past the slots, with the steps that free its slot.
    loads: Vec<link::LateLoad>,
    /// The next of `loads`.
    next: usize,
    pieces: usize,
    /// The board's count, less the host's wrap offset, at the start.
    raw0: i64,
    dir: i64,
}

/// `ip` split to the widths of a board of `p`, however many pieces that takes, for a
/// load while it runs with `ahead` slots for its pieces (all, or all but a homing
/// search's stop ramp's): refused when a piece's load would come less than
/// [`ROLL_LEAD_S`] before the board needs it.
pub(super) fn rolling(
    ip: &IntProfile,
    dir: bool,
    p: &CoreParams,
    ahead: usize,
) -> Result<AxisMove, String> {
    let m = AxisMove::rolling(ip, dir, p).map_err(|e| e.to_string())?;
    let ahead = ahead.max(1);
    let ends: Vec<u64> = m.pieces.iter().map(|pc| pc.t0 + pc.dur).collect();
    for i in ahead..ends.len() {
        let lead = ends[i - 1].saturating_sub(ends[i - ahead]) as f64 / p.clock_hz;
        if lead < ROLL_LEAD_S {
            return Err(format!(
                "its {} pieces (split at the board's tick width) are more than the {ahead} \
                 slots it has, and loading them as the move runs leaves {lead:.3} s for \
                 piece {i} (at least {ROLL_LEAD_S} s)",
                m.pieces.len(),
            ));
        }
    }
    Ok(m)
}

impl Roll {
    /// The later loads of a move of `pieces` pieces (`link::rolling_writes`), `dir` its
    /// direction; `count` and `offset` the axis's at the start.
    pub(super) fn new(
        loads: Vec<link::LateLoad>,
        pieces: usize,
        dir: bool,
        count: i64,
        offset: i64,
    ) -> Roll {
        Roll {
            loads,
            next: 0,
            pieces,
            raw0: count - offset,
            dir: if dir { 1 } else { -1 },
        }
    }

    /// Every piece is loaded.
    pub(super) fn loaded(&self) -> bool {
        self.next >= self.loads.len()
    }

    /// Why a move ended with pieces still to load.
    pub(super) fn why(&self) -> String {
        let loaded = self.loads.get(self.next).map_or(self.pieces, |l| l.piece);
        format!(
            "late_pieces: the host loaded the move's pieces too late ({loaded} of {} \
             loaded), so the board ended it after the last one loaded, short of its target \
             (the count is exact)",
            self.pieces
        )
    }
}

impl FpgaBackend {
    /// Loads the pieces of `axis`'s running move whose slots its count (as last read)
    /// shows free.
    pub(super) fn feed_roll(&mut self, axis: usize) -> Result<(), LinkError> {
        let ax = &mut self.axes[axis];
        let raw = ax.count - ax.offset;
        let running = ax.running.as_mut().filter(|r| !r.stopping);
        let running_homing = running
            .as_ref()
            .is_some_and(|r| r.stop_on_sensor == Some(true));
        let Some(roll) = running.and_then(|r| r.roll.as_mut()) else {
            return Ok(());
        };
        let made = u64::try_from((raw - roll.raw0) * roll.dir).unwrap_or(0);
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        while let Some(load) = roll.loads.get(roll.next).filter(|l| made >= l.made) {
            for wr in &load.writes {
                match l.write(wr.reg, wr.data) {
                    // a Hall stop has diverted a homing search to its ramp since the
                    // state was read: the board takes no more pieces, nor needs them
                    Err(LinkError::Refused {
                        status: Status::Busy,
                        ..
                    }) if running_homing => {
                        roll.next = roll.loads.len();
                        return Ok(());
                    }
                    r => r?,
                }
            }
            roll.next += 1;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The iCEBreaker's core as far as splitting goes: 16 slots of 2^20 − 1 ticks and
    /// 2^14 − 1 steps at 18 MHz.
    fn icebreaker() -> CoreParams {
        let mut p = CoreParams::default();
        (p.pieces, p.tick_bits, p.step_bits) = (16, 20, 14);
        (p.clock_hz, p.max_rate, p.max_piece_s) = (18e6, 1e5, 0.04);
        p
    }

    fn segments(segs: &[(u64, u64, u64)]) -> IntProfile {
        let segs: Vec<IntSegment> = (segs.iter())
            .map(|&(v0, ticks, steps)| IntSegment { v0, ticks, steps })
            .collect();
        IntProfile::segments(&segs, IntClock::hz(18_000_000)).unwrap()
    }

    /// A load refused as busy (the board's answer once a Hall stop has diverted the axis
    /// to its ramp) ends a homing search's loads quietly, the ramp ending the move; any
    /// other move's is a link error.
    #[test]
    fn a_busy_refusal_ends_a_searchs_loads_and_fails_any_other_move() {
        use super::super::model::connect;
        let (mut b, m) = connect();
        let w = b.params.widths().unwrap();
        let commit = link::RegWrite {
            reg: Reg::Core(core_addr(&w, true, 0, 0)),
            data: 1,
        };
        let load = |piece| link::LateLoad {
            piece,
            made: 0,
            writes: vec![commit],
        };
        for (search, ok) in [(Some(true), true), (None, false)] {
            b.axes[0].running = Some(Running {
                dir: 1,
                stop_on_sensor: search,
                stopping: false,
                end_tick: 0,
                ramp_steps: 0,
                wraps: 0,
                roll: Some(Roll::new(vec![load(4), load(5)], 6, true, 0, 0)),
            });
            m.lock().unwrap().refuse_core = true;
            let r = b.feed_roll(0);
            assert_eq!(r.is_ok(), ok, "{search:?}: {r:?}");
            if !ok {
                assert!(
                    matches!(
                        r,
                        Err(LinkError::Refused {
                            status: Status::Busy,
                            ..
                        })
                    ),
                    "{r:?}"
                );
            }
            let roll = b.axes[0].running.as_ref().unwrap().roll.as_ref().unwrap();
            assert_eq!(roll.loaded(), ok, "{search:?}");
            assert_eq!(m.lock().unwrap().refused, 1, "one refusal, no retry");
            m.lock().unwrap().refused = 0;
        }
        // taken, both loads go
        m.lock().unwrap().refuse_core = false;
        let r = b.axes[0].running.as_mut().unwrap();
        r.roll = Some(Roll::new(vec![load(4), load(5)], 6, true, 0, 0));
        b.feed_roll(0).unwrap();
        let roll = b.axes[0].running.as_ref().unwrap().roll.as_ref().unwrap();
        assert!(roll.loaded());
    }

    #[test]
    fn pieces_of_58_ms_roll_and_pieces_of_10_ms_leave_too_little_lead() {
        let p = icebreaker();
        // a 0.05 s ramp to 2000 steps/s and a 2 s cruise: 36 pieces of up to 58 ms, 15 of
        // them 0.87 s
        let long = segments(&[(0, 900_000, 50), (2000, 36_000_000, 4000)]);
        assert!(AxisMove::from_profile(&long, true, &p).is_err());
        let m = rolling(&long, true, &p, 16).unwrap();
        assert_eq!(m.pieces.len(), 36);
        assert_eq!(m.steps(), 4050);
        // 40 segments of 10 ms: 15 of them are 0.15 s
        let short = segments(&[(2000, 180_000, 20); 40]);
        let e = rolling(&short, true, &p, 16).unwrap_err();
        assert!(e.contains("leaves 0.150 s for piece 16"), "{e}");
    }
}
