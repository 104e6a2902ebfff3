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

/// The hour angle and declination the mount points at.
fn ha_dec_now(ctl: &Controller, m: &Mount) -> (f64, f64) {
    let p = m.pointing(ctl).unwrap();
    (p.ha, p.dec)
}

#[test]
fn an_alt_az_slew_ends_there_with_tracking_off_and_syncs_to_alt_az() {
    let tmp = tempfile::tempdir().unwrap();
    let (ctl, m) = mount(
        "dec_axis = \"dec\"\ndec_steps_per_rev = 1296000\nhorizon = 10.0\n",
        tmp.path(),
    );
    // Tracking on: refused (the point would not stay put in altitude and azimuth).
    m.set_tracking(&ctl, true).unwrap();
    assert!(matches!(
        m.slew_alt_az(&ctl, 40.0, 200.0),
        Err(MountError::NotNow(_))
    ));
    m.set_tracking(&ctl, false).unwrap();
    for (alt, az, says) in [
        (90.5, 10.0, "altitude"),
        (45.0, 360.0, "azimuth"),
        (45.0, -0.1, "azimuth"),
        (5.0, 180.0, "horizon"),
    ] {
        match m.slew_alt_az(&ctl, alt, az) {
            Err(MountError::Invalid(e)) => assert!(e.contains(says), "{alt} {az}: {e}"),
            r => panic!("{alt} {az}: {r:?}"),
        }
    }
    m.slew_alt_az(&ctl, 40.0, 200.0).unwrap();
    assert!(m.slewing());
    until(&ctl, &m, "alt-az slew ends", |s| {
        !m.slewing() && s.iter().all(|a| a.state == AxisState::Idle)
    });
    let p = m.pointing(&ctl).unwrap();
    // One step is 1″.
    assert!((p.alt - 40.0).abs() * 3600.0 < 2.0, "{p:?}");
    assert!((p.az - 200.0).abs() * 3600.0 < 4.0, "{p:?}");
    // West of the meridian: pier east.
    assert_eq!(p.side, PierSide::East);
    assert!(!m.tracking());
    // Sync to a point 0.5° higher: the axes stay, the reading moves.
    let before = m.axes_status(&ctl).unwrap()[0].position;
    m.sync_alt_az(&ctl, 40.5, 200.0).unwrap();
    let p = m.pointing(&ctl).unwrap();
    assert!(
        (p.alt - 40.5).abs() < 1e-9 && (p.az - 200.0).abs() < 1e-9,
        "{p:?}"
    );
    assert_eq!(m.axes_status(&ctl).unwrap()[0].position, before);
    assert!(matches!(
        m.sync_alt_az(&ctl, 91.0, 0.0),
        Err(MountError::Invalid(_))
    ));
}

#[test]
fn a_pier_flip_points_at_the_same_place_from_the_other_side_within_the_limit() {
    let tmp = tempfile::tempdir().unwrap();
    let (ctl, m) = mount(
        "dec_axis = \"dec\"\ndec_steps_per_rev = 1296000\nha_limit = 120.0\n",
        tmp.path(),
    );
    // HA 20° west: the counterweight side is east; from the west the polar axis turns
    // 110° from its centre (within 120°).
    m.set_tracking(&ctl, false).unwrap();
    let (lat, _, _) = m.site();
    let (alt, az) = coords::alt_az(20.0, 30.0, lat);
    m.slew_alt_az(&ctl, alt, az).unwrap();
    until(&ctl, &m, "slew ends", |_| !m.slewing());
    assert_eq!(m.pointing(&ctl).unwrap().side, PierSide::East);
    let before = ha_dec_now(&ctl, &m);
    // Already east: nothing moves.
    m.set_pier_side(&ctl, PierSide::East).unwrap();
    assert!(!m.slewing());
    m.set_pier_side(&ctl, PierSide::West).unwrap();
    assert!(m.slewing());
    until(&ctl, &m, "flip ends", |_| !m.slewing());
    let p = m.pointing(&ctl).unwrap();
    assert_eq!(p.side, PierSide::West);
    let s = m.axes_status(&ctl).unwrap();
    assert_eq!(s[0].position, 110 * 3600);
    assert!(
        (wrap(p.ha - before.0)).abs() * 3600.0 < 2.0,
        "{p:?} {before:?}"
    );
    assert!((p.dec - before.1).abs() * 3600.0 < 2.0, "{p:?} {before:?}");
    // At HA 40° the west side is 130° out: refused, nothing moves.
    let (alt, az) = coords::alt_az(40.0, 30.0, lat);
    m.set_pier_side(&ctl, PierSide::East).unwrap();
    until(&ctl, &m, "flip back ends", |_| !m.slewing());
    m.slew_alt_az(&ctl, alt, az).unwrap();
    until(&ctl, &m, "slew ends", |_| !m.slewing());
    match m.set_pier_side(&ctl, PierSide::West) {
        Err(MountError::Invalid(e)) => assert!(e.contains("ha_limit"), "{e}"),
        r => panic!("{r:?}"),
    }
    assert!(!m.slewing());
    assert!(matches!(
        m.set_pier_side(&ctl, PierSide::Unknown),
        Err(MountError::Invalid(_))
    ));
}

fn wrap(x: f64) -> f64 {
    coords::wrap180(x)
}

#[test]
fn a_fork_has_one_pier_side() {
    let tmp = tempfile::tempdir().unwrap();
    let (ctl, m) = mount(
        "mount = \"fork\"\ndec_axis = \"dec\"\ndec_steps_per_rev = 1296000\n",
        tmp.path(),
    );
    assert!(matches!(
        m.set_pier_side(&ctl, PierSide::West),
        Err(MountError::NotNow(_))
    ));
}

#[test]
fn sync_offsets_are_kept_across_a_reopening_and_utc_date_is_not() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = "dec_axis = \"dec\"\ndec_steps_per_rev = 1296000\n";
    let synced = {
        let (ctl, m) = mount(cfg, tmp.path());
        m.set_tracking(&ctl, true).unwrap();
        let lst = m.sidereal_time();
        let ra = (lst - 1.0).rem_euclid(24.0);
        m.sync(&ctl, ra, 40.0).unwrap();
        m.set_tracking(&ctl, false).unwrap();
        until(&ctl, &m, "at rest", |s| {
            s.iter().all(|a| a.state == AxisState::Idle)
        });
        // A clock set 2 h ahead: sidereal time runs 2 h (and 19.7 s) ahead.
        let host = m.sidereal_time();
        let later = time::iso8601(time::unix_now() + 7200.0);
        m.set_utc_date(&later).unwrap();
        let ahead = (m.sidereal_time() - host).rem_euclid(24.0);
        assert!(
            (ahead - 7200.0 * 1.002_737_909 / 3600.0).abs() < 1e-3,
            "{ahead}"
        );
        let read = time::parse_iso8601(&m.utc_date()).unwrap();
        assert!(
            (read - time::unix_now() - 7200.0).abs() < 1.0,
            "{}",
            m.utc_date()
        );
        assert!(matches!(
            m.set_utc_date("2026-01-01T00:00:00"),
            Err(MountError::Invalid(_))
        ));
        ha_dec_now(&ctl, &m)
    };
    let (ctl, m) = mount(cfg, tmp.path());
    // The host's clock again: the same hour angle, 2 h apart from the offset clock's.
    let (ha, dec) = ha_dec_now(&ctl, &m);
    assert!((dec - synced.1).abs() < 1e-9, "{dec} {synced:?}");
    assert!((wrap(ha - synced.0)).abs() < 1e-9, "{ha} {synced:?}");
    assert!((dec - 40.0).abs() < 1e-9, "{dec}");
    drop((ctl, m));
    // Another data directory: no offsets, the home pose looks at the pole.
    let other = tempfile::tempdir().unwrap();
    let (ctl, m) = mount(cfg, other.path());
    assert!((ha_dec_now(&ctl, &m).1 - 90.0).abs() < 1e-9);
}
