//! The mount on a simulated board: the rates its axes track at, pulses, slews and the
//! parked state across a reopening of the board.

use super::*;
use crate::config::BoardConfig;
use std::time::{Duration, Instant};

const BOARD: &str = "[[axis]]\nname = \"ha\"\nvmax = 40000.0\namax = 80000.0\n\
                     [[axis]]\nname = \"dec\"\nvmax = 40000.0\namax = 80000.0\n";

fn mount(extra: &str, dir: &std::path::Path) -> (Arc<Controller>, Mount) {
    let board = BoardConfig::parse(BOARD).unwrap();
    let cfg: MountConfig = toml::from_str(&format!(
        "ra_axis = \"ha\"\nra_steps_per_rev = 1296000\nlatitude = 50.0\nlongitude = 5.0\n{extra}"
    ))
    .unwrap();
    cfg.validate(&board).unwrap();
    let ctl = Arc::new(Controller::open(&board, dir, 1.0).unwrap());
    let m = Mount::open(cfg, &ctl).unwrap();
    (ctl, m)
}

/// Polls (ticking the mount) until `cond` holds; a generous deadline.
fn until(ctl: &Controller, m: &Mount, what: &str, mut cond: impl FnMut(&[AxisStatus]) -> bool) {
    let end = Instant::now() + Duration::from_secs(60);
    loop {
        m.tick(ctl).unwrap();
        let s = m.axes_status(ctl).unwrap();
        if cond(&s) {
            return;
        }
        assert!(Instant::now() < end, "{what}: {s:?}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn a_coelostat_turns_its_mirror_at_half_the_drive_rate() {
    let tmp = tempfile::tempdir().unwrap();
    let (ctl, m) = mount("mount = \"coelostat\"\ncoelostat_dec = -12.5\n", tmp.path());
    m.set_tracking(&ctl, true).unwrap();
    // One step per arcsecond of the axis: half of 15.041067″/s.
    let half = 15.041_067 / 2.0;
    until(&ctl, &m, "half sidereal", |s| {
        (s[0].speed - half).abs() < 1e-9
    });
    m.set_drive_rate(&ctl, DriveRate::Solar).unwrap();
    until(&ctl, &m, "half solar", |s| (s[0].speed - 7.5).abs() < 1e-9);
    // West: hour angle grows faster; the guide rate (half sidereal, to 1e-6″/s) adds
    // half of itself.
    m.pulse(&ctl, 3, 5_000).unwrap();
    let want = 7.5 + 15.041_067 / 4.0;
    until(&ctl, &m, "west pulse", |s| (s[0].speed - want).abs() < 1e-6);
    assert!(m.is_pulse_guiding());
    until(&ctl, &m, "pulse ends", |s| {
        !m.is_pulse_guiding() && (s[0].speed - 7.5).abs() < 1e-9
    });
    assert!(matches!(m.pulse(&ctl, 0, 10), Err(MountError::Invalid(_))));
    let p = m.pointing(&ctl).unwrap();
    assert_eq!((p.dec, p.side), (-12.5, PierSide::Unknown));
    // The declination is the mirror's, set by hand.
    assert!(matches!(
        m.slew(&ctl, p.ra, 0.0),
        Err(MountError::Invalid(_))
    ));
    m.set_tracking(&ctl, false).unwrap();
    until(&ctl, &m, "at rest", |s| s[0].state == AxisState::Idle);
}

#[test]
fn a_fork_slews_to_its_target_and_stays_parked_when_reopened() {
    let tmp = tempfile::tempdir().unwrap();
    let fork = "mount = \"fork\"\ndec_axis = \"dec\"\ndec_steps_per_rev = 1296000\n";
    {
        let (ctl, m) = mount(fork, tmp.path());
        m.set_tracking(&ctl, true).unwrap();
        let lst = m.sidereal_time();
        let ra = (lst - 1.0).rem_euclid(24.0); // HA +15°
        m.slew(&ctl, ra, 30.0).unwrap();
        assert!(m.slewing());
        until(&ctl, &m, "slew and catch-up end", |s| {
            s.iter().all(|a| a.state != AxisState::Moving)
        });
        until(&ctl, &m, "tracking again", |s| {
            s[0].state == AxisState::Tracking
        });
        let p = m.pointing(&ctl).unwrap();
        assert!((p.dec - 30.0).abs() < 1.0 / 3600.0, "{p:?}");
        assert!(((p.ra - ra + 12.0).rem_euclid(24.0) - 12.0).abs() * 54_000.0 < 10.0);
        assert!(!m.slewing());
        m.park(&ctl).unwrap();
        until(&ctl, &m, "parked", |_| m.at_park());
        let s = m.axes_status(&ctl).unwrap();
        assert_eq!((s[0].position, s[1].position), (0, 0));
        assert!(matches!(
            m.set_tracking(&ctl, true),
            Err(MountError::Parked)
        ));
    }
    let (ctl, m) = mount(fork, tmp.path());
    assert!(m.at_park());
    m.unpark(&ctl).unwrap();
    assert!(!m.at_park());
    drop((ctl, m));
    let (_ctl, m) = mount(fork, tmp.path());
    assert!(!m.at_park());
}

#[test]
fn slews_and_parks_end_approaching_from_one_side_by_the_backlash() {
    let tmp = tempfile::tempdir().unwrap();
    let (ctl, m) = mount(
        "dec_axis = \"dec\"\ndec_steps_per_rev = 1296000\nra_backlash = 2000\ndec_backlash = 1000\n",
        tmp.path(),
    );
    m.set_tracking(&ctl, true).unwrap();
    // From the home pose (counts 0, 0) to HA +30°, Dec 20° (pier east): the polar axis
    // runs down to −60°, the dec axis up to 70°.
    let mut low = [i64::MAX; 2];
    let slew = |ha: f64, dec: f64, low: &mut [i64; 2]| {
        *low = [i64::MAX; 2];
        let ra = (m.sidereal_time() - ha / 15.0).rem_euclid(24.0);
        m.slew(&ctl, ra, dec).unwrap();
        until(&ctl, &m, "slew ends", |s| {
            for k in 0..2 {
                low[k] = low[k].min(s[k].position);
            }
            !m.slewing()
        });
        let s = m.axes_status(&ctl).unwrap();
        [s[0].position, s[1].position]
    };
    let end = slew(30.0, 20.0, &mut low);
    // One step is 1″: the polar axis went below its end by more than half its backlash,
    // then came up to it (and tracks on up); the dec axis came up to 70° directly.
    assert!(low[0] < end[0] - 1000, "{low:?} {end:?}");
    assert_eq!(end[1], 70 * 3600);
    assert!(low[1] >= 0);
    // Back up the sky to Dec 60° (dec axis 30°): it overshoots below and comes up.
    let end = slew(30.0, 60.0, &mut low);
    assert_eq!(end[1], 30 * 3600);
    assert!(low[1] < end[1] - 500, "{low:?} {end:?}");
    // Park (home counts) from above on the dec axis: also ends coming up.
    m.park(&ctl).unwrap();
    let mut min_dec = i64::MAX;
    until(&ctl, &m, "parked", |s| {
        min_dec = min_dec.min(s[1].position);
        m.at_park()
    });
    let s = m.axes_status(&ctl).unwrap();
    assert_eq!((s[0].position, s[1].position), (0, 0));
    assert!(min_dec < -500, "{min_dec}");
}
