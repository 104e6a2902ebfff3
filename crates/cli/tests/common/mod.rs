//! Helpers the test binaries share.

// each test binary compiles this module and may use only part of it
#![allow(dead_code)]

use multistep_controller::client::{Client, Endpoint};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
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

/// A child process killed when dropped, its stderr echoed under a failing test; its stdin
/// and stdout kept for control lines (board-sim's `state`, `reset`, …).
pub struct Proc {
    child: Child,
    stdin: ChildStdin,
    stdout: BufReader<ChildStdout>,
    stderr: EchoedStderr,
}

impl Proc {
    /// Started; its first `lines` lines of output.
    pub fn spawn(cmd: &mut Command, lines: usize) -> (Proc, Vec<String>) {
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn multistep");
        let stderr = EchoedStderr::start(child.stderr.take().unwrap());
        let stdin = child.stdin.take().unwrap();
        let mut p = Proc {
            stdout: BufReader::new(child.stdout.take().unwrap()),
            child,
            stdin,
            stderr,
        };
        let first = (0..lines).map(|_| p.read_line()).collect();
        (p, first)
    }

    /// The next line of its output, trimmed ("" at its end).
    pub fn read_line(&mut self) -> String {
        let mut l = String::new();
        let _ = self.stdout.read_line(&mut l);
        l.trim().to_string()
    }

    /// Writes one line to its stdin.
    pub fn send(&mut self, line: &str) {
        writeln!(self.stdin, "{line}").expect("the child reads its stdin");
        self.stdin.flush().unwrap();
    }

    /// SIGKILL, and reaped.
    pub fn kill9(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill9();
        self.stderr.flush_if_failing();
    }
}

/// `bin serve` with the data and `board.toml` of `dir`, on the board link `link`
/// (`serial:PTY,timeout=S`); and a client of it.
pub fn serve_on_link(bin: &str, dir: &Path, link: &str) -> (Proc, Client) {
    try_serve_on_link(bin, dir, link).unwrap_or_else(|e| panic!("{e}"))
}

/// As [`serve_on_link`]; a service that ends before it listens (a board that does not
/// answer at start) is an error.
pub fn try_serve_on_link(bin: &str, dir: &Path, link: &str) -> Result<(Proc, Client), String> {
    let (serve, first) = Proc::spawn(
        Command::new(bin)
            .args(["serve", "--listen", "127.0.0.1:0", "--data"])
            .arg(dir.join("data"))
            .arg("--board-config")
            .arg(dir.join("board.toml"))
            .args(["--board-link", link]),
        1,
    );
    let addr = first[0].rsplit("tcp://").next().unwrap().to_string();
    if !addr.contains(':') {
        return Err(format!("serve said: {first:?}"));
    }
    let client = Client::connect(&Endpoint::Tcp(addr)).map_err(|e| e.to_string())?;
    Ok((serve, client))
}
