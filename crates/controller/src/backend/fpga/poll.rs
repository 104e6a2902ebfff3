//! Reading the board back each poll: its e-stop, session token, counts and states;
//! a reset or power cycle seen by the token; reconnecting a failed link.

use super::stream::Feed;
use super::*;

impl FpgaBackend {
    /// Reads what the host shows of the board: e-stop, session, counts, states.
    pub(super) fn read_board(&mut self) -> Result<(), LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let status = l.read(Reg::Board(BoardReg::Status))?;
        let busy = l.read(Reg::Board(BoardReg::Busy))?;
        self.estop_input = status & status_bits::ESTOP_INPUT != 0;
        // What this poll reads is believed once the session, read last, still holds: a
        // reset between two reads would show a moving axis come to rest.
        let told = self.events.len();
        let running = self
            .axes
            .iter()
            .enumerate()
            .filter(|(_, a)| a.running.is_some())
            .map(|(i, _)| 1u32 << i)
            .sum();
        if status & status_bits::ESTOP != 0 && !self.estopped {
            self.estopped = true;
            self.events.push_back((0, PinEvent::Estop));
        }
        for i in 0..self.axes.len() {
            let a = i as u32;
            let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
            let st = l.axis_state(a)?;
            let count = self.read_count(i)?;
            let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
            let ax = &mut self.axes[i];
            ax.sensor = st.hall;
            let Some(r) = ax.running.as_mut() else {
                if st.stream_armed {
                    // armed by a start that failed: the next start would replay nothing
                    l.write(Reg::Axis(a, AxisReg::StreamSteps), 0)?;
                }
                continue;
            };
            if st.hall_flag {
                let hp = readback::count(l.read(Reg::Axis(a, AxisReg::HallPosition))?, ax.offset);
                l.write(Reg::Board(BoardReg::Clear), 1 << a)?;
                let trigger = !r.stopping && r.stop_on_sensor == Some(true);
                r.stopping |= trigger;
                let edge = FilteredEdge {
                    tick: self.now,
                    active: true,
                    count_at_start: hp,
                    true_at_start: hp,
                };
                let target = match ax.feed.as_mut().filter(|f| trigger && f.lead_limited) {
                    // a fast streamed search: the host codes the stop ramp after the lead
                    // it had coded and cuts the stream's count to match
                    Some(f) => {
                        let amax = ax.settings.amax;
                        let total = f
                            .ramp_down(amax, self.params.clock_hz)
                            .map_err(LinkError::Move)?;
                        let n = u32::try_from(total).unwrap_or(u32::MAX);
                        l.write(Reg::Axis(a, AxisReg::StreamSteps), n)?;
                        f.count0 + r.dir * total as i64
                    }
                    None => hp + r.dir * r.ramp_steps as i64,
                };
                self.events.push_back((
                    i,
                    PinEvent::Sensor {
                        edge,
                        speed: ax.speed,
                        triggered: trigger.then_some(target),
                    },
                ));
            } else if !st.hall && !r.stopping && r.stop_on_sensor == Some(false) {
                // The board latches entering edges only: leaving is seen here, and the
                // axis halts at once (homing speed).
                l.write(Reg::Board(BoardReg::Stop), 1 << a)?;
                r.stopping = true;
                let count = readback::count(l.read(Reg::Axis(a, AxisReg::Position))?, ax.offset);
                ax.count = count;
                let edge = FilteredEdge {
                    tick: self.now,
                    active: false,
                    count_at_start: count,
                    true_at_start: count,
                };
                self.events.push_back((
                    i,
                    PinEvent::Sensor {
                        edge,
                        speed: ax.speed,
                        triggered: Some(count),
                    },
                ));
            }
            // A group waiting out its DIR setup has not started yet.
            let pending = status & status_bits::PENDING != 0;
            if pending || (busy >> a & 1 == 1 && st.busy) {
                let period = l.read(Reg::Axis(a, AxisReg::Period))?;
                ax.speed = if period > 0 {
                    self.params.clock_hz / period as f64
                } else {
                    0.0
                };
            } else {
                if st.stream_armed {
                    // armed but never started (a refused start): back to computed
                    l.write(Reg::Axis(a, AxisReg::StreamSteps), 0)?;
                }
                let ax = &mut self.axes[i];
                // a move loaded while it ran that ended with pieces still to load
                let short = (ax.running.take())
                    .filter(|r| !r.stopping)
                    .and_then(|r| r.roll)
                    .filter(|r| !r.loaded());
                ax.speed = 0.0;
                // with its motion: a stream is fed only while its axis runs (a StreamSteps
                // write to an idle axis arms its next start)
                let feed = ax.feed.take();
                // at rest: the board's counter takes the wrapped count
                self.fold_offset(i)?;
                self.events.push_back((i, PinEvent::End { end: self.now }));
                if let Some(f) = &feed {
                    stream_stats(i, f, count);
                }
                if st.underrun || st.stream_fault || feed.as_ref().is_some_and(|f| f.stopped) {
                    let why = late_reason(feed.as_ref(), st.stream_fault);
                    self.events.push_back((i, PinEvent::Late { why }));
                } else if let Some(r) = short {
                    self.events.push_back((i, PinEvent::Late { why: r.why() }));
                }
                continue;
            }
            self.feed_roll(i)?;
            let roll = self.axes[i].running.as_ref().and_then(|r| r.roll.as_ref());
            if roll.is_some_and(|r| r.loaded()) {
                // every piece is on the board: a restart from here lets the move end (the
                // session is kept only when it changes)
                self.keep_session_now();
            }
            let ax = &mut self.axes[i];
            if (st.underrun || st.stream_fault) && !ax.late_told {
                ax.late_told = true;
                eprintln!(
                    "warning: board {}: axis {i}: {}",
                    self.name,
                    late_reason(ax.feed.as_ref(), st.stream_fault)
                );
            }
            if ax.watch && ax.feed.is_some() {
                self.events.push_back((i, PinEvent::Step));
            }
        }
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        let session = l.read(Reg::Board(BoardReg::Session))?;
        if session != self.session {
            self.events.truncate(told);
            return self.session_changed(session, running);
        }
        if self.doubt != 0 {
            self.start_in_doubt();
        }
        Ok(())
    }

    /// The board was reset or lost power (its session register no longer holds this
    /// host's token): every axis lost its count, whatever the timing, and the board is
    /// claimed with a new token. `running`: the axes moving before the poll that saw it.
    /// The loss is told before the claim's first write: a link failure part way through
    /// the claim would otherwise leave the board holding this host's token, so that no
    /// later poll sees the reset, and the reset counts trusted.
    pub(super) fn session_changed(&mut self, session: u32, running: u32) -> Result<(), LinkError> {
        for i in 0..self.axes.len() {
            let ax = &mut self.axes[i];
            ax.feed = None;
            ax.offset = 0;
            ax.speed = 0.0;
            let moved = ax.running.take().is_some() || running >> i & 1 == 1;
            let why = format!(
                "the board was reset or lost power (its session register reads {session:#010x}, \
                 not this host's token); its count {} was lost{}; untrusted until homed",
                ax.count,
                if moved { " mid-move" } else { "" }
            );
            self.events.push_back((i, PinEvent::Lost { why }));
        }
        let token = link::session_token();
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        l.write(Reg::Board(BoardReg::Session), token)?;
        self.session = token;
        self.session_changes += 1;
        self.doubt = 0;
        self.estopped = false;
        // the board holds this host's token now, so no later poll sees the reset: until
        // the setup is through, it is done again (the next poll, or a start)
        self.reclaim = true;
        self.setup()?;
        for i in 0..self.axes.len() {
            self.read_count(i)?;
        }
        Ok(())
    }

    /// Logs the requests the link sent again since the last time.
    pub(super) fn tell_retransmits(&mut self) {
        if let Some(l) = self.link.as_mut().filter(|l| l.retransmitted > 0) {
            eprintln!(
                "note: board link {}: {} request(s) sent again (a reply damaged or late); \
                 each executed once",
                self.name, l.retransmitted
            );
            l.retransmitted = 0;
        }
    }

    /// The link failed at a start, so whether the board started it is unknown: its axes'
    /// counts cannot be trusted.
    pub(super) fn start_in_doubt(&mut self) {
        for (i, ax) in self.axes.iter_mut().enumerate() {
            if self.doubt >> i & 1 == 1 {
                ax.running = None;
                ax.feed = None;
                let why = "the link failed at its start, so the board may or may not have run \
                           the move; untrusted until homed"
                    .to_string();
                self.events.push_back((i, PinEvent::Lost { why }));
            }
        }
        self.doubt = 0;
    }

    pub(super) fn reconnect(&mut self) {
        if self.last_try.elapsed() < RECONNECT_PERIOD {
            return;
        }
        self.last_try = Instant::now();
        let port = match (self.open)() {
            Ok(p) => p,
            Err(e) => {
                self.down = Some(e);
                return;
            }
        };
        let mut l = HostLink::new(port);
        let id = match l.build_id() {
            Ok(id) => id,
            Err(e) => {
                self.down = Some(e.to_string());
                return;
            }
        };
        if CoreParams::from(&id) != self.params {
            self.down = Some("another board answers on this link".into());
            return;
        }
        self.link = Some(l.with_urgent(self.urgent.clone()));
        eprintln!("board link {}: answering again", self.name);
        self.down = None;
    }
}

/// Why an axis's motion was late: the board's underrun flag (an edge came late, none
/// early) or a bad code in its replay unit.
/// Each starts with its fault word (docs/PROTOCOL.md).
pub(super) fn late_reason(feed: Option<&Feed>, bad_code: bool) -> String {
    match (feed, bad_code) {
        (_, true) => {
            "bad_code: the board's replay unit met a bad code and stopped the stream".into()
        }
        (
            Some(Feed {
                lost: Some(why), ..
            }),
            _,
        ) => format!(
            "link_fault: {why}; the axis was stopped short of its target (the count is exact)"
        ),
        (Some(f), _) if f.resent > 0 => "link_fault: a bulk write of the stream was damaged \
             or lost on the link and sent again, so some edges came late (none early; the \
             count is exact)"
            .into(),
        (Some(_), _) => "stream_starved: the link fell behind the streamed move, so some \
                         edges came late (none early; the count is exact)"
            .into(),
        (None, _) => "calculator_late: the board's calculator fell behind, so some edges came \
                      late (none early; the count is exact)"
            .into(),
    }
}

/// With `MULTISTEP_LINK_STATS` set: one line per streamed motion on stderr (steps, link
/// bytes per step, the least code left in the buffer when the host came to top it up).
pub(super) fn stream_stats(axis: usize, f: &Feed, count: i64) {
    if std::env::var_os("MULTISTEP_LINK_STATS").is_none() {
        return;
    }
    let steps = f.coded().max(1);
    let framed = f.sent + link::BULK_OVERHEAD as u64 * f.frames;
    let what = if f.is_fixed() { "chain record" } else { "code" };
    eprintln!(
        "link stats: axis {axis}: {} steps ({} counted), {} {what} bytes in {} frames: \
         {:.3} {what} bytes/step, {:.3} with frames; buffer {} bytes, least left {} bytes",
        f.coded(),
        (count - f.count0).abs(),
        f.sent,
        f.frames,
        f.sent as f64 / steps as f64,
        framed as f64 / steps as f64,
        f.buffer,
        f.min_left()
    );
}
