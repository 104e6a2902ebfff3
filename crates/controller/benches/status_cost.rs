//! The service's own cost of one `status` request, for an instruction counter: the line
//! parsed, the board's four axes read and formatted into the reply's text, N times
//! (`moving`: with one axis in motion, so each request advances it).
//! `valgrind --tool=callgrind target/release/deps/status_cost-* N` minus the same with 0,
//! over N (docs/BENCHMARKS.md, "status without the link").

use multistep_controller::{BoardConfig, Controller};

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20_000);
    let line: &[u8] = match std::env::args().nth(2).as_deref() {
        Some("json") => b"status json",
        _ => b"status",
    };
    let dir = tempfile::tempdir().unwrap();
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    if std::env::args().any(|a| a == "moving") {
        ctl.execute_bytes(b"move A 400000");
    }
    let (mut bytes, mut text) = (0, String::new());
    for _ in 0..n {
        // what a connection does with each line
        text.clear();
        ctl.answer_bytes(std::hint::black_box(line), &mut text);
        bytes += std::hint::black_box(&text).len();
    }
    println!("{n} requests, {bytes} bytes");
}
