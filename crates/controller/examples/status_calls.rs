//! `status` answered N times on the simulated board (default config, four axes, one of
//! them moving), each reply rendered as the service sends it: the driver callgrind counts
//! to give instructions per `status` request (Ir at N minus Ir at 0, over N).
//!
//! `cargo build --release -p multistep-controller --example status_calls` then
//! `valgrind --tool=callgrind target/release/examples/status_calls N`

use multistep_controller::{BoardConfig, Controller};

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1000);
    let dir = tempfile::tempdir().expect("a temporary directory");
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).expect("the board");
    let moving = ctl.execute_bytes(b"move A 400000").to_text();
    assert!(moving.ends_with("ok\n"), "{moving}");
    let mut bytes = 0;
    for _ in 0..n {
        bytes += ctl.execute_bytes(b"status").to_text().len();
    }
    println!("{bytes}");
}
