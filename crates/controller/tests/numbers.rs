//! Motor numbers: every axis answers to its 0-based number on the board wherever its name
//! is accepted, and `status` shows the number.

use multistep_controller::{service, BoardConfig, Controller};

fn session(lines: &[&str]) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    let input: String = lines.iter().map(|l| format!("{l}\n")).collect();
    let mut out = Vec::new();
    service::serve_stream(&ctl, input.as_bytes(), &mut out).unwrap();
    String::from_utf8(out)
        .unwrap()
        .lines()
        .map(String::from)
        .collect()
}

#[test]
fn numbers_name_axes_and_status_shows_them() {
    // the default board's axes are X, Y, Z, A
    let out = session(&[
        "status 2",
        "set 1 vmax 1234",
        "get Y vmax",
        "move 3 -5",
        "status A",
        "status 4",
        "status 01",
        "status -1",
    ]);
    let mut it = out.iter();
    let z = it.next().unwrap();
    assert!(z.starts_with("Z pos=0 ") && z.ends_with(" num=2"), "{z}");
    assert_eq!(it.next().unwrap(), "ok");
    assert_eq!(it.next().unwrap(), "ok", "set by number");
    let v = it.next().unwrap();
    assert!(v.contains("1234"), "the setting went to Y: {v}");
    assert_eq!(it.next().unwrap(), "ok");
    let mv = it.next().unwrap();
    assert!(mv.starts_with("ok") || mv.contains("-5"), "{mv}");
    if !mv.starts_with("ok") {
        assert_eq!(it.next().unwrap(), "ok");
    }
    let a = it.next().unwrap();
    assert!(
        a.starts_with("A ") && a.contains("target=-5") || a.contains("pos=-"),
        "{a}"
    );
    assert!(a.ends_with(" num=3"), "{a}");
    assert_eq!(it.next().unwrap(), "ok");
    for bad in ["4", "01", "-1"] {
        let e = it.next().unwrap();
        assert!(
            e.starts_with("error:4 ") && e.contains(&format!("'{bad}'")),
            "{e}"
        );
    }
    assert!(it.next().is_none());
}

#[test]
fn status_json_carries_the_number() {
    let out = session(&["status json"]);
    let v: serde_json::Value = serde_json::from_str(&out[0]).unwrap();
    let nums: Vec<u64> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["number"].as_u64().unwrap())
        .collect();
    assert_eq!(nums, [0, 1, 2, 3]);
    assert_eq!(v[3]["axis"], "A");
}

#[test]
fn tracking_by_number_and_one_error_per_bad_line() {
    let out = session(&[
        "rate constant 15041/324",
        "rate fast -2000",
        "rates",
        "track 0 constant",
        "status X",
        "track X abc",
        "track X 1e9",
        "track X 12/0",
        "track X",
        "track X 10 lease=100",
        "track X 10 speed=3",
        "rate slow abc",
        "track 9 100",
        "home 2",
        "track Z 100",
        "release X",
        "track 1 fast",
        "track Y 0",
        "release 3",
        "status A",
        "energize 3",
        "status A",
    ]);
    let replies: Vec<&[String]> = {
        let mut v = Vec::new();
        let mut start = 0;
        for (k, l) in out.iter().enumerate() {
            if l == "ok" || l.starts_with("error:") {
                v.push(&out[start..=k]);
                start = k + 1;
            }
        }
        assert_eq!(start, out.len(), "a reply without its status line");
        v
    };
    assert_eq!(replies.len(), 22, "{out:#?}");
    let status = |k: usize| replies[k].last().unwrap().as_str();
    assert_eq!(replies[2], ["constant 15041/324", "fast -2000", "ok"]);
    assert_eq!(replies[3][0], format!("0 rate={}", 15041.0 / 324.0));
    let x = &replies[4][0];
    assert!(
        x.contains("state=tracking") && x.contains("rate=46.42") && x.contains(" en=1 num=0"),
        "{x}"
    );
    for (k, code) in [
        (5, 8),
        (6, 14),
        (7, 3),
        (8, 3),
        (9, 3),
        (10, 3),
        (11, 3),
        (12, 4),
        (14, 6),
        (15, 6),
    ] {
        assert!(
            status(k).starts_with(&format!("error:{code} ")),
            "line {k}: {}",
            status(k)
        );
    }
    assert!(status(5).contains("unknown rate 'abc'"));
    assert!(status(6).contains("above vmax"));
    assert_eq!(replies[16][0], "1 rate=-2000");
    assert_eq!(
        replies[17],
        ["Y rate=0", "ok"],
        "a zero rate stops (or is a no-op)"
    );
    let a = &replies[19][0];
    assert!(a.contains(" trusted=0 ") && a.contains(" en=0 "), "{a}");
    assert!(replies[21][0].contains(" en=1 "), "{}", replies[21][0]);
}
