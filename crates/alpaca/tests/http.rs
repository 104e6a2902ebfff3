//! The Alpaca semantics over real HTTP on 127.0.0.1, against a controller in this process:
//! transaction numbers, connection, parameter case, error numbers, HTTP 400s, the device
//! mappings, discovery and the access rule.

use multistep_alpaca::{start, AlpacaError, AlpacaOptions, AlpacaSection, AlpacaServer};
use multistep_controller::{AxisStatus, BoardConfig, Controller};
use serde_json::Value;
use std::io::{Read, Write};
use std::net::{TcpStream, UdpSocket};
use std::sync::Arc;
use std::time::{Duration, Instant};

const CONFIG: &str = r#"
[board]
name = "t"
[[axis]]
name = "F"
soft_min = 0
soft_max = 20000
steps_per_unit = 100.0
vmax = 4000.0
amax = 40000.0
home_speed = 100.0
home_search = 10000000
sim.sensor_at = -1000000
[[axis]]
name = "R"
period = 36000
steps_per_unit = 100.0
vmax = 8000.0
amax = 80000.0
[[axis]]
name = "W"
period = 4000
vmax = 1000.0
amax = 4000.0

[[alpaca.focuser]]
axis = "F"
name = "Focus"
[[alpaca.rotator]]
axis = "R"
[[alpaca.filterwheel]]
axis = "W"
slots = [
  { name = "Ha", position = 0, focus_offset = 12 },
  { name = "CaK", position = 2000, focus_offset = -7 },
  { name = "Hb" },
]
"#;
const TOKEN: &str = "alpaca-token-0123456789";

struct Rig {
    ctl: Arc<Controller>,
    server: AlpacaServer,
    _dir: tempfile::TempDir,
}

fn rig_with(addr: &str, allow_remote: bool, token: Option<&str>) -> Result<Rig, AlpacaError> {
    rig_at_scale(addr, allow_remote, token, 1.0)
}

fn rig_at_scale(
    addr: &str,
    allow_remote: bool,
    token: Option<&str>,
    time_scale: f64,
) -> Result<Rig, AlpacaError> {
    rig_on(CONFIG, addr, allow_remote, token, time_scale)
}

fn rig_on(
    config: &str,
    addr: &str,
    allow_remote: bool,
    token: Option<&str>,
    time_scale: f64,
) -> Result<Rig, AlpacaError> {
    let dir = tempfile::tempdir().unwrap();
    let config = BoardConfig::parse(config).unwrap();
    let ctl = Arc::new(Controller::open(&config, dir.path(), time_scale).unwrap());
    let section = AlpacaSection::from_board(&config).unwrap();
    let opts = AlpacaOptions {
        addr: addr.into(),
        allow_remote,
        token: token.map(String::from),
        discovery_port: Some(0),
        max_clients: multistep_web::server::DEFAULT_MAX_CLIENTS,
    };
    let server = start(ctl.clone(), &section, &opts)?;
    Ok(Rig {
        ctl,
        server,
        _dir: dir,
    })
}

fn rig() -> Rig {
    rig_with("127.0.0.1:0", false, None).unwrap()
}

impl Rig {
    fn addr(&self) -> String {
        self.server.addr().to_string()
    }
    fn get(&self, path: &str) -> (u16, Value) {
        exchange(&self.addr(), &format!("GET {path} HTTP/1.1\r\n"), "", "")
    }
    fn put(&self, path: &str, form: &str) -> (u16, Value) {
        exchange(&self.addr(), &format!("PUT {path} HTTP/1.1\r\n"), form, "")
    }
    /// A device call that must succeed; its Value.
    fn ok_get(&self, path: &str) -> Value {
        let (code, v) = self.get(path);
        assert_eq!(
            (code, &v["ErrorNumber"]),
            (200, &Value::from(0)),
            "{path}: {v}"
        );
        v["Value"].clone()
    }
    fn ok_put(&self, path: &str, form: &str) {
        let (code, v) = self.put(path, form);
        assert_eq!(
            (code, &v["ErrorNumber"]),
            (200, &Value::from(0)),
            "{path} {form}: {v}"
        );
    }
    fn error_number(&self, put: bool, path: &str, form: &str) -> u64 {
        let (code, v) = if put {
            self.put(path, form)
        } else {
            self.get(path)
        };
        assert_eq!(code, 200, "{path}: {v}");
        assert!(!v["ErrorMessage"].as_str().unwrap().is_empty(), "{v}");
        v["ErrorNumber"].as_u64().unwrap()
    }
    fn status(&self, axis: &str) -> AxisStatus {
        self.ctl.status(&[axis.to_string()]).unwrap().remove(0)
    }
    fn wait_idle(&self, axis: &str) -> AxisStatus {
        let t0 = Instant::now();
        loop {
            let s = self.status(axis);
            if s.target.is_none() {
                return s;
            }
            assert!(
                t0.elapsed() < Duration::from_secs(60),
                "{axis} still moving: {s:?}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    fn connect_all(&self) {
        for d in ["focuser", "rotator", "filterwheel"] {
            self.ok_put(&format!("/api/v1/{d}/0/connected"), "Connected=True");
        }
    }
}

/// One HTTP/1.1 exchange; the body parsed as JSON (Null if it is not), and the text kept
/// for 400s under `{"text": …}`.
fn exchange(addr: &str, request_line: &str, form: &str, extra: &str) -> (u16, Value) {
    let mut s = TcpStream::connect(addr).unwrap();
    let req = format!(
        "{request_line}Host: {addr}\r\nContent-Type: application/x-www-form-urlencoded\r\nContent-Length: {}\r\n{extra}Connection: close\r\n\r\n{form}",
        form.len()
    );
    s.write_all(req.as_bytes()).unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    let code = out[9..12].parse().unwrap();
    let body = out.split_once("\r\n\r\n").map_or("", |x| x.1);
    let v = serde_json::from_str(body).unwrap_or_else(|_| serde_json::json!({ "text": body }));
    (code, v)
}

#[test]
fn management_api_lists_the_configured_devices() {
    let r = rig();
    assert_eq!(r.ok_get("/management/apiversions"), serde_json::json!([1]));
    let d = r.ok_get("/management/v1/description");
    assert_eq!(d["ServerName"], "multistep board t");
    let list = r.ok_get("/management/v1/configureddevices");
    let got: Vec<(String, String, u64)> = list
        .as_array()
        .unwrap()
        .iter()
        .map(|d| {
            (
                d["DeviceType"].as_str().unwrap().to_string(),
                d["DeviceName"].as_str().unwrap().to_string(),
                d["DeviceNumber"].as_u64().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        got,
        [
            ("Focuser".into(), "Focus".into(), 0),
            ("Rotator".into(), "t rotator R".into(), 0),
            ("FilterWheel".into(), "t filterwheel W".into(), 0)
        ]
    );
    assert!(list[1]["UniqueID"].as_str().unwrap().contains("rotator-R"));
    let (code, page) = r.get("/setup");
    assert_eq!(code, 200);
    assert!(page["text"].as_str().unwrap().contains("axis W"));
}

#[test]
fn transaction_ids_are_echoed_and_increase_and_names_ignore_case() {
    let r = rig();
    let (_, a) = r.get("/api/v1/focuser/0/connected?ClientID=3&ClientTransactionID=41");
    let (_, b) = r.get("/api/v1/focuser/0/connected?clientid=3&clienttransactionid=42");
    assert_eq!(a["ClientTransactionID"], 41);
    assert_eq!(b["ClientTransactionID"], 42);
    let (sa, sb) = (
        a["ServerTransactionID"].as_u64().unwrap(),
        b["ServerTransactionID"].as_u64().unwrap(),
    );
    assert!(sb > sa && sa >= 1, "{sa} {sb}");
    // Not a uint32: answered with 0.
    let (_, c) = r.get("/api/v1/focuser/0/connected?ClientTransactionID=-5");
    assert_eq!(c["ClientTransactionID"], 0);
    // PUT parameters come from the form body, any case.
    let (_, d) = r.put(
        "/api/v1/focuser/0/connected",
        "CONNECTED=true&CLIENTTRANSACTIONID=77",
    );
    assert_eq!(
        (d["ErrorNumber"].as_u64(), d["ClientTransactionID"].as_u64()),
        (Some(0), Some(77))
    );
    assert_eq!(r.ok_get("/api/v1/focuser/0/connected"), true);
}

#[test]
fn connection_is_needed_for_device_calls_but_not_for_the_description() {
    let r = rig();
    for d in ["focuser", "rotator", "filterwheel"] {
        assert_eq!(r.ok_get(&format!("/api/v1/{d}/0/connected")), false);
        assert_eq!(r.ok_get(&format!("/api/v1/{d}/0/connecting")), false);
        assert!(r.ok_get(&format!("/api/v1/{d}/0/description")).is_string());
        assert!(r
            .ok_get(&format!("/api/v1/{d}/0/interfaceversion"))
            .is_u64());
        assert_eq!(
            r.error_number(false, &format!("/api/v1/{d}/0/position"), ""),
            0x407
        );
    }
    r.ok_put("/api/v1/focuser/0/connect", "");
    assert_eq!(r.ok_get("/api/v1/focuser/0/connected"), true);
    assert_eq!(r.ok_get("/api/v1/focuser/0/position"), 0);
    r.ok_put("/api/v1/focuser/0/disconnect", "");
    assert_eq!(
        r.error_number(false, "/api/v1/focuser/0/ismoving", ""),
        0x407
    );
    r.connect_all();
    let st = r.ok_get("/api/v1/rotator/0/devicestate");
    let names: Vec<&str> = st
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["Name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["IsMoving", "MechanicalPosition", "Position"]);
    assert_eq!(
        r.error_number(true, "/api/v1/focuser/0/action", "Action=x&Parameters="),
        0x40C
    );
    assert_eq!(
        r.error_number(
            true,
            "/api/v1/focuser/0/commandblind",
            "Command=x&Raw=false"
        ),
        0x400
    );
    assert_eq!(
        r.ok_get("/api/v1/focuser/0/supportedactions"),
        serde_json::json!([])
    );
}

#[test]
fn malformed_requests_get_http_400_with_a_reason() {
    let r = rig();
    r.connect_all();
    for (put, path, form) in [
        (true, "/api/v1/focuser/0/move", ""),
        (true, "/api/v1/focuser/0/move", "Position=abc"),
        (true, "/api/v1/focuser/0/move", "Position=1.5"),
        (true, "/api/v1/focuser/0/connected", "Connected=yes"),
        (false, "/api/v1/focuser/0/warp", ""),
        (false, "/api/v1/focuser/1/position", ""),
        (false, "/api/v1/telescope/0/connected", ""),
        (false, "/api/v1/focuser/0/move", ""),
        (true, "/api/v1/rotator/0/moveabsolute", "Angle=3"),
    ] {
        let (code, v) = if put { r.put(path, form) } else { r.get(path) };
        assert_eq!(code, 400, "{path} {form}: {v}");
        assert!(!v["text"].as_str().unwrap().is_empty());
    }
    assert_eq!(r.get("/nothing/here").0, 404);
    let (code, _) = exchange(
        &r.addr(),
        "DELETE /api/v1/focuser/0/position HTTP/1.1\r\n",
        "",
        "",
    );
    assert_eq!(code, 405);
}

#[test]
fn focuser_moves_halts_and_refuses_bad_targets_homing_and_estop() {
    let r = rig();
    r.connect_all();
    let f = "/api/v1/focuser/0";
    assert_eq!(r.ok_get(&format!("{f}/maxstep")), 20000);
    assert_eq!(r.ok_get(&format!("{f}/maxincrement")), 20000);
    assert_eq!(r.ok_get(&format!("{f}/absolute")), true);
    // 1000 µm per unit over 100 microsteps per unit.
    assert_eq!(r.ok_get(&format!("{f}/stepsize")), 10.0);
    assert_eq!(r.ok_get(&format!("{f}/tempcomp")), false);
    assert_eq!(r.ok_get(&format!("{f}/tempcompavailable")), false);
    assert_eq!(
        r.error_number(true, &format!("{f}/tempcomp"), "TempComp=true"),
        0x400
    );
    assert_eq!(
        r.error_number(false, &format!("{f}/temperature"), ""),
        0x400
    );
    assert_eq!(
        r.error_number(true, &format!("{f}/move"), "Position=20001"),
        0x401
    );
    assert_eq!(
        r.error_number(true, &format!("{f}/move"), "Position=-1"),
        0x401
    );

    r.ok_put(&format!("{f}/move"), "Position=1500");
    assert_eq!(r.status("F").target, Some(1500));
    let s = r.wait_idle("F");
    assert_eq!(s.position, 1500);
    assert_eq!(r.ok_get(&format!("{f}/position")), 1500);
    assert_eq!(r.ok_get(&format!("{f}/ismoving")), false);

    // A long move, halted: it stops short of the target, where the line protocol says.
    r.ok_put(&format!("{f}/move"), "Position=20000");
    assert_eq!(r.ok_get(&format!("{f}/ismoving")), true);
    assert_eq!(
        r.error_number(true, &format!("{f}/move"), "Position=100"),
        0x40B
    );
    while r.status("F").position == 1500 {
        std::thread::sleep(Duration::from_millis(5));
    }
    r.ok_put(&format!("{f}/halt"), "");
    let s = r.wait_idle("F");
    assert!(s.position > 1500 && s.position < 20000, "{s:?}");
    assert_eq!(r.ok_get(&format!("{f}/position")), s.position);

    // Homing (slow, the sensor is far away): a move is an invalid operation.
    r.ctl.home("F").unwrap();
    assert_eq!(r.ok_get(&format!("{f}/ismoving")), true);
    assert_eq!(
        r.error_number(true, &format!("{f}/move"), "Position=10"),
        0x40B
    );
    r.ctl.estop();
    assert_eq!(
        r.error_number(true, &format!("{f}/move"), "Position=10"),
        0x40B
    );
    r.ctl.reset();
    r.ok_put(&format!("{f}/move"), "Position=0");
    r.wait_idle("F");
    // The controller's own soft limits decide within 0..=MaxStep, set over the protocol.
    assert!(r
        .ctl
        .execute_bytes(b"set F soft_min 100")
        .to_text()
        .starts_with("ok"));
    assert_eq!(
        r.error_number(true, &format!("{f}/move"), "Position=50"),
        0x401
    );
    assert!(r
        .ctl
        .execute_bytes(b"set F soft_max 900")
        .to_text()
        .starts_with("ok"));
    assert_eq!(r.ok_get(&format!("{f}/maxstep")), 900);
    assert!(r
        .ctl
        .execute_bytes(b"set F soft_max none")
        .to_text()
        .starts_with("ok"));
    assert_eq!(r.error_number(false, &format!("{f}/maxstep"), ""), 0x402);
}

#[test]
fn rotator_takes_the_short_way_across_the_wrap_and_syncs() {
    let r = rig();
    r.connect_all();
    let rot = "/api/v1/rotator/0";
    assert_eq!(r.ok_get(&format!("{rot}/canreverse")), true);
    assert_eq!(r.ok_get(&format!("{rot}/stepsize")), 0.01);
    assert_eq!(
        r.error_number(true, &format!("{rot}/moveabsolute"), "Position=360"),
        0x401
    );
    assert_eq!(
        r.error_number(true, &format!("{rot}/moveabsolute"), "Position=-0.5"),
        0x401
    );
    assert_eq!(
        r.error_number(true, &format!("{rot}/moveabsolute"), "Position=NaN"),
        0x401
    );

    // Which way a move went: the DIR line of the last move; with where it ended that
    // fixes the travel, as a move never turns half a period or more (whatever the load,
    // unlike watching the move's target while it runs).
    r.ok_put(&format!("{rot}/moveabsolute"), "Position=350");
    // From 0 the short way to 350° is 10° down.
    let s = r.wait_idle("R");
    assert_eq!((s.position, s.dir_level), (35000, false));
    assert_eq!(r.ok_get(&format!("{rot}/position")), 350.0);
    r.ok_put(&format!("{rot}/moveabsolute"), "Position=10");
    assert_eq!(r.ok_get(&format!("{rot}/targetposition")), 10.0);
    // 350° → 10° goes up through 360°: 20°, not 340° back.
    let s = r.wait_idle("R");
    assert_eq!((s.position, s.dir_level), (1000, true));
    assert_eq!(r.ok_get(&format!("{rot}/position")), 10.0);
    assert_eq!(r.ok_get(&format!("{rot}/mechanicalposition")), 10.0);

    // Sync: the sky angle is offset, the mechanics are not.
    r.ok_put(&format!("{rot}/sync"), "Position=100");
    assert_eq!(r.ok_get(&format!("{rot}/position")), 100.0);
    assert_eq!(r.ok_get(&format!("{rot}/mechanicalposition")), 10.0);
    r.ok_put(&format!("{rot}/moveabsolute"), "Position=95");
    assert_eq!(r.wait_idle("R").position, 500);
    r.ok_put(&format!("{rot}/move"), "Position=-10");
    assert_eq!(r.wait_idle("R").position, 35500);
    assert_eq!(r.ok_get(&format!("{rot}/position")), 85.0);
    r.ok_put(&format!("{rot}/movemechanical"), "Position=0");
    assert_eq!(r.wait_idle("R").position, 0);
    // Reverse: angles run the other way round.
    r.ok_put(&format!("{rot}/reverse"), "Reverse=true");
    assert_eq!(r.ok_get(&format!("{rot}/reverse")), true);
    r.ok_put(&format!("{rot}/movemechanical"), "Position=30");
    assert_eq!(r.wait_idle("R").position, 33000);
    assert_eq!(r.ok_get(&format!("{rot}/mechanicalposition")), 30.0);
}

/// The focuser and rotator with the controller's backlash: every reversal ends on its
/// target (the load's position), the motor turning the backlash more in the same move.
#[test]
fn focuser_and_rotator_reversals_end_on_their_targets_with_backlash() {
    let config = CONFIG
        .replace("name = \"F\"\n", "name = \"F\"\nbacklash = 250\n")
        .replace("name = \"R\"\n", "name = \"R\"\nbacklash = 90\n");
    let r = rig_on(&config, "127.0.0.1:0", false, None, 1.0).unwrap();
    r.connect_all();
    // the simulated mechanics are the motor: less the slack, a constant from the start
    let motor = |s: &AxisStatus| s.sim_position - s.slack;
    let f = "/api/v1/focuser/0";
    let f0 = motor(&r.status("F")) - r.status("F").position;
    for (to, slack) in [(1500, 250), (1000, 0), (1200, 250), (1300, 250), (200, 0)] {
        r.ok_put(&format!("{f}/move"), &format!("Position={to}"));
        let s = r.wait_idle("F");
        assert_eq!((s.position, s.slack), (to, slack));
        assert_eq!(motor(&s) - s.position, f0);
        assert_eq!(r.ok_get(&format!("{f}/position")), to);
    }
    let rot = "/api/v1/rotator/0";
    let r0 = motor(&r.status("R")) - r.status("R").position;
    // 350° down from 0, 10° up across the wrap, 5° down: each a reversal
    for (to, pos, slack) in [(350.0, 35000, 0), (10.0, 1000, 90), (5.0, 500, 0)] {
        r.ok_put(&format!("{rot}/moveabsolute"), &format!("Position={to}"));
        let s = r.wait_idle("R");
        assert_eq!((s.position, s.slack), (pos, slack));
        assert_eq!(r.ok_get(&format!("{rot}/position")), to);
        assert_eq!((motor(&s) - s.position - r0).rem_euclid(36000), 0);
    }
}

#[test]
fn rotator_with_a_travel_refuses_the_wrap_and_turns_the_long_way() {
    let config = CONFIG.replace(
        "[[alpaca.rotator]]\naxis = \"R\"\n",
        "[[alpaca.rotator]]\naxis = \"R\"\nmin_deg = -90.0\nmax_deg = 180.0\n",
    );
    let r = rig_on(&config, "127.0.0.1:0", false, None, 1.0).unwrap();
    let rot = "/api/v1/rotator/0";
    r.ok_put(&format!("{rot}/connected"), "Connected=true");
    // 200° lies in the wrap (180°..270°)
    let (_, v) = r.put(&format!("{rot}/moveabsolute"), "Position=200");
    assert_eq!(v["ErrorNumber"], 0x401, "{v}");
    assert!(
        v["ErrorMessage"].as_str().unwrap().contains("cable wrap"),
        "{v}"
    );
    assert_eq!(r.status("R").position, 0);
    r.ok_put(&format!("{rot}/moveabsolute"), "Position=170");
    assert_eq!(r.wait_idle("R").position, 17000);
    // 170° → 280° (-80°): the short way crosses the wrap, so 250° down, in legs that
    // follow one another while a client polls IsMoving
    r.ok_put(&format!("{rot}/moveabsolute"), "Position=280");
    let end = Instant::now() + Duration::from_secs(60);
    let mut seen = Vec::new();
    while r.ok_get(&format!("{rot}/ismoving")) == true {
        seen.push(r.status("R").position);
        assert!(Instant::now() < end, "still moving: {seen:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
    let s = r.status("R");
    assert_eq!((s.position, s.dir_level), (28000, false));
    assert!(
        seen.iter().all(|&p| p <= 18000 || p >= 27000),
        "entered the wrap: {seen:?}"
    );
    assert!(seen.iter().any(|&p| p < 9000), "{seen:?}");
    assert_eq!(r.ok_get(&format!("{rot}/position")), 280.0);
    // and back up, a client reading only DeviceState
    r.ok_put(&format!("{rot}/moveabsolute"), "Position=170");
    let moving = || {
        let v = r.ok_get(&format!("{rot}/devicestate"));
        let items = v.as_array().unwrap().clone();
        items.iter().find(|i| i["Name"] == "IsMoving").unwrap()["Value"] == true
    };
    while moving() {
        let p = r.status("R").position;
        assert!(p <= 18000 || p >= 27000, "entered the wrap: {p}");
        assert!(Instant::now() < end, "still moving at {p}");
        std::thread::sleep(Duration::from_millis(20));
    }
    let s = r.status("R");
    assert_eq!((s.position, s.dir_level), (17000, true));
}

/// Hundredths of a degree as the decimal text a client sends.
fn deg(h: i64) -> String {
    format!("{}.{:02}", h / 100, h % 100)
}

proptest::proptest! {
    #![proptest_config(proptest::test_runner::Config { cases: 24, ..Default::default() })]

    /// Any start, target, sync angle and sense: MoveAbsolute turns the shorter way (at
    /// most 180°, the rational difference reduced into (−180°, 180°]) and ends on the
    /// target. Angles are whole hundredths (1 microstep = 0.01°) so every value is exact.
    #[test]
    fn rotator_move_absolute_takes_the_shorter_way(
        a in 0i64..36000, b in 0i64..36000, sync in 0i64..36000, reverse: bool,
    ) {
        // Fast simulated time: each move ends within milliseconds of wall time.
        let r = rig_at_scale("127.0.0.1:0", false, None, 1e4).unwrap();
        let rot = "/api/v1/rotator/0";
        r.ok_put(&format!("{rot}/connected"), "Connected=true");
        r.ok_put(&format!("{rot}/reverse"), &format!("Reverse={reverse}"));
        r.ok_put(&format!("{rot}/sync"), &format!("Position={}", deg(sync)));
        r.ok_put(&format!("{rot}/moveabsolute"), &format!("Position={}", deg(a)));
        let from = r.wait_idle("R").position;
        proptest::prop_assert_eq!(r.ok_get(&format!("{rot}/position")), Value::from(a as f64 / 100.0));
        r.ok_put(&format!("{rot}/moveabsolute"), &format!("Position={}", deg(b)));
        let sense = if reverse { -1 } else { 1 };
        let mut want = (sense * (b - a)).rem_euclid(36000);
        if want > 18000 {
            want -= 36000;
        }
        let end = r.wait_idle("R");
        // The move may be over before it can be watched: its direction (the DIR line) and
        // where it ended fix how far it went, as a move never turns a full period.
        if want != 0 {
            proptest::prop_assert_eq!(end.dir_level, want > 0, "turn {} from {}", want, from);
        }
        proptest::prop_assert_eq!(end.position, (from + want).rem_euclid(36000));
        proptest::prop_assert_eq!(r.ok_get(&format!("{rot}/position")), Value::from(b as f64 / 100.0));
    }
}

#[test]
fn filter_wheel_changes_by_slot_and_reads_minus_one_while_moving() {
    let r = rig();
    r.connect_all();
    let w = "/api/v1/filterwheel/0";
    assert_eq!(
        r.ok_get(&format!("{w}/names")),
        serde_json::json!(["Ha", "CaK", "Hb"])
    );
    assert_eq!(
        r.ok_get(&format!("{w}/focusoffsets")),
        serde_json::json!([12, -7, 0])
    );
    assert_eq!(r.ok_get(&format!("{w}/position")), 0);
    r.ok_put(&format!("{w}/position"), "Position=1");
    let during = r.ok_get(&format!("{w}/position"));
    // Still moving after the read (a 2 s move): then the read was during the move.
    if r.status("W").target.is_some() {
        assert_eq!(during, -1);
    }
    assert_eq!(r.wait_idle("W").position, 2000);
    assert_eq!(r.ok_get(&format!("{w}/position")), 1);
    assert_eq!(
        r.error_number(true, &format!("{w}/position"), "Position=3"),
        0x401
    );
    assert_eq!(
        r.error_number(true, &format!("{w}/position"), "Position=-1"),
        0x401
    );
    // Slot "Hb" is the board's named position of that name, not saved yet.
    assert_eq!(
        r.error_number(true, &format!("{w}/position"), "Position=2"),
        0x402
    );
    r.ctl
        .with_board(|b, now| {
            b.move_axis(
                "W",
                multistep_controller::protocol::Amount::Steps(3000),
                true,
                &Default::default(),
                now,
            )
        })
        .unwrap();
    r.wait_idle("W");
    assert_eq!(r.ok_get(&format!("{w}/position")), -1, "between slots");
    r.ctl.execute_bytes(b"save Hb W");
    assert_eq!(r.ok_get(&format!("{w}/position")), 2);
    r.ok_put(&format!("{w}/position"), "Position=0");
    // The wheel is periodic: 3000 → 4000 ≡ 0 is the short way (up).
    let s = r.wait_idle("W");
    assert_eq!((s.position, s.dir_level), (0, true));
    r.ok_put(&format!("{w}/position"), "Position=2");
    let s = r.wait_idle("W");
    assert_eq!((s.position, s.dir_level), (3000, false));
}

#[test]
fn discovery_answers_unicast_and_loopback_broadcast_with_the_http_port() {
    let r = rig();
    let d = r.server.discovery_addr().unwrap();
    let c = UdpSocket::bind("127.0.0.1:0").unwrap();
    c.set_broadcast(true).unwrap();
    c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    for to in ["127.0.0.1", "127.255.255.255"] {
        c.send_to(b"alpacadiscovery1", (to, d.port())).unwrap();
        let mut buf = [0u8; 128];
        let (n, from) = c.recv_from(&mut buf).unwrap();
        let v: Value = serde_json::from_slice(&buf[..n]).unwrap();
        assert_eq!(v["AlpacaPort"], r.server.addr().port(), "{to}");
        assert_eq!(from.ip().to_string(), "127.0.0.1", "{to}");
    }
    // Anything else gets no answer.
    c.set_read_timeout(Some(Duration::from_millis(300)))
        .unwrap();
    c.send_to(b"alpacadiscovery2", d).unwrap();
    assert!(c.recv_from(&mut [0u8; 128]).is_err());
}

#[test]
fn remote_use_needs_the_flag_and_a_token_carried_by_every_request() {
    assert!(matches!(
        rig_with("0.0.0.0:0", false, None),
        Err(AlpacaError::RemoteNotAllowed(_))
    ));
    assert!(matches!(
        rig_with("0.0.0.0:0", true, None),
        Err(AlpacaError::TokenRequired)
    ));
    let r = rig_with("0.0.0.0:0", true, Some(TOKEN)).unwrap();
    let addr = format!("127.0.0.1:{}", r.server.addr().port());
    let line = "GET /management/v1/configureddevices HTTP/1.1\r\n";
    assert_eq!(exchange(&addr, line, "", "").0, 403);
    assert_eq!(
        exchange(
            &addr,
            line,
            "",
            "Authorization: Bearer wrong-token-0123456789\r\n"
        )
        .0,
        403
    );
    assert_eq!(
        exchange(
            &addr,
            line,
            "",
            &format!("Authorization: Bearer {TOKEN}\r\n")
        )
        .0,
        200
    );
    // What `http://alpaca:TOKEN@host:port` makes a client send.
    let basic = base64_of(&format!("alpaca:{TOKEN}"));
    assert_eq!(
        exchange(
            &addr,
            line,
            "",
            &format!("Authorization: Basic {basic}\r\n")
        )
        .0,
        200
    );
    // The scheme name is case-insensitive; a wrong Basic password is refused.
    let auth = |v: String| exchange(&addr, line, "", &format!("Authorization: {v}\r\n")).0;
    assert_eq!(auth(format!("bearer {TOKEN}")), 200);
    assert_eq!(auth(format!("BASIC {basic}")), 200);
    assert_eq!(
        auth(format!("Basic {}", base64_of(&format!("{TOKEN}:x")))),
        403
    );
    assert_eq!(auth("Basic !!!".into()), 403);
    // On loopback a foreign Host (DNS rebinding) is refused.
    let l = rig();
    let (code, _) = exchange(&l.addr(), line, "", "");
    assert_eq!(code, 200);
    let mut s = TcpStream::connect(l.addr()).unwrap();
    s.write_all(format!("{line}Host: evil.example\r\nConnection: close\r\n\r\n").as_bytes())
        .unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    assert!(out.starts_with("HTTP/1.1 403"), "{out}");
}

/// Standard base64, written out here so the test does not share the server's decoder.
fn base64_of(s: &str) -> String {
    const A: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let b = s.as_bytes();
    let mut out = String::new();
    for c in b.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}
