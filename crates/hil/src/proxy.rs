//! A faulty link for tests: a pseudo-terminal a host opens in place of the board's,
//! joined to the board's by a thread that flips, drops, duplicates and delays bytes in
//! both directions at a given rate, drawn from a seeded generator, counting each fault.
//! The same seed and the same byte streams give the same faults.

use crate::pty::Pty;
use crate::HilError;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::collections::VecDeque;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Which way a byte goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Way {
    ToBoard = 0,
    ToHost = 1,
}

/// What was done to a byte.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    /// One bit flipped.
    Flip = 0,
    /// Lost.
    Drop = 1,
    /// Sent twice.
    Duplicate = 2,
    /// Held, with every byte after it that way, for a while.
    Delay = 3,
}

impl FaultKind {
    pub const ALL: [FaultKind; 4] = [
        FaultKind::Flip,
        FaultKind::Drop,
        FaultKind::Duplicate,
        FaultKind::Delay,
    ];

    pub fn name(self) -> &'static str {
        match self {
            FaultKind::Flip => "flip",
            FaultKind::Drop => "drop",
            FaultKind::Duplicate => "duplicate",
            FaultKind::Delay => "delay",
        }
    }
}

/// One injected fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FaultEvent {
    /// Since the proxy started.
    pub at: Duration,
    pub way: Way,
    pub kind: FaultKind,
    /// The byte's index in its direction's stream (from 0).
    pub index: u64,
    pub byte: u8,
}

/// Faults so far, `[kind][way]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FaultCounts(pub [[u64; 2]; 4]);

impl FaultCounts {
    pub fn of(&self, kind: FaultKind) -> u64 {
        self.0[kind as usize].iter().sum()
    }
    pub fn total(&self) -> u64 {
        FaultKind::ALL.iter().map(|&k| self.of(k)).sum()
    }
}

/// How the proxy damages bytes.
#[derive(Clone, Debug)]
pub struct ProxyOptions {
    /// Probability that a byte is damaged (0 ..= 1); [`LinkProxy::set_rate`] changes it.
    pub rate: f64,
    /// Relative weights of flip, drop, duplicate and delay.
    pub weights: [u32; 4],
    /// A delay holds the direction for up to this long.
    pub max_delay: Duration,
    pub seed: u64,
}

impl Default for ProxyOptions {
    fn default() -> Self {
        ProxyOptions {
            rate: 0.0,
            weights: [1, 1, 1, 1],
            max_delay: Duration::from_millis(20),
            seed: 1,
        }
    }
}

/// Faults kept for [`LinkProxy::log`].
const LOG_LEN: usize = 256;

struct Shared {
    stop: AtomicBool,
    rate: AtomicU64,
    counts: Mutex<FaultCounts>,
    log: Mutex<VecDeque<FaultEvent>>,
    bytes: [AtomicU64; 2],
}

/// A running proxy; dropping it stops it.
pub struct LinkProxy {
    /// The pseudo-terminal the host opens.
    pub path: String,
    shared: Arc<Shared>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl LinkProxy {
    /// Joins a new pseudo-terminal to the board's at `board_pty`.
    pub fn start(board_pty: &str, opts: ProxyOptions) -> Result<LinkProxy, HilError> {
        let bad = |what: &str| HilError::Setting(format!("proxy: {what}"));
        if !(0.0..=1.0).contains(&opts.rate) {
            return Err(bad("the rate is a probability (0 ..= 1)"));
        }
        if opts.weights.iter().all(|&w| w == 0) {
            return Err(bad("every fault weight is 0"));
        }
        let io = |what: &str, source| HilError::Io {
            what: format!("proxy: {what}"),
            source,
        };
        let host = Pty::open().map_err(|e| io("open a pty", e))?;
        let board = open_tty(board_pty).map_err(|e| io(board_pty, e))?;
        let shared = Arc::new(Shared {
            stop: AtomicBool::new(false),
            rate: AtomicU64::new(opts.rate.to_bits()),
            counts: Mutex::new(FaultCounts::default()),
            log: Mutex::new(VecDeque::new()),
            bytes: [AtomicU64::new(0), AtomicU64::new(0)],
        });
        let path = host.path.clone();
        let sh = shared.clone();
        let thread = std::thread::Builder::new()
            .name("link-proxy".into())
            .spawn(move || Forwarder::new(host, board, opts, sh).run())
            .map_err(|e| io("thread", e))?;
        Ok(LinkProxy {
            path,
            shared,
            thread: Some(thread),
        })
    }

    /// Changes the probability that a byte is damaged (0: a clean link).
    pub fn set_rate(&self, rate: f64) {
        let r = if rate.is_finite() {
            rate.clamp(0.0, 1.0)
        } else {
            0.0
        };
        self.shared.rate.store(r.to_bits(), Ordering::Relaxed);
    }

    pub fn counts(&self) -> FaultCounts {
        *lock(&self.shared.counts)
    }

    /// The latest faults (up to 256), oldest first.
    pub fn log(&self) -> Vec<FaultEvent> {
        lock(&self.shared.log).iter().copied().collect()
    }

    /// Bytes forwarded so far, `[to board, to host]` (before faults).
    pub fn bytes(&self) -> [u64; 2] {
        [0, 1].map(|w| self.shared.bytes[w].load(Ordering::Relaxed))
    }
}

impl Drop for LinkProxy {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Opens a terminal device for non-blocking reads and writes.
fn open_tty(path: &str) -> std::io::Result<OwnedFd> {
    let c = std::ffi::CString::new(path)
        .map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, "NUL in the path"))?;
    // SAFETY: a NUL-terminated path; the descriptor is owned from here on.
    let fd = unsafe {
        libc::open(
            c.as_ptr(),
            libc::O_RDWR | libc::O_NOCTTY | libc::O_NONBLOCK | libc::O_CLOEXEC,
        )
    };
    if fd < 0 {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: fd was just opened and is not owned elsewhere.
    Ok(unsafe { OwnedFd::from_raw_fd(fd) })
}

/// Reads what is there (never blocks).
fn read_fd(fd: i32, out: &mut Vec<u8>) {
    let mut buf = [0u8; 512];
    loop {
        // SAFETY: reads into a buffer of the given length.
        let n = unsafe { libc::read(fd, buf.as_mut_ptr().cast(), buf.len()) };
        if n <= 0 {
            return;
        }
        out.extend_from_slice(&buf[..n as usize]);
    }
}

/// Writes what the terminal takes now; returns how many bytes.
fn write_fd(fd: i32, bytes: &[u8]) -> usize {
    // SAFETY: writes from a buffer of the given length.
    let n = unsafe { libc::write(fd, bytes.as_ptr().cast(), bytes.len()) };
    n.max(0) as usize
}

/// One direction's bytes on their way: each with the instant it may go.
#[derive(Default)]
struct Lane {
    queue: VecDeque<(Instant, u8)>,
    /// A delay holds every byte until then.
    held_until: Option<Instant>,
    index: u64,
}

struct Forwarder {
    host: Pty,
    board: OwnedFd,
    opts: ProxyOptions,
    shared: Arc<Shared>,
    rng: StdRng,
    lanes: [Lane; 2],
    t0: Instant,
}

impl Forwarder {
    fn new(host: Pty, board: OwnedFd, opts: ProxyOptions, shared: Arc<Shared>) -> Forwarder {
        Forwarder {
            host,
            board,
            rng: StdRng::seed_from_u64(opts.seed),
            opts,
            shared,
            lanes: Default::default(),
            t0: Instant::now(),
        }
    }

    fn run(mut self) {
        let mut buf = Vec::new();
        while !self.shared.stop.load(Ordering::Relaxed) {
            self.wait();
            for way in [Way::ToBoard, Way::ToHost] {
                buf.clear();
                read_fd(self.source(way), &mut buf);
                for &b in &buf {
                    self.take(way, b);
                }
                self.flush(way);
            }
        }
    }

    fn source(&self, way: Way) -> i32 {
        match way {
            Way::ToBoard => self.host.as_raw_fd(),
            Way::ToHost => self.board.as_raw_fd(),
        }
    }

    /// Waits for bytes either way, or until a held byte may go (1 ms at most, so a
    /// stop is seen).
    fn wait(&self) {
        let now = Instant::now();
        let mut ms = 1;
        for lane in &self.lanes {
            if let Some(&(t, _)) = lane.queue.front() {
                ms = ms.min(t.saturating_duration_since(now).as_millis() as i32);
            }
        }
        let mut fds = [self.host.as_raw_fd(), self.board.as_raw_fd()].map(|fd| libc::pollfd {
            fd,
            events: libc::POLLIN,
            revents: 0,
        });
        // SAFETY: two valid pollfds.
        let n = unsafe { libc::poll(fds.as_mut_ptr(), 2, ms) };
        // A hung-up side polls readable at once: rest instead of spinning.
        if n > 0
            && fds
                .iter()
                .any(|p| p.revents & (libc::POLLHUP | libc::POLLERR) != 0)
        {
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    /// A byte from one side: damaged or not, queued for the other.
    fn take(&mut self, way: Way, mut b: u8) {
        let now = Instant::now();
        let w = way as usize;
        self.shared.bytes[w].fetch_add(1, Ordering::Relaxed);
        let rate = f64::from_bits(self.shared.rate.load(Ordering::Relaxed));
        let index = self.lanes[w].index;
        self.lanes[w].index += 1;
        let mut copies = 1;
        if rate > 0.0 && self.rng.gen_bool(rate) {
            let kind = self.pick();
            match kind {
                FaultKind::Flip => b ^= 1 << self.rng.gen_range(0..8),
                FaultKind::Drop => copies = 0,
                FaultKind::Duplicate => copies = 2,
                FaultKind::Delay => {
                    let max = self.opts.max_delay.as_micros().max(1) as u64;
                    let until = now + Duration::from_micros(self.rng.gen_range(0..=max));
                    let lane = &mut self.lanes[w];
                    lane.held_until = Some(lane.held_until.map_or(until, |h| h.max(until)));
                }
            }
            lock(&self.shared.counts).0[kind as usize][w] += 1;
            let mut log = lock(&self.shared.log);
            if log.len() == LOG_LEN {
                log.pop_front();
            }
            log.push_back(FaultEvent {
                at: now - self.t0,
                way,
                kind,
                index,
                byte: b,
            });
        }
        let lane = &mut self.lanes[w];
        let at = lane.held_until.map_or(now, |h| h.max(now));
        for _ in 0..copies {
            lane.queue.push_back((at, b));
        }
    }

    fn pick(&mut self) -> FaultKind {
        let total: u32 = self.opts.weights.iter().sum();
        let mut x = self.rng.gen_range(0..total);
        for (k, &wt) in FaultKind::ALL.iter().zip(&self.opts.weights) {
            if x < wt {
                return *k;
            }
            x -= wt;
        }
        FaultKind::Flip
    }

    /// Sends the bytes whose time has come, as far as the other side takes them.
    fn flush(&mut self, way: Way) {
        let fd = match way {
            Way::ToBoard => self.board.as_raw_fd(),
            Way::ToHost => self.host.as_raw_fd(),
        };
        let now = Instant::now();
        let lane = &mut self.lanes[way as usize];
        let ready: Vec<u8> = lane
            .queue
            .iter()
            .take_while(|(t, _)| *t <= now)
            .map(|&(_, b)| b)
            .collect();
        if ready.is_empty() {
            return;
        }
        let n = write_fd(fd, &ready);
        lane.queue.drain(..n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sends `bytes` from the host's side and collects what reaches the board's pty
    /// until `want` bytes came or a generous deadline passed.
    fn through(opts: ProxyOptions, bytes: &[u8], want: usize) -> (Vec<u8>, FaultCounts) {
        let board = Pty::open().unwrap();
        let proxy = LinkProxy::start(&board.path, opts).unwrap();
        let host = open_tty(&proxy.path).unwrap();
        let mut sent = 0;
        while sent < bytes.len() {
            sent += write_fd(host.as_raw_fd(), &bytes[sent..]);
        }
        let mut got = Vec::new();
        let t0 = Instant::now();
        while got.len() < want && t0.elapsed() < Duration::from_secs(10) {
            board.wait_readable(10);
            board.read_available(&mut got);
        }
        while proxy.bytes()[0] < bytes.len() as u64 && t0.elapsed() < Duration::from_secs(10) {
            std::thread::sleep(Duration::from_millis(1));
        }
        (got, proxy.counts())
    }

    #[test]
    fn a_clean_proxy_passes_every_byte_in_order() {
        let bytes: Vec<u8> = (0..=255).cycle().take(2000).collect();
        let (got, counts) = through(ProxyOptions::default(), &bytes, bytes.len());
        assert_eq!(got, bytes);
        assert_eq!(counts.total(), 0);
    }

    #[test]
    fn faults_are_counted_by_kind_and_do_what_they_say() {
        let bytes = vec![0x55u8; 500];
        let only = |k: usize| {
            let mut weights = [0; 4];
            weights[k] = 1;
            ProxyOptions {
                rate: 1.0,
                weights,
                max_delay: Duration::from_millis(1),
                seed: 3,
            }
        };
        let (got, c) = through(only(FaultKind::Duplicate as usize), &bytes, 1000);
        assert_eq!((got.len(), c.of(FaultKind::Duplicate)), (1000, 500));
        let (got, c) = through(only(FaultKind::Flip as usize), &bytes, 500);
        assert_eq!(c.of(FaultKind::Flip), 500);
        assert!(got.iter().all(|b| (b ^ 0x55).count_ones() == 1), "{got:?}");
        let (got, c) = through(only(FaultKind::Delay as usize), &bytes, 500);
        assert_eq!((got, c.of(FaultKind::Delay)), (bytes.clone(), 500));
        let (got, c) = through(only(FaultKind::Drop as usize), &bytes, 0);
        assert_eq!((got.len(), c.of(FaultKind::Drop), c.total()), (0, 500, 500));
    }

    #[test]
    fn a_rate_that_is_no_probability_is_refused() {
        let board = Pty::open().unwrap();
        for rate in [-0.1, 1.5, f64::NAN] {
            let opts = ProxyOptions {
                rate,
                ..ProxyOptions::default()
            };
            assert!(LinkProxy::start(&board.path, opts).is_err(), "{rate}");
        }
    }
}
