//! `estop` and `stop` do not queue behind slow work on the board: asked for while four
//! previews of a long group are being timed, they are applied before any preview is done.
//! The order is checked with events, not clocks.

use multistep_controller::config::{AxisConfig, BoardConfig, BoardSection};
use multistep_controller::protocol::{Amount, MoveOpts};
use multistep_controller::{AxisSettings, AxisState, Controller, CtlError};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Barrier};

const PREVIEWS: usize = 4;

fn config() -> BoardConfig {
    let axis = |name: &str| AxisConfig {
        name: name.into(),
        settings: AxisSettings {
            vmax: 20_000.0,
            amax: 100_000.0,
            ..AxisSettings::default()
        },
    };
    BoardConfig {
        board: BoardSection {
            name: "h".into(),
            clock_hz: 50e6,
            fifo_depth: 4,
            link: None,
            sync_line: None,
        },
        axes: vec![axis("X"), axis("Y"), axis("Z")],
        alpaca: None,
    }
}

/// A group whose TDM timing takes a while: tens of milliseconds in the test profile,
/// against the microseconds a halt takes.
fn long_group() -> Vec<(String, Amount)> {
    vec![
        ("X".to_string(), Amount::Steps(3_000_000)),
        ("Y".to_string(), Amount::Steps(2_250_000)),
    ]
}

/// Starts `PREVIEWS` previews of a long group, runs `halt` once every preview thread has
/// started, and returns how many previews had been timed when `halt` returned. A preview
/// that asks after an e-stop is refused at once; at least one must have been timed across
/// the halt.
fn previews_done_when(ctl: &Arc<Controller>, halt: impl FnOnce()) -> usize {
    let go = Arc::new(Barrier::new(PREVIEWS + 1));
    let (started, done) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
    let threads: Vec<_> = (0..PREVIEWS)
        .map(|_| {
            let (ctl, go) = (ctl.clone(), go.clone());
            let (started, done) = (started.clone(), done.clone());
            std::thread::spawn(move || {
                go.wait();
                started.fetch_add(1, Ordering::SeqCst);
                let p = ctl.preview(&long_group(), false, false, &MoveOpts::default());
                if p.is_ok() {
                    done.fetch_add(1, Ordering::SeqCst);
                }
                p.map(|axes| axes.len())
            })
        })
        .collect();
    go.wait();
    while started.load(Ordering::SeqCst) < PREVIEWS {
        std::thread::yield_now();
    }
    halt();
    let when = done.load(Ordering::SeqCst);
    let mut timed = 0;
    for t in threads {
        match t.join().unwrap() {
            Ok(n) => {
                assert_eq!(n, 2);
                timed += 1;
            }
            Err(e) => assert!(matches!(e, CtlError::EStopped), "{e}"),
        }
    }
    assert!(timed > 0, "no preview was under way");
    when
}

/// A board whose axis Z tracks at 5000 steps/s.
fn open_tracking(dir: &std::path::Path) -> Arc<Controller> {
    let ctl = Arc::new(Controller::open(&config(), dir, 1.0).unwrap());
    let r = ctl.execute_bytes(b"track Z 5000");
    assert!(r.result.is_ok(), "{}", r.to_text());
    ctl
}

fn state(ctl: &Controller, axis: &str) -> AxisState {
    ctl.status(&[axis.to_string()]).unwrap()[0].state
}

#[test]
fn an_estop_is_applied_before_any_preview_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = open_tracking(dir.path());
    let done = previews_done_when(&ctl, || ctl.estop());
    assert_eq!(done, 0, "the estop waited for {done} previews");
    assert!(ctl.with_board(|b, _| b.is_estopped()));
    assert_eq!(state(&ctl, "Z"), AxisState::Fault);
}

#[test]
fn a_stop_is_applied_before_any_preview_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = open_tracking(dir.path());
    let done = previews_done_when(&ctl, || ctl.stop(Some("Z")).unwrap());
    assert_eq!(done, 0, "the stop waited for {done} previews");
    // Stopping, or already at rest: the ramp from 5000 steps/s takes 12.5 ms.
    let s = &ctl.status(&["Z".to_string()]).unwrap()[0];
    assert!(s.rate.is_none_or(|r| r == 0.0), "{s:?}");
}

#[test]
fn a_stop_of_an_unknown_axis_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = open_tracking(dir.path());
    assert!(ctl.stop(Some("Q")).is_err());
    assert_eq!(state(&ctl, "Z"), AxisState::Tracking);
}

/// Board ticks of `ms` milliseconds at the config's 50 MHz.
fn ticks(ms: u64) -> u64 {
    ms * 50_000
}

/// Z's status once the board's clock has passed `tick` (it advances on every status).
fn z_after(ctl: &Controller, tick: u64) -> multistep_controller::AxisStatus {
    let end = std::time::Instant::now() + std::time::Duration::from_secs(60);
    loop {
        let (now, s) = ctl.with_board(|b, now| {
            let s = b.status(&["Z".to_string()], now).unwrap().remove(0);
            (b.now(), s)
        });
        if now >= tick {
            return s;
        }
        assert!(
            std::time::Instant::now() < end,
            "the board clock stands at {now}"
        );
        std::thread::yield_now();
    }
}

/// Z's first position past `position`, as the board's clock runs on.
fn z_stepped_past(ctl: &Controller, position: i64) -> i64 {
    let end = std::time::Instant::now() + std::time::Duration::from_secs(60);
    loop {
        let now = ctl.now();
        let s = z_after(ctl, now + ticks(1));
        if s.position > position {
            return s.position;
        }
        assert!(std::time::Instant::now() < end, "Z stays at {}", s.position);
    }
}

/// Under the previews' load, the e-stop holds at the tick it was asked at: no step of
/// the tracking axis after it, neither counted nor on the simulated motor, while the
/// board's clock runs on for 50 ms.
#[test]
fn no_axis_steps_after_the_estop_tick() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = open_tracking(dir.path());
    let moving = z_after(&ctl, ctl.now() + ticks(20));
    assert!(moving.speed > 0.0, "{moving:?}");
    // Precondition: Z steps on past `moving` before the e-stop (on a loaded machine the
    // e-stop could otherwise come before its next step, and prove nothing).
    let stepped = z_stepped_past(&ctl, moving.position);
    let before = ctl.now();
    previews_done_when(&ctl, || ctl.estop());
    let after = ctl.now();
    let s = z_after(&ctl, 0);
    let latched = s.move_end.expect("halted at a tick");
    assert!(
        (before..=after).contains(&latched),
        "{before} ≤ {latched} ≤ {after}"
    );
    let later = z_after(&ctl, after + ticks(50));
    assert_eq!(
        (later.position, later.sim_position, later.move_end),
        (s.position, s.sim_position, Some(latched)),
        "Z stepped after the e-stop"
    );
    assert!(
        s.position >= stepped && stepped > moving.position,
        "Z moved until the e-stop: {} then {stepped} then {}",
        moving.position,
        s.position
    );
}
