//! Helpers the test binaries share.

// each test binary compiles this module and may use only part of it
#![allow(dead_code)]

use std::io::{BufRead, BufReader, Read};
use std::sync::mpsc;
use std::time::Duration;

/// A child's stderr, read by a thread of the test that started it.
///
/// Each line is printed with `eprintln!`, which the test harness captures for a thread a
/// test spawned: the child's warnings (an injected fault's `warning: … faulted`) appear
/// under a failing test, or with `--nocapture`, and stay out of a passing run's log.
pub struct EchoedStderr {
    eof: mpsc::Receiver<()>,
}

impl EchoedStderr {
    /// Starts echoing `stderr` (the pipe of a child spawned with `Stdio::piped()`).
    pub fn start(stderr: impl Read + Send + 'static) -> EchoedStderr {
        let (tx, eof) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                match line {
                    Ok(l) => eprintln!("{l}"),
                    Err(_) => break,
                }
            }
            let _ = tx.send(());
        });
        EchoedStderr { eof }
    }

    /// Once the child has ended: waits until its last lines are echoed, when the test is
    /// failing (so they are in the output shown with the failure). A grandchild that keeps
    /// the pipe open ends the wait at a generous deadline.
    pub fn flush_if_failing(&self) {
        if std::thread::panicking() {
            let _ = self.eof.recv_timeout(Duration::from_secs(10));
        }
    }
}
