//! The service's long CPU-bound work (a group's or a preview's TDM timing) on a few
//! threads of their own, at the lowest OS priority (Linux `SCHED_IDLE`), with a bounded
//! queue: however many clients ask for it, the threads that answer `estop`, `stop` and
//! `status` (and the board's ticker) keep a core and preempt the timing at once.

use crate::error::CtlError;
use std::collections::VecDeque;
use std::sync::mpsc;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// The nice value of the pool's threads (Linux; 0 is a normal thread's, 19 the lowest).
pub const WORKER_NICE: i32 = 10;

/// Jobs waiting (not yet running) past which a new one is refused with
/// [`CtlError::Overloaded`].
pub const DEFAULT_QUEUE: usize = 32;

/// Which queue and workers a job has: moves and previews never share a worker.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lane {
    Move,
    Preview,
}

type Job = Box<dyn FnOnce() + Send>;

#[derive(Default)]
struct Queues {
    moves: VecDeque<Job>,
    previews: VecDeque<Job>,
    quit: bool,
}

impl Queues {
    fn len(&self) -> usize {
        self.moves.len() + self.previews.len()
    }
}

struct Inner {
    queues: Mutex<Queues>,
    moves_ready: Condvar,
    previews_ready: Condvar,
}

impl Inner {
    fn queues(&self) -> MutexGuard<'_, Queues> {
        self.queues.lock().unwrap_or_else(|p| p.into_inner())
    }
}

/// A fixed set of worker threads; see the module doc.
pub struct WorkPool {
    inner: Arc<Inner>,
    cap: usize,
    threads: Vec<JoinHandle<()>>,
}

impl WorkPool {
    /// `threads` workers for moves (at nice [`WORKER_NICE`]) and as many for previews (in
    /// the idle class, [`idle_class`]), at least one each, and at most `cap` jobs waiting.
    /// Moves never wait behind previews; previews take only CPU time nothing else wants.
    pub fn new(threads: usize, cap: usize) -> Result<WorkPool, CtlError> {
        let inner = Arc::new(Inner {
            queues: Mutex::default(),
            moves_ready: Condvar::new(),
            previews_ready: Condvar::new(),
        });
        let n = threads.max(1);
        let threads = [Lane::Move, Lane::Preview]
            .into_iter()
            .flat_map(|lane| (0..n).map(move |i| (lane, i)))
            .map(|(lane, i)| {
                let inner = inner.clone();
                let name = match lane {
                    Lane::Move => format!("timing-{i}"),
                    Lane::Preview => format!("preview-{i}"),
                };
                std::thread::Builder::new()
                    .name(name)
                    .spawn(move || worker(&inner, lane))
                    .map_err(|e| CtlError::Io(format!("cannot start a timing thread: {e}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(WorkPool {
            inner,
            cap,
            threads,
        })
    }

    /// The default for this machine: one move worker and one preview worker per two
    /// cores (at least one each), so that on a small machine a core stays free for the
    /// threads that answer halts.
    pub fn for_this_machine() -> Result<WorkPool, CtlError> {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        WorkPool::new(cores / 2, DEFAULT_QUEUE)
    }

    /// Runs `f` on a worker of `lane` and waits for its result; refused at once when
    /// `cap` jobs already wait.
    pub fn run<R: Send + 'static>(
        &self,
        lane: Lane,
        f: impl FnOnce() -> R + Send + 'static,
    ) -> Result<R, CtlError> {
        let (tx, rx) = mpsc::sync_channel(1);
        let job: Job = Box::new(move || {
            let _ = tx.send(f());
        });
        {
            let mut q = self.inner.queues();
            if q.len() >= self.cap {
                return Err(CtlError::Overloaded(format!(
                    "{} moves and previews are waiting to be timed; try again later",
                    q.len()
                )));
            }
            match lane {
                Lane::Move => q.moves.push_back(job),
                Lane::Preview => q.previews.push_back(job),
            }
        }
        match lane {
            Lane::Move => self.inner.moves_ready.notify_one(),
            Lane::Preview => self.inner.previews_ready.notify_one(),
        }
        // A job that panicked drops its sender.
        rx.recv()
            .map_err(|_| CtlError::Io("timing the move failed (a worker panicked)".into()))
    }
}

fn worker(inner: &Inner, lane: Lane) {
    lower_priority(WORKER_NICE);
    // A preview holds no lock a halt or a move needs, so it can wait for an idle CPU; a
    // move's timing stays in the normal class so that moves still start on a busy host.
    if lane == Lane::Preview {
        idle_class();
    }
    let ready = match lane {
        Lane::Move => &inner.moves_ready,
        Lane::Preview => &inner.previews_ready,
    };
    loop {
        let job = {
            let mut q = inner.queues();
            loop {
                if q.quit {
                    return;
                }
                let next = match lane {
                    Lane::Move => q.moves.pop_front(),
                    Lane::Preview => q.previews.pop_front(),
                };
                if let Some(j) = next {
                    break j;
                }
                q = ready.wait(q).unwrap_or_else(|p| p.into_inner());
            }
        };
        // A panic ends that job only (its caller gets an error), not the worker.
        let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(job));
    }
}

/// Lowers the calling thread's scheduling priority to `nice` (it cannot be raised again
/// without privileges). On Linux the nice value is per thread (setpriority(2) on the
/// thread's id); elsewhere this does nothing.
pub(crate) fn lower_priority(nice: i32) {
    #[cfg(target_os = "linux")]
    // SAFETY: plain system calls on this thread's own id; no memory is shared.
    unsafe {
        let tid = libc::gettid() as libc::id_t;
        // never raised: a service started at a lower priority keeps it
        let nice = nice.max(libc::getpriority(libc::PRIO_PROCESS, tid));
        if libc::setpriority(libc::PRIO_PROCESS, tid, nice) != 0 {
            eprintln!(
                "warning: cannot lower a thread's priority: {}",
                std::io::Error::last_os_error()
            );
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = nice;
}

/// Moves the calling thread to Linux's `SCHED_IDLE` class (sched(7)): it runs only on a
/// CPU no normal thread wants, and a normal thread that wakes preempts it at once (a
/// nice value only weighs its share). Needs no privilege and is never a raise: it is the
/// lowest class, a thread already in it is left there, and one at `SCHED_BATCH` or real time
/// priority is lowered to it. Elsewhere this does nothing.
pub(crate) fn idle_class() {
    #[cfg(target_os = "linux")]
    // SAFETY: plain system calls on this thread's own id with a parameter on the stack.
    unsafe {
        let tid = libc::gettid();
        if libc::sched_getscheduler(tid) == libc::SCHED_IDLE {
            return;
        }
        let p = libc::sched_param { sched_priority: 0 };
        if libc::sched_setscheduler(tid, libc::SCHED_IDLE, &p) != 0 {
            eprintln!(
                "warning: cannot move a thread to SCHED_IDLE: {}",
                std::io::Error::last_os_error()
            );
        }
    }
}

impl Drop for WorkPool {
    fn drop(&mut self) {
        self.inner.queues().quit = true;
        self.inner.moves_ready.notify_all();
        self.inner.previews_ready.notify_all();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Barrier;

    #[test]
    fn a_full_queue_refuses_at_once_and_moves_never_wait_behind_previews() {
        let pool = Arc::new(WorkPool::new(1, 2).unwrap());
        // hold the one preview worker until the queue is filled
        let (held, release) = (Arc::new(Barrier::new(2)), Arc::new(Barrier::new(2)));
        let blocker = {
            let (pool, held, release) = (pool.clone(), held.clone(), release.clone());
            std::thread::spawn(move || {
                pool.run(Lane::Preview, move || {
                    held.wait();
                    release.wait();
                })
            })
        };
        held.wait();
        // a move is timed while the previews' worker is taken
        assert_eq!(pool.run(Lane::Move, || 5).unwrap(), 5);
        let queued: Vec<_> = (1..=2)
            .map(|n| {
                let p = pool.clone();
                let t = std::thread::spawn(move || p.run(Lane::Preview, move || n));
                while pool.inner.queues().len() < n {
                    std::thread::yield_now();
                }
                t
            })
            .collect();
        let e = pool.run(Lane::Move, || ()).unwrap_err();
        assert_eq!(e.code(), 23, "{e}");
        release.wait();
        blocker.join().unwrap().unwrap();
        let done: Vec<usize> = queued
            .into_iter()
            .map(|t| t.join().unwrap().unwrap())
            .collect();
        assert_eq!(done, [1, 2]);
    }

    #[test]
    fn a_job_that_panics_is_an_error_and_the_worker_goes_on() {
        let pool = WorkPool::new(1, 4).unwrap();
        let r = pool.run(Lane::Preview, || -> u32 { panic!("boom") });
        assert!(r.is_err());
        assert_eq!(pool.run(Lane::Move, || 7).unwrap(), 7);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn workers_run_at_the_lower_priority() {
        let pool = WorkPool::new(1, 4).unwrap();
        // SAFETY: reads this thread's own nice value.
        let nice =
            || unsafe { libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t) };
        for lane in [Lane::Move, Lane::Preview] {
            let n = pool.run(lane, nice).unwrap();
            assert!(n >= WORKER_NICE, "{lane:?}: nice {n}");
        }
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn workers_run_in_the_idle_class_and_it_is_never_left() {
        let pool = WorkPool::new(1, 4).unwrap();
        // SAFETY: reads and sets this thread's own policy.
        let policy = || unsafe { libc::sched_getscheduler(libc::gettid()) };
        let own = policy();
        assert_ne!(own, libc::SCHED_IDLE, "run the tests in a normal class");
        assert_eq!(pool.run(Lane::Preview, policy).unwrap(), libc::SCHED_IDLE);
        // a move's timing stays in the caller's class
        assert_eq!(pool.run(Lane::Move, policy).unwrap(), own);
        // again on a thread already idle: it stays there (no raise back to normal)
        let again = std::thread::spawn(move || {
            idle_class();
            idle_class();
            policy()
        })
        .join()
        .unwrap();
        assert_eq!(again, libc::SCHED_IDLE);
        // the caller of a job keeps its own class
        assert_eq!(policy(), own);
    }
}
