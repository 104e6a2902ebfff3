//! The service's long CPU-bound work (a group's or a preview's TDM timing) on a few
//! threads of their own, at a lower OS priority, with a bounded queue: however many
//! clients ask for it, the threads that answer `estop`, `stop` and `status` (and the
//! board's ticker) keep a core and the scheduler's preference.

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

/// Which queue a job waits in: moves are taken before previews.
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
    ready: Condvar,
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
    /// `threads` workers (at least one) and at most `cap` jobs waiting.
    pub fn new(threads: usize, cap: usize) -> Result<WorkPool, CtlError> {
        let inner = Arc::new(Inner {
            queues: Mutex::default(),
            ready: Condvar::new(),
        });
        let threads = (0..threads.max(1))
            .map(|i| {
                let inner = inner.clone();
                std::thread::Builder::new()
                    .name(format!("timing-{i}"))
                    .spawn(move || worker(&inner))
                    .map_err(|e| CtlError::Io(format!("cannot start a timing thread: {e}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(WorkPool {
            inner,
            cap,
            threads,
        })
    }

    /// The default for this machine: one worker per two cores (at least one), so that
    /// on a small machine a core stays free for the threads that answer halts.
    pub fn for_this_machine() -> Result<WorkPool, CtlError> {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        WorkPool::new(cores / 2, DEFAULT_QUEUE)
    }

    /// Runs `f` on a worker and waits for its result; refused at once when `cap` jobs
    /// already wait.
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
        self.inner.ready.notify_one();
        // A job that panicked drops its sender.
        rx.recv()
            .map_err(|_| CtlError::Io("timing the move failed (a worker panicked)".into()))
    }
}

fn worker(inner: &Inner) {
    lower_priority(WORKER_NICE);
    loop {
        let job = {
            let mut q = inner.queues();
            loop {
                if q.quit {
                    return;
                }
                if let Some(j) = q.moves.pop_front().or_else(|| q.previews.pop_front()) {
                    break j;
                }
                q = inner.ready.wait(q).unwrap_or_else(|p| p.into_inner());
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

impl Drop for WorkPool {
    fn drop(&mut self) {
        self.inner.queues().quit = true;
        self.inner.ready.notify_all();
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
    fn a_full_queue_refuses_at_once_and_moves_go_before_previews() {
        let pool = Arc::new(WorkPool::new(1, 2).unwrap());
        // hold the one worker until the queue is filled
        let (held, release) = (Arc::new(Barrier::new(2)), Arc::new(Barrier::new(2)));
        let order = Arc::new(Mutex::new(Vec::new()));
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
        let queued: Vec<_> = [(Lane::Preview, "preview"), (Lane::Move, "move")]
            .into_iter()
            .map(|(lane, name)| {
                let (p, order) = (pool.clone(), order.clone());
                let t = std::thread::spawn(move || {
                    p.run(lane, move || order.lock().unwrap().push(name))
                });
                // each waits in the queue before the next is asked for
                while pool.inner.queues().len() < 1 + (lane == Lane::Move) as usize {
                    std::thread::yield_now();
                }
                t
            })
            .collect();
        let e = pool.run(Lane::Move, || ()).unwrap_err();
        assert_eq!(e.code(), 23, "{e}");
        release.wait();
        blocker.join().unwrap().unwrap();
        for t in queued {
            t.join().unwrap().unwrap();
        }
        assert_eq!(*order.lock().unwrap(), ["move", "preview"]);
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
        let nice = pool
            .run(Lane::Preview, || unsafe {
                libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t)
            })
            .unwrap();
        assert!(nice >= WORKER_NICE, "nice {nice}");
    }
}
