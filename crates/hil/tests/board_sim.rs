//! Hardware in the loop: the board's RTL in Verilator behind a pseudo-terminal, driven by
//! the host link over `serialport` as a real host would. Needs `verilator` and `g++`
//! (skipped with a message when missing, unless CI is set: then it fails).

use multistep_core::int::{
    IntClock, IntEdgeGenerator, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment,
};
use multistep_hdl::link::{
    move_writes, start_write, AxisReg, BoardReg, BuildId, HostLink, LinkError, Reg,
};
use multistep_hdl::AxisMove;
use multistep_hil::{BoardSim, Options, SensorOptions};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Clocks from the group's tick 0 to a STEP pin's rise at move tick t (docs/HDL.md, "Tick
/// 0 on the board").
const TICK0: u64 = 1;

fn tools_present() -> bool {
    let have = multistep_hdl::tools::find("verilator", "verilator").is_ok()
        && multistep_hdl::tools::find("g++", "g++").is_ok();
    if !have {
        let ci = std::env::var("CI").is_ok_and(|v| v == "true");
        assert!(
            !ci,
            "verilator and g++ are needed under CI (apt-get install -y verilator g++)"
        );
        eprintln!("SKIPPED: verilator or g++ missing (apt-get install -y verilator g++)");
    }
    have
}

/// Models built once per target directory, shared by the tests.
fn cache() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("verilator")
}

fn start(axes: u32, sensors: Vec<SensorOptions>, edges: Option<PathBuf>) -> BoardSim {
    start_board("ulx3s-25f", axes, sensors, edges)
}

fn start_board(
    board: &str,
    axes: u32,
    sensors: Vec<SensorOptions>,
    edges: Option<PathBuf>,
) -> BoardSim {
    BoardSim::start(&Options {
        board: board.into(),
        axes: Some(axes),
        sensors,
        edges,
        cache_dir: Some(cache()),
        ..Options::default()
    })
    .expect("board-sim starts")
}

type Port = Box<dyn serialport::SerialPort>;

fn link(sim: &BoardSim, timeout_ms: u64) -> HostLink<Port> {
    let port = serialport::new(&sim.pty_path, sim.board.baud)
        .timeout(Duration::from_millis(timeout_ms))
        .open()
        .expect("the pty opens as a serial port");
    HostLink::new(port)
}

fn wait_idle(l: &mut HostLink<Port>) {
    let t0 = Instant::now();
    while l.read(Reg::Board(BoardReg::Busy)).unwrap() != 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(300),
            "the move never ends"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Waits until the simulated motors are at rest: with the board idle and no motor
/// settling, simulated time stops. (A move sent while a rotor still rings after the last
/// one starts from a state that depends on the wall clock.)
fn wait_settled(sim: &BoardSim) {
    let t0 = Instant::now();
    let mut last = sim.state().unwrap().ticks;
    loop {
        std::thread::sleep(Duration::from_millis(100));
        let now = sim.state().unwrap().ticks;
        if now == last {
            return;
        }
        last = now;
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "the motors never settle"
        );
    }
}

fn edges_log(path: &std::path::Path, axes: usize) -> (Vec<u64>, Vec<Vec<u64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut go = Vec::new();
    let mut rises = vec![Vec::new(); axes];
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["#", "go", c] => go.push(c.parse().unwrap()),
            [a, c] => rises[a.parse::<usize>().unwrap()].push(c.parse().unwrap()),
            _ => panic!("bad edge line {line:?}"),
        }
    }
    (go, rises)
}

#[test]
fn two_axis_move_over_the_pty_is_exact() {
    if !tools_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("edges.txt");
    let sim = start(2, Vec::new(), Some(log.clone()));
    // the generated code's shape is known for this Verilator (posedge's unit tests)
    let version = std::process::Command::new("verilator")
        .arg("--version")
        .output()
        .unwrap();
    if String::from_utf8_lossy(&version.stdout).starts_with("Verilator 5.006 ") {
        assert!(
            sim.direct,
            "Verilator 5.006's model is run by eval, not directly"
        );
    }
    // the model was built with its training run's profile (unless turned off)
    if std::env::var_os("MULTISTEP_HIL_PGO").is_none() {
        assert!(
            sim.trained,
            "the model's profile-guided build fell back to a plain one"
        );
    }
    let p = sim.board.core.clone();
    let mut l = link(&sim, 2000);
    assert_eq!(
        l.build_id().unwrap(),
        BuildId::of(&p, sim.board.baud).unwrap()
    );
    let clock = IntClock::hz(p.clock_hz as u64);
    let trap = IntProfile::limits(
        &IntLimitsMove {
            steps: 1500,
            vmax: 40_000,
            amax: 2_000_000,
            start_speed: 0,
            end_speed: 0,
        },
        clock,
    )
    .unwrap();
    let chain = IntProfile::segments(
        &[
            IntSegment {
                v0: 10_000,
                ticks: 500_000,
                steps: 100,
            },
            IntSegment {
                v0: 10_000,
                ticks: 500_000,
                steps: 150,
            },
            IntSegment {
                v0: 20_000,
                ticks: 500_000,
                steps: 200,
            },
        ],
        clock,
    )
    .unwrap();
    let m0 = AxisMove::from_profile(&trap, true, &p).unwrap();
    let m1 = AxisMove::from_profile(&chain, false, &p).unwrap();
    let mut w = move_writes(&p, 0, &m0, 0).unwrap();
    w.extend(move_writes(&p, 1, &m1, 0).unwrap());
    w.push(start_write(0b11));
    l.write_all(&w).unwrap();
    wait_idle(&mut l);
    let pos = |l: &mut HostLink<Port>, a| l.read(Reg::Axis(a, AxisReg::Position)).unwrap() as i32;
    assert_eq!(pos(&mut l, 0), 1500);
    assert_eq!(pos(&mut l, 1), -450);
    // every rise is in the log once the host has read a reply, while board-sim still runs
    let (go, rises) = edges_log(&log, 2);
    assert_eq!(go.len(), 1, "one group start");
    for (a, prof) in [trap, chain].into_iter().enumerate() {
        let want: Vec<u64> = IntEdgeGenerator::new(prof)
            .map(|t| go[0] + t + TICK0)
            .collect();
        assert_eq!(rises[a].len(), want.len(), "axis {a}: rises");
        assert_eq!(rises[a], want, "axis {a}: every rise at go + t + 1");
    }
    sim.quit().unwrap();
}

/// 0.5 ms at 50 MHz.
const DEBOUNCE: u32 = 25_000;

#[test]
fn hall_pass_latches_the_sensor_position_and_short_glitches_are_rejected() {
    if !tools_present() {
        return;
    }
    // the window [1200, 1600) forward; glitches up to 0.2 ms (a debounce is 0.5 ms)
    let sensor = SensorOptions {
        sensor_at: 1200,
        sensor_width: 400,
        home_dir: 1,
        glitch_rate: 200.0,
        glitch_max: 0.0002,
        glitch_gap: 0.001,
        seed: 7,
        ..SensorOptions::default()
    };
    let sim = start(2, vec![sensor], None);
    let p = sim.board.core.clone();
    let mut l = link(&sim, 2000);
    l.write(Reg::Board(BoardReg::Debounce), DEBOUNCE).unwrap();
    l.write(Reg::Board(BoardReg::Enable), 0b11).unwrap();
    // an injected glitch at rest, half a debounce long: never accepted
    for _ in 0..3 {
        sim.glitch(0).unwrap();
        std::thread::sleep(Duration::from_millis(50));
        let st = l.axis_state(0).unwrap();
        assert!(!st.hall && !st.hall_flag, "a short glitch is not accepted");
    }
    // a constant-speed pass: 16 000 microsteps/s after a 20 ms ramp
    let v = 16_000u64;
    let clock = IntClock::hz(p.clock_hz as u64);
    let trap = IntProfile::limits(
        &IntLimitsMove {
            steps: 2400,
            vmax: v,
            amax: 800_000,
            start_speed: 0,
            end_speed: 0,
        },
        clock,
    )
    .unwrap();
    let m = AxisMove::from_profile(&trap, true, &p).unwrap();
    let mut w = move_writes(&p, 0, &m, 0).unwrap();
    w.push(start_write(0b1));
    l.write_all(&w).unwrap();
    wait_idle(&mut l);
    wait_settled(&sim);
    let st = l.axis_state(0).unwrap();
    assert!(st.hall_flag, "the pass was seen");
    assert!(!st.hall, "past the window at the end");
    let hp = l.read(Reg::Axis(0, AxisReg::HallPosition)).unwrap() as i32 as f64;
    // the count where the accepted level began: the sensor edge plus the steps the command
    // leads the rotor by (its lag)
    let lag = hp - 1200.0;
    // glitches come at random simulated times: one next to the sensor edge moves the
    // level's start by up to its length (0.2 ms, 3.2 steps at v); a dropout less than a
    // debounce time after the edge starts the level again after it
    let glitch_steps = v as f64 * 0.0002;
    let debounce_steps = v as f64 * f64::from(DEBOUNCE) / p.clock_hz;
    assert!(
        (-1.0 - glitch_steps..=32.0 + glitch_steps + debounce_steps).contains(&lag),
        "HallPosition {hp}: lag {lag} microsteps"
    );
    let s = sim.state().unwrap();
    let a = &s.axes[0];
    assert_eq!(a.step_rises, 2400);
    assert_eq!(a.commanded, 2400);
    assert!(
        (a.position - 2400.0).abs() < 8.0,
        "the rotor settles at the command: {}",
        a.position
    );
    // back to 0, the mechanics slip 64 microsteps ahead (a lost step seen from the load),
    // and the same pass again: the sensor comes 64 steps early
    let back = AxisMove::from_profile(&trap, false, &p).unwrap();
    let mut w = move_writes(&p, 0, &back, 0).unwrap();
    w.push(start_write(0b1));
    l.write_all(&w).unwrap();
    wait_idle(&mut l);
    assert_eq!(l.read(Reg::Axis(0, AxisReg::Position)).unwrap(), 0);
    wait_settled(&sim);
    sim.slip(0, 64).unwrap();
    let mut w = move_writes(&p, 0, &m, 0).unwrap();
    w.push(start_write(0b1));
    l.write_all(&w).unwrap();
    wait_idle(&mut l);
    let hp2 = l.read(Reg::Axis(0, AxisReg::HallPosition)).unwrap() as i32 as f64;
    assert!(
        (hp - 64.0 - hp2).abs() <= 2.0 + 2.0 * glitch_steps,
        "after a 64-step slip the Hall edge comes at {hp2}, first at {hp}"
    );
    let a = &sim.state().unwrap().axes[0];
    assert_eq!(a.step_rises, 3 * 2400);
    assert!((a.position - 2400.0 - 64.0).abs() < 8.0, "{}", a.position);
    sim.quit().unwrap();
}

#[test]
fn estop_reset_and_a_cut_link() {
    if !tools_present() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("edges.txt");
    let sim = start(2, Vec::new(), Some(log.clone()));
    let p = sim.board.core.clone();
    let mut l = link(&sim, 1000);
    // the host's session token is kept until a reset clears it; the registers return
    // to their defaults
    assert_eq!(
        l.claim(0x5EED_0001).unwrap(),
        0,
        "a fresh board has no session"
    );
    assert_eq!(l.claim(0x5EED_0002).unwrap(), 0x5EED_0001);
    l.write(Reg::Board(BoardReg::Enable), 0b11).unwrap();
    sim.reset().unwrap();
    // controls are taken in order: once state answers, the reset pulse has begun (bytes
    // sent while the board is in reset are lost, as on the board)
    sim.state().unwrap();
    std::thread::sleep(Duration::from_millis(50));
    let s2 = l.read(Reg::Board(BoardReg::Session)).unwrap();
    assert_eq!(s2, 0, "the reset cleared the session");
    assert_eq!(l.read(Reg::Board(BoardReg::Enable)).unwrap(), 0);
    // a cut link: reads time out (each sent again, then given up); restored, they
    // answer again
    sim.cut().unwrap();
    assert!(matches!(
        l.read(Reg::Board(BoardReg::Id)),
        Err(LinkError::Timeout(_))
    ));
    sim.restore().unwrap();
    std::thread::sleep(Duration::from_millis(20));
    assert_eq!(l.read(Reg::Board(BoardReg::Id)).unwrap() >> 16, 0x4D53);
    // the e-stop pin mid-move: STEP stops at once and the board reads back latched
    let clock = IntClock::hz(p.clock_hz as u64);
    let long = IntProfile::segments(
        &[IntSegment {
            v0: 50_000,
            ticks: 50_000_000,
            steps: 50_000,
        }],
        clock,
    )
    .unwrap();
    let m = AxisMove::from_profile(&long, true, &p);
    let m = match m {
        Ok(m) => m,
        Err(_) => {
            // longer than a piece: a 0.2 s cruise instead
            let short = IntProfile::segments(
                &[IntSegment {
                    v0: 50_000,
                    ticks: 10_000_000,
                    steps: 10_000,
                }],
                clock,
            )
            .unwrap();
            AxisMove::from_profile(&short, true, &p).unwrap()
        }
    };
    let mut w = move_writes(&p, 1, &m, 0).unwrap();
    w.push(start_write(0b10));
    l.write_all(&w).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    sim.estop(true).unwrap();
    let at = sim.state().unwrap();
    std::thread::sleep(Duration::from_millis(50));
    let st = l.axis_state(1).unwrap();
    assert!(st.estopped && !st.busy, "{st:?}");
    let status = l.read(Reg::Board(BoardReg::Status)).unwrap();
    let estop =
        multistep_hdl::link::status_bits::ESTOP | multistep_hdl::link::status_bits::ESTOP_INPUT;
    assert_eq!(status & estop, estop, "latched and the input active");
    assert_eq!(l.read(Reg::Board(BoardReg::Estop)).unwrap(), 1);
    let after = sim.state().unwrap();
    assert_eq!(
        after.axes[1].step_rises, at.axes[1].step_rises,
        "no STEP after the e-stop"
    );
    assert!(at.axes[1].step_rises > 0 && at.axes[1].step_rises < m.edges().len() as u64);
    sim.estop(false).unwrap();
    l.write(Reg::Board(BoardReg::Estop), 0).unwrap();
    assert_eq!(l.read(Reg::Board(BoardReg::Estop)).unwrap(), 0);
    sim.quit().unwrap();
    let (_, rises) = edges_log(&log, 2);
    assert!(
        rises[1].iter().all(|&c| c <= at.ticks),
        "every rise before the e-stop"
    );
}

#[test]
fn icebreaker_at_its_own_clock_baud_and_widths() {
    if !tools_present() {
        return;
    }
    // 18 MHz, 1 Mbaud, 48-bit radicand, 26-bit kernels, FIFO depth 2, radix 2
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("edges.txt");
    let sim = start_board("icebreaker", 2, Vec::new(), Some(log.clone()));
    let p = sim.board.core.clone();
    assert_eq!(p.clock_hz, 18e6);
    let mut l = link(&sim, 2000);
    assert_eq!(
        l.build_id().unwrap(),
        BuildId::of(&p, sim.board.baud).unwrap()
    );
    let hz = p.clock_hz as u64;
    let ms = |t: u64| t * hz / 1000;
    let profs: Vec<IntProfile> = [(800, 2, 6, 2), (2000, 20, 30, 20)]
        .into_iter()
        .map(|(steps, a, c, d)| {
            IntProfile::phase(
                &IntPhaseMove {
                    steps,
                    accel_ticks: ms(a),
                    cruise_ticks: ms(c),
                    decel_ticks: ms(d),
                    start_speed: 0,
                    end_speed: 0,
                },
                IntClock::hz(hz),
            )
            .unwrap()
        })
        .collect();
    let mut w = Vec::new();
    for (a, prof) in profs.iter().enumerate() {
        let m = AxisMove::from_profile(prof, a == 0, &p).unwrap();
        w.extend(move_writes(&p, a as u32, &m, 0).unwrap());
    }
    w.push(start_write(0b11));
    l.write_all(&w).unwrap();
    wait_idle(&mut l);
    assert_eq!(l.read(Reg::Axis(0, AxisReg::Position)).unwrap() as i32, 800);
    assert_eq!(
        l.read(Reg::Axis(1, AxisReg::Position)).unwrap() as i32,
        -2000
    );
    sim.quit().unwrap();
    let (go, rises) = edges_log(&log, 2);
    assert_eq!(go.len(), 1);
    for (a, prof) in profs.into_iter().enumerate() {
        let want: Vec<u64> = IntEdgeGenerator::new(prof)
            .map(|t| go[0] + t + TICK0)
            .collect();
        assert_eq!(rises[a], want, "axis {a}: every rise at go + t + 1");
    }
}
