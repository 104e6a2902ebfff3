//! The board's crystal against host time: its free-running count (`Ticks`, 0x1A) read
//! with host time stamped before and after (`crate::clock_rate` fits them). The 32-bit
//! count wraps every 2^32 clocks (86 s at 50 MHz); readings a second apart are unwrapped
//! by the host time between them, so a gap of any length (a link down for minutes) keeps
//! the count whole. A board that lost its state (its session changed) may have restarted
//! its count: the fit starts again.

use super::FpgaBackend;
use crate::clock_rate::Reading;
use multistep_link::{BoardReg, LinkError, Reg, Status};
use std::time::Instant;

/// Host time in ns from some zero (a test gives its own clock).
pub(super) type HostClock = Box<dyn Fn() -> u64 + Send>;

/// What the host keeps of the board's count between readings.
pub(super) struct TickReader {
    /// Host time of the readings.
    clock: HostClock,
    /// The last reading: the register's value, its unwrapped count, its host time (ns).
    last: Option<(u32, u64, u64)>,
    /// The board's session changes seen at the last reading.
    sessions: u64,
    /// The board has no `Ticks` register (a build before it): nothing is read.
    absent: bool,
}

impl TickReader {
    pub(super) fn new() -> TickReader {
        let base = Instant::now();
        TickReader {
            clock: Box::new(move || base.elapsed().as_nanos() as u64),
            last: None,
            sessions: 0,
            absent: false,
        }
    }

    fn host_ns(&self) -> u64 {
        (self.clock)()
    }

    /// `raw` read at host time `at_ns` as a count that never wraps, on a board of
    /// `clock_hz`: the wraps since the last reading are the ones the host time between
    /// them says (the crystal's error is far below half a wrap).
    pub(super) fn unwrap(&mut self, raw: u32, at_ns: u64, clock_hz: f64) -> u64 {
        let count = match self.last {
            None => u64::from(raw),
            Some((r0, c0, t0)) => {
                let expected = (at_ns - t0) as f64 * clock_hz / 1e9;
                let short = u64::from(raw.wrapping_sub(r0));
                let wraps = ((expected - short as f64) / 4_294_967_296.0)
                    .round()
                    .max(0.0);
                c0 + short + (wraps as u64) * (1 << 32)
            }
        };
        self.last = Some((raw, count, at_ns));
        count
    }
}

impl FpgaBackend {
    /// Reads `Ticks` stamped with host time; `true` with it when the board's count may
    /// have restarted since the last reading. `None`: a board without the register (said
    /// once), or the link failed.
    pub(super) fn read_ticks(&mut self) -> Option<(Reading, bool)> {
        if self.ticks.absent {
            return None;
        }
        let sent_ns = self.ticks.host_ns();
        let l = self.link().ok()?;
        let raw = match l.read(Reg::Board(BoardReg::Ticks)) {
            Ok(raw) => raw,
            Err(LinkError::Refused {
                status: Status::BadAddress,
                ..
            }) => {
                eprintln!(
                    "note: board {}: no Ticks register (a build before it): its tracking \
                     follows its crystal, not host time",
                    self.name
                );
                self.ticks.absent = true;
                return None;
            }
            Err(e) => {
                self.failed(e);
                return None;
            }
        };
        let recv_ns = self.ticks.host_ns();
        let restarted = self.ticks.sessions != self.session_changes;
        if restarted {
            self.ticks.sessions = self.session_changes;
            self.ticks.last = None;
        }
        let tick = self.ticks.unwrap(raw, recv_ns, self.params.clock_hz);
        Some((
            Reading {
                sent_ns,
                recv_ns,
                tick,
            },
            restarted,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::super::model::connect;
    use super::*;
    use crate::backend::BoardBackend;
    use crate::clock_rate::ClockEstimator;

    /// Readings every 30 s of host time on a 50 MHz board 40 ppm fast: the count wraps
    /// between some of them (every 86 s) and once two readings are 10 minutes apart; the
    /// unwrapped counts are the board's ticks exactly.
    #[test]
    fn counts_are_unwrapped_by_the_host_time_between_readings() {
        let mut t = TickReader::new();
        let hz = 50e6;
        let ticks = |ns: u64| (ns as f64 * hz * (1.0 + 40e-6) / 1e9) as u64 + 12_345;
        let mut at = 0u64;
        for k in 0..40 {
            at += if k == 20 {
                600_000_000_000
            } else {
                30_000_000_000
            };
            let want = ticks(at);
            assert_eq!(t.unwrap(want as u32, at, hz), want, "reading {k}");
        }
    }

    /// Through the link, a reading a second of host time for 100 s, the register
    /// model's count running 25 ppm fast against that time: the readings fit the crystal
    /// within 0.01 ppm; a power cycle (the session lost) starts the count again.
    #[test]
    fn the_board_count_read_through_the_link_fits_its_crystal() {
        use std::sync::atomic::{AtomicU64, Ordering};
        use std::sync::Arc;
        let (mut b, m) = connect();
        let host = Arc::new(AtomicU64::new(0));
        let h = host.clone();
        b.ticks.clock = Box::new(move || h.load(Ordering::SeqCst));
        let mut est = ClockEstimator::new(50e6);
        let mut fit = None;
        for k in 0..100u64 {
            let ns = k * 1_000_000_000;
            host.store(ns, Ordering::SeqCst);
            m.lock().unwrap().ticks = (ns as f64 * 50e6 * (1.0 + 25e-6) / 1e9) as u64 as u32;
            let (r, restarted) = b.tick_reading().expect("the model has Ticks");
            assert!(!restarted, "reading {k}");
            fit = est.add(r).unwrap();
        }
        let fit = fit.expect("a fit over 99 s");
        assert!((fit.ppm - 25.0).abs() < 0.01, "{fit:?}");
        m.lock().unwrap().power_cycle();
        b.begin_advance();
        while b.poll(1).is_some() {}
        let (_, restarted) = b.tick_reading().unwrap();
        assert!(
            restarted,
            "a board that lost its state may have restarted its count"
        );
    }
}
