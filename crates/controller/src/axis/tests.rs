use super::*;
use crate::protocol::Reply;

/// The line as it was first written: one `format!` and a replace per field, then the
/// reply's replace of line breaks over the whole line.
fn reference(s: &AxisStatus) -> String {
    let opt = |o: Option<i64>| o.map_or("none".to_string(), |x| x.to_string());
    format!(
        "{} pos={} units={} state={} homed={} trusted={} target={} speed={:.1} sensor={} drift={} fault={} store={} rate={} en={} num={}",
        s.axis, s.position, s.units, s.state.name(), s.homed as u8, s.trusted as u8,
        opt(s.target), s.speed, s.sensor as u8, opt(s.drift),
        s.fault.as_deref().unwrap_or("none").replace(' ', "_"), s.store,
        s.rate.map_or("none".to_string(), |r| r.to_string()), s.enabled as u8, s.number,
    )
    .replace(['\n', '\r'], " ")
}

#[test]
fn the_status_line_is_the_reference_byte_for_byte() {
    let mut s = AxisStatus {
        axis: "X".into(),
        number: 3,
        position: -123_456,
        units: -1.2345678901234567,
        state: AxisState::Fault,
        homed: true,
        trusted: false,
        target: Some(99),
        speed: -2500.04999,
        sensor: true,
        slack: 0,
        drift: None,
        drift_checks: 0,
        move_start: None,
        move_end: None,
        fault: Some("stall at\n 12 \r\nsteps  ".into()),
        sim_position: 0,
        dir_level: false,
        rate: Some(1e-7),
        clock_ppm: None,
        clock_fix: None,
        enabled: false,
        enable_level: false,
        store: "fail ing\n".into(),
        link: None,
        age_ms: None,
    };
    let a = s.line();
    assert_eq!(a, reference(&s));
    assert!(
        a.contains("fault=stall_at _12_  steps__ store=fail ing  rate=0.0000001"),
        "{a}"
    );
    let text = Reply::ok(vec![a.clone()]).to_text();
    let a = a.as_str();
    assert_eq!(text, format!("{a}\nok\n"));
    (s.fault, s.rate, s.target, s.drift) = (None, None, None, Some(-4));
    assert_eq!(s.line(), reference(&s));
    let json = serde_json::to_string(&s).unwrap();
    assert!(!json.contains("link") && !json.contains("age_ms"), "{json}");
    // a board with a link: the two fields after the others, in both forms
    (s.link, s.age_ms) = (Some(Link::Down), Some(12));
    assert_eq!(s.line(), format!("{} link=down age_ms=12", reference(&s)));
    let json = serde_json::to_string(&s).unwrap();
    assert!(json.contains(r#""link":"down","age_ms":12"#), "{json}");
    assert_eq!(serde_json::from_str::<AxisStatus>(&json).unwrap(), s);
}
