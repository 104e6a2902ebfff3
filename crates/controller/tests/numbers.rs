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
