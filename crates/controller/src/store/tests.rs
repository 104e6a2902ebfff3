use super::*;
use multistep_core::MoveParams;

#[test]
fn records_survive_reopening() {
    let dir = tempfile::tempdir().unwrap();
    let rec = AxisRecord {
        position: -1234,
        homed: true,
        trusted: true,
        moving: Some(MovingMarker {
            from: 1,
            target: 2,
            homing: false,
        }),
        sim_position: 5,
        slack: 3,
    };
    {
        let s = Store::open(dir.path()).unwrap();
        s.put_axis("X", &rec).unwrap();
        let set = AxisSettings {
            vmax: 1234.5,
            ..AxisSettings::default()
        };
        s.put_settings("X", &set).unwrap();
        s.put_preset(
            "fast",
            &MoveOpts {
                params: MoveParams {
                    vmax: Some(9.0),
                    ..MoveParams::default()
                },
                ..Default::default()
            },
        )
        .unwrap();
        s.put_named("line", &NamedPosition::from([("X".to_string(), 7)]))
            .unwrap();
    }
    let s = Store::open(dir.path()).unwrap();
    assert_eq!(s.axis("X").unwrap(), Some(rec));
    assert_eq!(s.axis("Y").unwrap(), None);
    assert_eq!(s.settings("X").unwrap().unwrap().vmax, 1234.5);
    assert_eq!(s.preset("fast").unwrap().unwrap().params.vmax, Some(9.0));
    assert_eq!(s.named_position("line").unwrap().unwrap()["X"], 7);
    assert!(s.forget_named("line").unwrap());
    assert!(s.named().unwrap().is_empty());
}

#[test]
fn the_link_session_survives_reopening() {
    let dir = tempfile::tempdir().unwrap();
    let kept = LinkSession {
        token: 0xDEAD_BEEF,
        offsets: vec![0, -3600],
        streamed: 0b10,
        armed: 0b01,
        folding: None,
        rolled: 0b10,
    };
    {
        let s = Store::open(dir.path()).unwrap();
        assert_eq!(s.link_session().unwrap(), None, "a new board has none");
        s.put_link_session(&kept).unwrap();
    }
    let s = Store::open(dir.path()).unwrap();
    assert_eq!(s.link_session().unwrap(), Some(kept));
}

#[test]
fn presets_stored_field_by_field_still_load() {
    // The JSON of a preset as stored before the values had one definition in the core.
    let old = r#"{"preset":null,"profile":"scurve","vmax":9.5,"amax":100.0,"jmax":null,"smax":null,"accel_time":null,"cruise_time":null,"decel_time":null,"start_speed":null,"end_speed":2.0,"rho":null,"phi":0.25,"psi":null}"#;
    let dir = tempfile::tempdir().unwrap();
    let s = Store::open(dir.path()).unwrap();
    let raw: serde_json::Value = serde_json::from_str(old).unwrap();
    s.put(PRESETS, "old", &raw).unwrap();
    let want = MoveOpts {
        preset: None,
        profile: Some("scurve".into()),
        params: MoveParams {
            vmax: Some(9.5),
            amax: Some(100.0),
            end_speed: Some(2.0),
            phi: Some(0.25),
            ..MoveParams::default()
        },
    };
    assert_eq!(s.preset("old").unwrap(), Some(want.clone()));
    // Written now, it reads back, and its keys are the old ones.
    s.put_preset("new", &want).unwrap();
    assert_eq!(s.preset("new").unwrap(), Some(want.clone()));
    let written: serde_json::Value =
        serde_json::from_str(&serde_json::to_string(&want).unwrap()).unwrap();
    assert_eq!(written, raw);
    // A key no version knows is still refused.
    let bad = r#"{"vmax":1.0,"vmx":2.0}"#;
    assert!(serde_json::from_str::<MoveOpts>(bad).is_err());
}

#[test]
fn a_file_that_is_not_a_database_is_damaged_and_a_reset_moves_it_aside() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(DB_FILE);
    std::fs::write(&path, "hello world garbage").unwrap();
    let msg = Store::open(dir.path()).err().unwrap().to_string();
    assert!(
        msg.contains("is damaged") && msg.contains("--reset-damaged-data"),
        "{msg}"
    );
    assert_eq!(std::fs::read(&path).unwrap(), b"hello world garbage");
    let (s, aside) = Store::open_or_reset(dir.path(), true).unwrap();
    assert_eq!(
        std::fs::read(aside.unwrap()).unwrap(),
        b"hello world garbage"
    );
    assert!(s.presets().unwrap().is_empty());
    assert_eq!(s.axis("X").unwrap(), None);
}

#[test]
fn health_sees_a_deleted_file_within_its_check_period_and_a_write_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let s = Store::open(dir.path()).unwrap();
    assert_eq!(s.check(), StoreHealth::Ok);
    std::fs::remove_file(dir.path().join("board.redb")).unwrap();
    // one check period later the file is looked at again
    std::thread::sleep(HEALTH_CHECK_PERIOD + Duration::from_millis(10));
    assert!(matches!(s.check(), StoreHealth::Gone(_)), "{:?}", s.check());

    let dir = tempfile::tempdir().unwrap();
    let s = Store::open(dir.path()).unwrap();
    assert_eq!(s.check(), StoreHealth::Ok);
    std::fs::remove_file(dir.path().join("board.redb")).unwrap();
    // a write never trusts an earlier look
    assert!(s.put_named("p", &NamedPosition::new()).is_err());
    assert!(matches!(s.check(), StoreHealth::Gone(_)));
}
