//! Halts asked for without the board's lock: `estop` and `stop` are queued here and
//! applied by whichever thread holds the board next, so neither waits for a link exchange.

use super::*;

/// A halt asked for: `estop`, or `stop` of one axis (`Some`) or all.
pub(super) enum HaltKind {
    EStop,
    Stop(Option<String>),
}

/// Halts asked for and not yet applied. Asking takes no board lock: whoever holds the
/// board next (a command, the ticker, the asker itself) applies them before anything else,
/// at the tick they were asked at, so an e-stop never queues behind other work.
pub(super) struct Halts {
    /// Something is queued: checked on every board lock without taking `queue`, and by
    /// the FPGA backend between link frames (shared with the board).
    pub(super) pending: Arc<AtomicBool>,
    /// E-stopped axes wait to be written down.
    unrecorded: AtomicBool,
    /// The earliest tick of the halts queued (`u64::MAX`: none), shared with the board.
    pub(super) tick: Arc<AtomicU64>,
    queue: Mutex<HaltQueue>,
    pub(super) applied: Condvar,
    /// When the last e-stop was applied to the board (its write, on the FPGA board).
    pub(super) estop_applied: Mutex<Option<Instant>>,
}

#[derive(Default)]
pub(super) struct HaltQueue {
    next_ticket: u64,
    asked: Vec<(u64, HaltKind, u64)>,
    /// Outcomes by ticket, until their askers take them.
    pub(super) done: HashMap<u64, Result<(), CtlError>>,
    unrecorded: Vec<Halted>,
}

impl Default for Halts {
    fn default() -> Self {
        Halts {
            pending: Arc::new(AtomicBool::new(false)),
            unrecorded: AtomicBool::new(false),
            tick: Arc::new(AtomicU64::new(u64::MAX)),
            queue: Mutex::default(),
            applied: Condvar::new(),
            estop_applied: Mutex::default(),
        }
    }
}

impl Halts {
    pub(super) fn queue(&self) -> MutexGuard<'_, HaltQueue> {
        self.queue.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Queues a halt asked for at tick `at`; returns its ticket.
    pub(super) fn ask(&self, kind: HaltKind, at: u64) -> u64 {
        let mut q = self.queue();
        let ticket = q.next_ticket;
        q.next_ticket += 1;
        q.asked.push((ticket, kind, at));
        self.tick.fetch_min(at, Ordering::SeqCst);
        self.pending.store(true, Ordering::SeqCst);
        ticket
    }

    /// Applies every queued halt to the board, in the order asked.
    pub(super) fn apply(&self, b: &mut Board) {
        // A load first: the common case writes nothing shared.
        if !self.pending.load(Ordering::SeqCst) || !self.pending.swap(false, Ordering::SeqCst) {
            return;
        }
        let asked = {
            let mut q = self.queue();
            self.tick.store(u64::MAX, Ordering::SeqCst);
            std::mem::take(&mut q.asked)
        };
        let mut done = Vec::with_capacity(asked.len());
        let mut halted = Vec::new();
        for (ticket, kind, at) in asked {
            let r = match kind {
                HaltKind::EStop => {
                    halted.push(b.estop_latch(at));
                    *self.estop_applied.lock().unwrap_or_else(|p| p.into_inner()) =
                        Some(Instant::now());
                    Ok(())
                }
                HaltKind::Stop(axis) => b.stop(axis.as_deref(), at),
            };
            done.push((ticket, r));
        }
        let mut q = self.queue();
        q.done.extend(done);
        if !halted.is_empty() {
            q.unrecorded.extend(halted);
            self.unrecorded.store(true, Ordering::SeqCst);
        }
        self.applied.notify_all();
    }

    /// Writes down the axes e-stops halted: disk writes, left to the next holder of the
    /// board (the ticker's within a millisecond) so that no asker waits for them.
    pub(super) fn record(&self, b: &mut Board) {
        if self.unrecorded.load(Ordering::SeqCst) && self.unrecorded.swap(false, Ordering::SeqCst) {
            let halted = std::mem::take(&mut self.queue().unrecorded);
            for h in halted {
                b.record_halted(h);
            }
        }
    }
}
