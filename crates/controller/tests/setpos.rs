//! `setpos AXIS N`: an idle axis's position is renamed without moving, stored like any
//! position, refused while the axis moves, and read back through the client's words.

use multistep_controller::protocol::{parse, Amount, Command};
use multistep_controller::{AxisStatus, BoardConfig, Controller};
use std::time::{Duration, Instant};

fn answer(ctl: &Controller, line: &str) -> String {
    ctl.execute_bytes(line.as_bytes()).to_text()
}

fn status(ctl: &Controller) -> AxisStatus {
    ctl.status(&["X".to_string()]).unwrap().remove(0)
}

fn wait_idle(ctl: &Controller) -> AxisStatus {
    let end = Instant::now() + Duration::from_secs(60);
    loop {
        let s = status(ctl);
        if s.target.is_none() {
            return s;
        }
        assert!(Instant::now() < end, "still moving: {s:?}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn setpos_renames_an_idle_axis_without_moving_and_is_stored() {
    let dir = tempfile::tempdir().unwrap();
    let trusted = {
        let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
        let before = status(&ctl);
        assert_eq!(answer(&ctl, "setpos X 5000"), "X pos=5000\nok\n");
        let s = status(&ctl);
        assert_eq!((s.position, s.target, s.homed), (5000, None, false));
        // the mechanics did not move: the simulated place shifts with the name
        assert_eq!(
            s.sim_position - s.position,
            before.sim_position - before.position
        );
        // a move from there ends where the new numbers say, with no step lost
        assert_eq!(answer(&ctl, "move X 100"), "X target=5100\nok\n");
        let s = wait_idle(&ctl);
        assert_eq!(s.position, 5100);
        assert_eq!(
            s.sim_position - s.position,
            before.sim_position - before.position
        );
        s.trusted
    };
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    let s = status(&ctl);
    assert_eq!((s.position, s.trusted), (5100, trusted));
}

#[test]
fn setpos_is_refused_while_moving_outside_the_limits_and_with_bad_words() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    assert!(answer(&ctl, "move X 1000000").ends_with("ok\n"));
    let busy = answer(&ctl, "setpos X 0");
    assert!(busy.starts_with("error:6 axis X is moving"), "{busy}");
    assert_eq!(answer(&ctl, "stop X"), "ok\n");
    let at = wait_idle(&ctl).position;

    assert_eq!(answer(&ctl, "set X soft_max 2000"), "ok\n");
    let out = answer(&ctl, "setpos X 2001");
    assert!(out.starts_with("error:5 "), "{out}");
    for bad in ["setpos X", "setpos X 1 2", "setpos X many", "setpos"] {
        let out = answer(&ctl, bad);
        assert!(out.starts_with("error:"), "{bad}: {out}");
    }
    assert_eq!(status(&ctl).position, at);

    // a periodic axis reads the new position modulo its period
    assert_eq!(answer(&ctl, "set X soft_max none"), "ok\n");
    assert_eq!(answer(&ctl, "set X period 1000"), "ok\n");
    assert_eq!(answer(&ctl, "setpos X -2300"), "X pos=700\nok\n");
    assert_eq!(status(&ctl).position, 700);
}

#[test]
fn setpos_reads_back_as_written() {
    for (line, to) in [
        ("setpos X -12", Amount::Steps(-12)),
        ("setpos 0 2.5u", Amount::Units(2.5)),
    ] {
        let c = parse(line).unwrap();
        assert!(
            matches!(&c, Command::SetPos { to: t, .. } if *t == to),
            "{c:?}"
        );
        assert_eq!(c.to_string(), line);
    }
}
