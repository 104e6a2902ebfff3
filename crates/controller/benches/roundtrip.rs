//! Command round-trip latency over TCP (p50, p99) and status polling rate, against the
//! real service code in-process (TCP on 127.0.0.1). Percentiles need every sample, which
//! criterion does not report, so this bench measures them itself.
//! Run: `cargo bench -p multistep-controller --bench roundtrip`.

use multistep_controller::client::{Client, Endpoint};
use multistep_controller::{service, BoardConfig, Controller};
use std::sync::Arc;
use std::time::{Duration, Instant};

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn latency(c: &mut Client, line: &str, n: usize) -> Vec<Duration> {
    for _ in 0..200 {
        c.request(line).unwrap();
    }
    let mut t: Vec<Duration> = (0..n)
        .map(|_| {
            let t0 = Instant::now();
            c.request(line).unwrap();
            t0.elapsed()
        })
        .collect();
    t.sort();
    t
}

fn polling_rate(addr: &str, clients: usize, secs: f64) -> f64 {
    let stop = Instant::now() + Duration::from_secs_f64(secs);
    let threads: Vec<_> = (0..clients)
        .map(|_| {
            let addr = addr.to_string();
            std::thread::spawn(move || {
                let mut c = Client::connect(&Endpoint::Tcp(addr)).unwrap();
                let mut n = 0u64;
                while Instant::now() < stop {
                    assert_eq!(c.status().unwrap().len(), 4);
                    n += 1;
                }
                n
            })
        })
        .collect();
    let total: u64 = threads.into_iter().map(|t| t.join().unwrap()).sum();
    total as f64 / secs
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = Arc::new(Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap());
    let listener = service::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    std::thread::spawn({
        let ctl = ctl.clone();
        move || service::serve_tcp(ctl, listener)
    });
    let mut c = Client::connect(&Endpoint::Tcp(addr.clone())).unwrap();
    // One axis in motion all along, so the ticker thread competes for the board as it
    // does in service (4 000 steps/s for ~100 s).
    c.request("move A 400000").unwrap();

    println!("| command | samples | p50 (µs) | p99 (µs) | p99.9 (µs) |");
    println!("|---|---|---|---|---|");
    for line in ["version", "status X", "status json", "get X vmax"] {
        let t = latency(&mut c, line, 20_000);
        println!(
            "| `{line}` | {} | {:.1} | {:.1} | {:.1} |",
            t.len(),
            percentile(&t, 0.5).as_secs_f64() * 1e6,
            percentile(&t, 0.99).as_secs_f64() * 1e6,
            percentile(&t, 0.999).as_secs_f64() * 1e6
        );
    }
    // A move that is planned, timed by the TDM engine and written (redb commit) each time.
    let t = {
        let mut v: Vec<Duration> = (0..200)
            .map(|k| {
                let line = if k % 2 == 0 {
                    "move X 100"
                } else {
                    "move X -100"
                };
                let t0 = Instant::now();
                c.request(line).unwrap();
                let d = t0.elapsed();
                c.request("stop X").unwrap();
                while c.status().unwrap()[0].state != multistep_controller::AxisState::Idle {
                    std::thread::sleep(Duration::from_millis(1));
                }
                d
            })
            .collect();
        v.sort();
        v
    };
    println!(
        "| `move X ±100` (plan + TDM + durable marker) | {} | {:.1} | {:.1} | – |",
        t.len(),
        percentile(&t, 0.5).as_secs_f64() * 1e6,
        percentile(&t, 0.99).as_secs_f64() * 1e6
    );
    println!();
    println!("| status polling (`status json`, 4 axes) | polls/s |");
    println!("|---|---|");
    for clients in [1, 4] {
        println!(
            "| {clients} client(s) | {:.0} |",
            polling_rate(&addr, clients, 3.0)
        );
    }
}
