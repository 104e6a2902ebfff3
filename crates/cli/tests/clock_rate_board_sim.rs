//! board-sim's `--ppm` against the host's fit of a board's clock (the controller's
//! `clock_rate`): two verilated boards on one SYNC line, board 0 on the nominal clock
//! standing for host time, board 1 37 ppm fast. Each `Fire` latches both boards' counts at
//! one fall (`SyncTick`); board 1's counts against board 0's, fitted as the host fits
//! readings, give its rate within 0.5 ppm over 0.2 s of board time (the link's round trips
//! between the fires).
//! Needs `verilator` and `g++`.

use multistep_controller::clock_rate::{ClockEstimator, Reading};
use multistep_hdl::link::{BoardReg, HostLink, Reg};
use multistep_hil::multi::{MultiBoardSim, MultiOptions};
use multistep_hil::Options;
use std::path::PathBuf;
use std::time::{Duration, Instant};

type Port = Box<dyn serialport::SerialPort>;

#[test]
fn the_fit_of_a_verilated_board_finds_its_ppm() {
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("verilator");
    let board = || Options {
        board: "ulx3s-25f".into(),
        axes: Some(1),
        cache_dir: Some(cache.clone()),
        ..Options::default()
    };
    let ppm = 37.0;
    let sim = MultiBoardSim::start(&MultiOptions {
        boards: vec![board(), board()],
        ppm: vec![0.0, ppm],
        power_up_us: vec![0.0, 0.0],
    })
    .expect("board-sim starts");
    let clock_hz = sim.boards[0].core.clock_hz;
    let mut l: Vec<HostLink<Port>> = (0..2)
        .map(|i| {
            let port = serialport::new(&sim.pty_paths[i], sim.boards[i].baud)
                .timeout(Duration::from_millis(5000))
                .open()
                .expect("the pty opens as a serial port");
            HostLink::new(port)
        })
        .collect();
    let mut fit = ClockEstimator::new(clock_hz).with_min_span(100_000);
    let mut last = [0u32; 2];
    for k in 0..24 {
        l[k % 2].write(Reg::Board(BoardReg::Fire), 1).unwrap();
        // the fall reaches both boards: each one's latched count changes
        let t0 = Instant::now();
        let mut now = last;
        for (i, h) in l.iter_mut().enumerate() {
            while now[i] == last[i] {
                assert!(t0.elapsed() < Duration::from_secs(60), "no fall seen");
                now[i] = h.read(Reg::Board(BoardReg::SyncTick)).unwrap();
            }
        }
        last = now;
        // board 0's count is host time
        let host_ns = (f64::from(now[0]) * 1e9 / clock_hz).round() as u64;
        let r = Reading {
            sent_ns: host_ns,
            recv_ns: host_ns,
            tick: u64::from(now[1]),
        };
        fit.add(r).unwrap();
        // some board time between fires: reads of a register, each a round trip
        for _ in 0..(k % 5 + 1) * 20 {
            l[0].read(Reg::Board(BoardReg::Status)).unwrap();
        }
    }
    drop(l);
    sim.quit().unwrap();
    let f = fit.fit().expect("a fit");
    let span = f64::from(last[0]) / clock_hz;
    eprintln!(
        "board-sim --ppm 0,{ppm}: fitted {:+.3} ppm from {} falls over {:.2} ms of board time",
        f.ppm,
        f.kept,
        span * 1e3
    );
    assert!((f.ppm - ppm).abs() < 0.5, "{f:?}");
}
