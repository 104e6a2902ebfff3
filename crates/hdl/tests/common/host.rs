//! The host side of a board co-simulation: requests and bulk writes in order with their
//! sequence numbers, the simulation directory, and the replies checked against them.

use multistep_hdl::board_sim::{simulate, simulate_with, BoardLog, Script};
use multistep_hdl::link::{BulkWrite, Reg, RegWrite, Reply, Request};
use multistep_hdl::simulator::Simulator;
use multistep_hdl::BoardTop;
use std::path::PathBuf;

/// A script that sends requests back to back; `seqs` holds each one's sequence number,
/// so request i is answered by reply i.
pub struct Host {
    pub s: Script,
    pub seqs: Vec<u8>,
    seq: u8,
}

impl Default for Host {
    fn default() -> Host {
        Host::new()
    }
}

impl Host {
    pub fn new() -> Host {
        Host {
            s: Script::new(),
            seqs: Vec::new(),
            seq: 0,
        }
    }

    /// The sequence number the next request gets.
    pub fn seq(&self) -> u8 {
        self.seq
    }

    /// How many requests were sent (the index the next one gets).
    pub fn sent(&self) -> usize {
        self.seqs.len()
    }

    pub fn write(&mut self, reg: Reg, data: u32) -> usize {
        self.push(Request::write(self.seq, reg, data))
    }

    pub fn read(&mut self, reg: Reg) -> usize {
        self.push(Request::read(self.seq, reg))
    }

    pub fn writes(&mut self, ws: &[RegWrite]) {
        for w in ws {
            self.write(w.reg, w.data);
        }
    }

    /// Sends `r` (its sequence number must be [`Host::seq`]); returns its reply's index.
    pub fn push(&mut self, r: Request) -> usize {
        self.s.send(&r);
        self.sent_one(r.seq)
    }

    /// Sends a bulk write (its sequence number must be [`Host::seq`]).
    pub fn bulk(&mut self, w: &BulkWrite) -> usize {
        self.s.send_bulk(w).unwrap();
        self.sent_one(w.seq)
    }

    /// Sends `r` again, as it was (a host that lost its reply); returns the index of the
    /// reply to this copy.
    pub fn again(&mut self, r: &Request) -> usize {
        self.again_bytes(&r.encode(), r.seq)
    }

    /// Sends raw frame bytes under an earlier request's `seq` (e.g. a damaged copy of
    /// it); returns the index of its reply.
    pub fn again_bytes(&mut self, bytes: &[u8], seq: u8) -> usize {
        self.s.bytes(bytes).expect_reply();
        self.seqs.push(seq);
        self.seqs.len() - 1
    }

    /// Sends raw frame bytes that expect one reply (e.g. a corrupted frame).
    pub fn frame(&mut self, bytes: &[u8]) -> usize {
        self.s.bytes(bytes).expect_reply();
        self.sent_one(self.seq)
    }

    fn sent_one(&mut self, seq: u8) -> usize {
        self.seq = seq.wrapping_add(1);
        self.seqs.push(seq);
        self.seqs.len() - 1
    }

    /// Simulates `b` running this script (at most `timeout` clocks) in the simulator
    /// `MULTISTEP_SIM` names, and checks that every request was answered, in order.
    pub fn run(&self, b: &BoardTop, name: &str, timeout: u64) -> (BoardLog, Vec<Reply>) {
        let (_dir, path) = sim_dir(name);
        let log = simulate(b, &self.s, &path, timeout).unwrap_or_else(|e| panic!("{name}: {e}"));
        self.replies(name, log)
    }

    /// [`Host::run`] in Icarus Verilog and in Verilator: both write the same log.
    pub fn run_in_both(&self, b: &BoardTop, name: &str, timeout: u64) -> (BoardLog, Vec<Reply>) {
        let [icarus, verilator] = [Simulator::Icarus, Simulator::Verilator].map(|sim| {
            let (_dir, path) = sim_dir(&format!("{name}-{sim:?}"));
            simulate_with(sim, b, &self.s, &path, timeout)
                .unwrap_or_else(|e| panic!("{name} in {sim:?}: {e}"))
        });
        assert!(
            !icarus.step.iter().all(Vec::is_empty),
            "{name}: no STEP edge"
        );
        assert_eq!(icarus, verilator, "{name}: Icarus and Verilator disagree");
        self.replies(name, verilator)
    }

    fn replies(&self, name: &str, log: BoardLog) -> (BoardLog, Vec<Reply>) {
        let got: Vec<Reply> = log
            .replies()
            .into_iter()
            .map(|r| r.unwrap_or_else(|e| panic!("{name}: {e}")))
            .collect();
        assert_eq!(got.len(), self.seqs.len(), "{name}: one reply per request");
        for (r, &q) in got.iter().zip(&self.seqs) {
            assert_eq!(r.seq, q, "{name}: reply order");
        }
        (log, got)
    }
}

/// A fresh simulation directory named after the test, removed when the guard drops;
/// `MS_BOARD_KEEP=1` keeps it (its path is printed).
pub fn sim_dir(name: &str) -> (Option<tempfile::TempDir>, PathBuf) {
    let dir = tempfile::Builder::new().prefix(name).tempdir().unwrap();
    if std::env::var_os("MS_BOARD_KEEP").is_some() {
        let p = dir.keep();
        eprintln!("{name}: {}", p.display());
        (None, p)
    } else {
        let p = dir.path().to_path_buf();
        (Some(dir), p)
    }
}

/// 50 % duty: STEP stays high for half of the interval to the next edge (at least one
/// tick), the last pulse for half of the last interval.
pub fn half_interval_falls(rises: &[u64]) -> Vec<u64> {
    let mut prev = 0;
    (0..rises.len())
        .map(|k| {
            let interval = rises
                .get(k + 1)
                .map_or(rises[k] - prev, |next| next - rises[k]);
            prev = rises[k];
            rises[k] + (interval / 2).max(1)
        })
        .collect()
}
