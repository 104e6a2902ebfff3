//! Command round-trip latency over TCP (p50, p99) and status polling rate, against the
//! real service code in-process (TCP on 127.0.0.1). Percentiles need every sample, which
//! criterion does not report, so this bench measures them itself.
//! Run: `cargo bench -p multistep-controller --bench roundtrip` (`-- floor`: only `status`
//! against a minimal server's floor, the process on one CPU).

use multistep_controller::client::{Client, Endpoint};
use multistep_controller::{service, BoardConfig, Controller};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
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

/// The least a server can do for one request: read a line, write `reply`, nothing else
/// (the floor the service's `status` is compared with).
fn floor_server(reply: Vec<u8>) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = listener.local_addr().unwrap().to_string();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let stream = stream.unwrap();
            stream.set_nodelay(true).unwrap();
            let reply = reply.clone();
            std::thread::spawn(move || {
                let mut out = &stream;
                let mut input = BufReader::new(&stream);
                let mut line = Vec::new();
                while input.read_until(b'\n', &mut line).unwrap_or(0) > 0 {
                    line.clear();
                    if out.write_all(&reply).is_err() {
                        return;
                    }
                }
            });
        }
    });
    addr
}

/// One request on a raw socket: the line written, the reply read to its `ok` line.
fn raw_request(s: &mut TcpStream, line: &[u8], buf: &mut Vec<u8>) {
    s.write_all(line).unwrap();
    buf.clear();
    let mut chunk = [0u8; 4096];
    while !buf.ends_with(b"\nok\n") {
        let n = s.read(&mut chunk).unwrap();
        assert!(n > 0, "the server closed");
        buf.extend_from_slice(&chunk[..n]);
    }
}

/// `status` against the floor: the same client code on both, the same bytes back, rounds
/// alternated so that both see the same machine.
fn status_against_floor(service_addr: &str, reply: Vec<u8>) {
    let floor_addr = floor_server(reply);
    let connect = |a: &str| {
        let s = TcpStream::connect(a).unwrap();
        s.set_nodelay(true).unwrap();
        s
    };
    let (mut svc, mut floor) = (connect(service_addr), connect(&floor_addr));
    let mut buf = Vec::new();
    let (mut ts, mut tf) = (Vec::new(), Vec::new());
    for round in 0..22 {
        for (s, t) in [(&mut svc, &mut ts), (&mut floor, &mut tf)] {
            for _ in 0..1000 {
                let t0 = Instant::now();
                raw_request(s, b"status\n", &mut buf);
                if round >= 2 {
                    t.push(t0.elapsed());
                }
            }
        }
    }
    ts.sort();
    tf.sort();
    let (s50, f50) = (percentile(&ts, 0.5), percentile(&tf, 0.5));
    println!(
        "| `status` (4 axes, {} bytes) | service | floor | service / floor |",
        buf.len()
    );
    println!("|---|---:|---:|---:|");
    println!(
        "| p50 (µs) | {:.1} | {:.1} | {:.2} |",
        s50.as_secs_f64() * 1e6,
        f50.as_secs_f64() * 1e6,
        s50.as_secs_f64() / f50.as_secs_f64()
    );
    println!(
        "| p99 (µs) | {:.1} | {:.1} | {:.2} |",
        percentile(&ts, 0.99).as_secs_f64() * 1e6,
        percentile(&tf, 0.99).as_secs_f64() * 1e6,
        percentile(&ts, 0.99).as_secs_f64() / percentile(&tf, 0.99).as_secs_f64()
    );
    println!();
}

/// Every thread of this process on CPU 0 from here on. On a virtual machine a wakeup
/// across virtual CPUs costs tens of microseconds and lands on either server at random;
/// on one CPU both are served alike.
fn pin_to_one_cpu() {
    #[cfg(target_os = "linux")]
    // SAFETY: a CPU set on the stack, passed by pointer to the call that reads it.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(0, &mut set);
        assert_eq!(
            libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set),
            0
        );
    }
}

fn main() {
    let floor_only = std::env::args().any(|a| a == "floor");
    if floor_only {
        pin_to_one_cpu();
    }
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

    let reply = ctl.execute_bytes(b"status").to_text().into_bytes();
    status_against_floor(&addr, reply);
    if floor_only {
        return; // `-- floor`: only the comparison above, on one CPU
    }

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
