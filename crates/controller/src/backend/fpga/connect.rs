//! Opening the link to a board and readying it: the constructors, the probe of its replay
//! and chain units, the board's setup after every (re)connection, and a link error's
//! turn into the controller's.

use super::*;

impl FpgaBackend {
    /// Connects to the board on `spec` and checks it has at least `axes` axes.
    pub fn connect(spec: &LinkSpec, axes: usize) -> Result<FpgaBackend, CtlError> {
        FpgaBackend::with_opener(spec.to_string(), serial_opener(spec), axes)
    }

    /// [`FpgaBackend::connect`] by a host that kept `before` (see session.rs): the board
    /// still holding its token is adopted as it runs.
    pub fn connect_resuming(
        spec: &LinkSpec,
        axes: usize,
        before: Option<LinkSession>,
    ) -> Result<FpgaBackend, CtlError> {
        FpgaBackend::with_opener_resuming(spec.to_string(), serial_opener(spec), axes, before)
    }

    /// [`FpgaBackend::connect`] over any stream `open` gives.
    pub fn with_opener(name: String, open: Opener, axes: usize) -> Result<FpgaBackend, CtlError> {
        FpgaBackend::with_opener_resuming(name, open, axes, None)
    }

    /// [`FpgaBackend::with_opener`] with the session kept before (see session.rs).
    pub fn with_opener_resuming(
        name: String,
        mut open: Opener,
        axes: usize,
        before: Option<LinkSession>,
    ) -> Result<FpgaBackend, CtlError> {
        let port = open().map_err(CtlError::Link)?;
        let mut l = HostLink::new(port);
        let id = l.build_id().map_err(link_err)?;
        let params = CoreParams::from(&id);
        if (id.axes as usize) < axes {
            return Err(CtlError::Setting(format!(
                "the board on {name} has {} axes, the config {axes}",
                id.axes
            )));
        }
        let session = match before {
            Some(_) => 0,
            None => {
                let t = link::session_token();
                l.claim(t).map_err(link_err)?;
                t
            }
        };
        let mut b = FpgaBackend {
            name,
            open,
            link: Some(l),
            down: None,
            last_try: Instant::now(),
            params,
            session,
            doubt: 0,
            axes: (0..axes)
                .map(|_| FpgaAxis {
                    count: 0,
                    offset: 0,
                    sensor: false,
                    speed: 0.0,
                    running: None,
                    settings: AxisSettings::default(),
                    feed: None,
                    late_told: false,
                    watch: false,
                })
                .collect(),
            events: VecDeque::new(),
            now: 0,
            estopped: false,
            estop_input: false,
            hall_stop: 0,
            enabled: ((1u64 << axes) - 1) as u32,
            last_poll: None,
            read_at: None,
            polled: false,
            streams: false,
            buffer: 0,
            chains: 0,
            arming: false,
            keep: None,
            kept: None,
            writing: false,
            adopted: false,
            armed: 0,
            armed_at: None,
            arm_lifetime: ARM_LIFETIME,
            setup_due: false,
            reclaim: false,
            urgent: None,
            fold_due: 0,
            folding: None,
            ticks: ticks::TickReader::new(),
            session_changes: 0,
        };
        if let Some(before) = &before {
            b.resume(before).map_err(link_err)?;
        }
        b.buffer = b.probe_streams().map_err(link_err)?;
        b.streams = b.buffer > 0;
        b.chains = b.probe_chains().map_err(link_err)?;
        if b.adopted {
            b.setup_due = true;
        } else {
            b.setup().map_err(link_err)?;
            // a group armed before this host connected belongs to no group of its own
            b.disarm("it was armed before this host connected")
                .map_err(link_err)?;
        }
        b.read_board().map_err(link_err)?;
        b.read_at = Some(Instant::now());
        Ok(b)
    }

    pub(super) fn mask(&self) -> u32 {
        ((1u64 << self.axes.len()) - 1) as u32
    }

    /// The size of the board's stream buffers (0: no replay units): an idle axis's free
    /// stream count once arming (a `StreamSteps` write; 0 leaves the axis computed)
    /// emptied it; with every axis busy, the most any has free.
    pub(super) fn probe_streams(&mut self) -> Result<u32, LinkError> {
        let axes = self.axes.len() as u32;
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        for a in 0..axes {
            if !l.axis_state(a)?.busy {
                l.write(Reg::Axis(a, AxisReg::StreamSteps), 0)?;
                return l.read(Reg::Axis(a, AxisReg::StreamFree));
            }
        }
        let mut most = 0;
        for a in 0..axes {
            most = most.max(l.read(Reg::Axis(a, AxisReg::StreamFree))?);
        }
        Ok(most)
    }

    /// The board's chain record size (`BoardReg::Chains`), or 0: a board without chain
    /// units refuses the read.
    pub(super) fn probe_chains(&mut self) -> Result<u32, LinkError> {
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        match l.read(Reg::Board(BoardReg::Chains)) {
            Err(LinkError::Refused {
                status: Status::BadAddress,
                ..
            }) => Ok(0),
            r => r,
        }
    }

    /// Sends every streaming axis the code its buffer has room for.
    pub(super) fn feed_streams(&mut self) -> Result<(), LinkError> {
        for i in 0..self.axes.len() {
            let ax = &mut self.axes[i];
            // only while the axis runs: a StreamSteps write to an idle axis arms it
            let (Some(f), Some(l), Some(_)) =
                (ax.feed.as_mut(), self.link.as_mut(), ax.running.as_ref())
            else {
                continue;
            };
            if f.lost.is_some() {
                // what the board holds of the code is unknown: the axis stops, its count
                // exact; read_board reports it
                if !f.stopped {
                    l.write(Reg::Board(BoardReg::Stop), 1 << i)?;
                    f.stopped = true;
                }
                continue;
            }
            let done = (ax.count - f.count0).unsigned_abs();
            if let Err(e) = pump(l, f, i as u32, done, true) {
                if matches!(e, LinkError::Io(_)) || e.in_doubt() {
                    return Err(e);
                }
                // this axis's stream alone failed (a step its replay unit cannot time, a
                // refused write): the axis halts, its count exact, and the board is read on
                eprintln!(
                    "warning: board link {}: axis {i}: {e}; the axis is halted",
                    self.name
                );
                l.write(Reg::Board(BoardReg::Stop), 1 << i)?;
                ax.feed = None;
                let why = format!(
                    "bad_code: the host cannot code the axis's next step for the board's \
                     replay unit ({e}); the axis was halted there (the count is exact)"
                );
                self.events.push_back((i, PinEvent::Late { why }));
            }
        }
        Ok(())
    }

    /// The board's registers as the host wants them (after start-up and every reset):
    /// debounce, no Hall stops, each axis's DIR and ENABLE levels, ENABLE on.
    pub(super) fn setup(&mut self) -> Result<(), LinkError> {
        let clock = self.params.clock_hz;
        let want = self
            .axes
            .iter()
            .map(|a| (a.settings.debounce * clock).ceil())
            .fold(0.0, f64::max);
        // the register holds a period's bits: a longer filter time would wrap
        let most = ((1u64 << self.params.tick_bits.min(32)) - 1) as f64;
        if want > most {
            eprintln!(
                "warning: board link {}: a debounce of {} s is longer than the board's \
                 filter holds; it filters {} s",
                self.name,
                want / clock,
                most / clock
            );
        }
        let debounce = want.min(most) as u32;
        let mask = self.mask();
        let enabled = self.enabled;
        let axes_where = |f: fn(&AxisSettings) -> bool| -> u32 {
            self.axes
                .iter()
                .enumerate()
                .filter(|(_, a)| f(&a.settings))
                .map(|(i, _)| 1u32 << i)
                .sum()
        };
        let dir_invert = axes_where(|s| s.invert_dir);
        let enable_low = axes_where(|s| !s.enable_active_high);
        let l = self.link.as_mut().ok_or(LinkError::Io("no link".into()))?;
        l.write(Reg::Board(BoardReg::Debounce), debounce)?;
        l.write(Reg::Board(BoardReg::HallStop), 0)?;
        // the levels before ENABLE: an active-low driver is never energized by the switch
        l.write(Reg::Board(BoardReg::DirInvert), dir_invert)?;
        l.write(Reg::Board(BoardReg::EnableLow), enable_low)?;
        l.write(Reg::Board(BoardReg::Enable), mask & enabled)?;
        self.hall_stop = 0;
        // every register this host sets is set: a reset board is claimed in full
        self.reclaim = false;
        Ok(())
    }

    /// A reset board's claim that the link cut short is finished before a start: a move
    /// must not run on registers at their power-up values (every driver off).
    pub(super) fn finish_claim(&mut self) -> Result<(), CtlError> {
        if self.reclaim {
            if let Err(e) = self.setup() {
                return Err(self.failed(e));
            }
        }
        Ok(())
    }

    pub(super) fn link(&mut self) -> Result<&mut HostLink<Box<dyn Port>>, CtlError> {
        match (&mut self.link, &self.down) {
            (Some(l), _) => Ok(l),
            (None, why) => Err(CtlError::Link(format!(
                "board link {} is down: {}",
                self.name,
                why.as_deref().unwrap_or("not connected")
            ))),
        }
    }

    /// An error of the link: an I/O failure, or a reply still lost or damaged after the
    /// link's retransmissions, takes the link down (retried later).
    pub(super) fn failed(&mut self, e: LinkError) -> CtlError {
        if matches!(e, LinkError::Io(_)) || e.in_doubt() {
            if self.down.is_none() {
                eprintln!(
                    "warning: board link {}: {e}; its axes are faulted",
                    self.name
                );
            }
            self.link = None;
            self.down = Some(e.to_string());
            self.last_try = Instant::now();
        } else {
            eprintln!("warning: board link {}: {e}", self.name);
        }
        link_err(e)
    }
}

#[cfg(test)]
mod tests {
    use super::super::model::connect;
    use super::AxisSettings;
    use crate::backend::BoardBackend;

    #[test]
    fn a_debounce_longer_than_the_register_holds_is_clamped_not_wrapped() {
        let (mut b, m) = connect();
        let clock = b.params.clock_hz;
        let most = (1u64 << b.params.tick_bits) - 1;
        let mut s = AxisSettings {
            debounce: 0.002,
            ..AxisSettings::default()
        };
        b.configure(0, &s);
        assert_eq!(
            f64::from(m.lock().unwrap().debounce),
            (0.002 * clock).ceil()
        );
        // the largest of the axes' filter times; 1001 ticks more than the register holds
        // would wrap to 1000 ticks
        s.debounce = (most + 1001) as f64 / clock;
        b.configure(1, &s);
        assert_eq!(u64::from(m.lock().unwrap().debounce), most);
    }
}
