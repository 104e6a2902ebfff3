//! The telescope mount on the line protocol (`mount …`, docs/PROTOCOL.md "Mount"): a real
//! `multistep serve` over TCP, its Alpaca side beside it serving the same mount.

use multistep_controller::client::{Client, ClientError, Endpoint};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");

/// The example's solar telescope: a German equatorial mount, 0.28″ per step, slewing at
/// 20°/s, beside its focuser, rotator and filter wheel.
const EXAMPLE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/telescope-mount.toml"
);

struct Serve(Child);

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts serve on `config` (with Alpaca on a free port when `alpaca`); its line-protocol
/// client and Alpaca address.
fn serve(dir: &Path, config: &str, alpaca: bool) -> (Serve, Client, Option<String>) {
    let cfg = dir.join("board.toml");
    std::fs::write(&cfg, config).unwrap();
    let mut cmd = Command::new(BIN);
    cmd.args(["serve", "--listen", "127.0.0.1:0", "--data"])
        .arg(dir.join("d"))
        .arg("--board-config")
        .arg(&cfg)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if alpaca {
        cmd.args(["--alpaca", "127.0.0.1:0", "--alpaca-no-discovery"]);
    }
    let mut child = cmd.spawn().unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let http = alpaca.then(|| {
        let mut said = String::new();
        err.read_line(&mut said).unwrap();
        said.trim()
            .strip_prefix("alpaca devices on http://")
            .and_then(|r| r.split('/').next())
            .expect(&said)
            .to_string()
    });
    // Keep the pipe drained (the mount's warnings) so serve never blocks on it.
    std::thread::spawn(move || std::io::copy(&mut err, &mut std::io::sink()));
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let tcp = first.trim().rsplit("tcp://").next().unwrap().to_string();
    let client = Client::connect(&Endpoint::Tcp(tcp)).unwrap();
    (Serve(child), client, http)
}

/// `mount`'s status line as key → value.
fn status(c: &mut Client) -> std::collections::HashMap<String, String> {
    status_of(c, "mount")
}

/// The status line `line` (`mount`, `mount 1`, …) answers, as key → value.
fn status_of(c: &mut Client, line: &str) -> std::collections::HashMap<String, String> {
    let lines = c.request(line).unwrap();
    assert_eq!(lines.len(), 1, "{lines:?}");
    let rest = lines[0].strip_prefix("mount ").expect(&lines[0]);
    rest.split(' ')
        .map(|kv| {
            let (k, v) = kv.split_once('=').expect(kv);
            (k.to_string(), v.to_string())
        })
        .collect()
}

fn num(s: &std::collections::HashMap<String, String>, k: &str) -> f64 {
    s[k].parse().unwrap()
}

/// The refusal's code and message.
fn refused(c: &mut Client, line: &str) -> (u16, String) {
    match c.request(line) {
        Err(ClientError::Refused(r)) => (r.code, r.message),
        other => panic!("{line}: {other:?}"),
    }
}

fn until(
    c: &mut Client,
    what: &str,
    cond: impl Fn(&std::collections::HashMap<String, String>) -> bool,
) {
    let end = Instant::now() + Duration::from_secs(60);
    loop {
        let s = status(c);
        if cond(&s) {
            return;
        }
        assert!(Instant::now() < end, "{what}: {s:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// One Alpaca request to telescope 0 (HTTP/1.0, the answer's JSON `Value`).
fn alpaca(http: &str, method: &str, path: &str, body: &str) -> String {
    let v = alpaca_to(http, 0, method, path, body);
    assert_eq!(v["ErrorNumber"], 0, "{path}: {v}");
    v["Value"].to_string()
}

/// One Alpaca request to telescope `n`: the whole answer.
fn alpaca_to(http: &str, n: usize, method: &str, path: &str, body: &str) -> serde_json::Value {
    let mut s = TcpStream::connect(http).unwrap();
    write!(
        s,
        "{method} /api/v1/telescope/{n}/{path}?ClientID=1&ClientTransactionID=1 HTTP/1.0\r\nHost: {http}\r\n\
         Content-Type: application/x-www-form-urlencoded\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    let json = out.split("\r\n\r\n").nth(1).expect(&out);
    serde_json::from_str(json).expect(json)
}

/// Hours between two right ascensions, across 0 h.
fn ra_gap(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(24.0);
    d.min(24.0 - d)
}

#[test]
fn mount_commands_slew_abort_guide_park_the_mount_the_alpaca_side_serves() {
    let tmp = tempfile::tempdir().unwrap();
    let config = std::fs::read_to_string(EXAMPLE).unwrap();
    let (_serve, mut c, http) = serve(tmp.path(), &config, true);
    let http = http.unwrap();
    let s = status(&mut c);
    for (k, v) in [
        ("tracking", "0"),
        ("slewing", "0"),
        ("parked", "0"),
        ("guiding", "0"),
        ("rate", "sidereal"),
        ("lat", "52.1"),
        ("lon", "4.4"),
        ("elevation", "10"),
    ] {
        assert_eq!(s[k], v, "{k}: {s:?}");
    }
    // At home the tube points at the pole.
    assert!((num(&s, "dec") - 90.0).abs() < 1e-9, "{s:?}");

    let (code, msg) = refused(&mut c, "mount slew 1 20");
    assert_eq!(code, 24);
    assert!(msg.contains("Tracking"), "{msg}");
    c.request("mount track on").unwrap();
    assert_eq!(status(&mut c)["tracking"], "1");

    // One hour west of the meridian, Dec 30°.
    let lst = num(&status(&mut c), "lst");
    let ra = (lst - 1.0).rem_euclid(24.0);
    c.request(&format!("mount slew {ra} 30")).unwrap();
    assert_eq!(status(&mut c)["slewing"], "1");
    alpaca(&http, "PUT", "connected", "Connected=True&ClientID=1");
    assert_eq!(alpaca(&http, "GET", "slewing", ""), "true");
    until(&mut c, "slew ends", |s| s["slewing"] == "0");
    let s = status(&mut c);
    // One step is 3.6″ = 0.001°; the catch-up move aims at where the target is now.
    assert!(
        ra_gap(num(&s, "ra"), ra) < 0.002 / 15.0 * 2.0,
        "{ra}: {s:?}"
    );
    assert!((num(&s, "dec") - 30.0).abs() < 0.002, "{s:?}");
    assert_eq!(s["tracking"], "1");
    let alpaca_dec: f64 = alpaca(&http, "GET", "declination", "").parse().unwrap();
    assert!((alpaca_dec - 30.0).abs() < 1.0 / 3600.0, "{alpaca_dec}");

    // Aborted on the way to Dec −20°: it stops short, still tracking.
    c.request(&format!("mount slew {ra} -20")).unwrap();
    until(&mut c, "slew under way", |s| num(s, "dec") < 29.0);
    c.request("mount abort").unwrap();
    until(&mut c, "abort stops", |s| s["slewing"] == "0");
    let s = status(&mut c);
    let dec = num(&s, "dec");
    assert!(dec < 29.0 && dec > -15.0, "{s:?}");
    assert_eq!(s["tracking"], "1");

    c.request("mount pulse n 400").unwrap();
    assert_eq!(status(&mut c)["guiding"], "1");
    until(&mut c, "pulse ends", |s| s["guiding"] == "0");

    c.request("mount track on lunar").unwrap();
    assert_eq!(status(&mut c)["rate"], "lunar");
    c.request("mount sync 3.5 10").unwrap();
    let s = status(&mut c);
    assert!(ra_gap(num(&s, "ra"), 3.5) < 1e-3 && (num(&s, "dec") - 10.0).abs() < 1e-3);

    c.request("mount track off").unwrap();
    assert_eq!(status(&mut c)["tracking"], "0");
    c.request("mount park").unwrap();
    until(&mut c, "parked", |s| s["parked"] == "1");
    assert_eq!(alpaca(&http, "GET", "atpark", ""), "true");
    for line in ["mount track on", "mount pulse e 10", "mount abort"] {
        let (code, msg) = refused(&mut c, line);
        assert_eq!(code, 24, "{line}");
        assert!(msg.contains("parked"), "{line}: {msg}");
    }
    c.request("mount unpark").unwrap();
    assert_eq!(status(&mut c)["parked"], "0");
    assert_eq!(alpaca(&http, "GET", "atpark", ""), "false");

    c.request("mount track on").unwrap();
    for (line, code, says) in [
        ("mount slew 24 0", 24, "outside [0, 24)"),
        ("mount slew 1 95", 24, "outside [−90, 90]"),
        ("mount sync -1 0", 24, "outside [0, 24)"),
        // Six hours west at Dec −50° is 37° below the horizon (limit 5°) at 52° N.
        (
            &*format!("mount slew {} -50", (lst - 6.0).rem_euclid(24.0)),
            24,
            "horizon",
        ),
        ("mount pulse x 10", 3, "'x' is not n"),
        ("mount track sideways", 3, "neither on nor off"),
        ("mount", 0, ""),
    ] {
        if code == 0 {
            c.request(line).unwrap();
            continue;
        }
        let (got, msg) = refused(&mut c, line);
        assert_eq!(got, code, "{line}: {msg}");
        assert!(msg.contains(says), "{line}: {msg}");
    }
}

#[test]
fn a_board_without_a_telescope_refuses_mount() {
    let tmp = tempfile::tempdir().unwrap();
    let cfg = "[board]\nname = \"plain\"\n[[axis]]\nname = \"X\"\n";
    let (_serve, mut c, _) = serve(tmp.path(), cfg, false);
    let (code, msg) = refused(&mut c, "mount");
    assert_eq!(code, 24);
    assert!(msg.contains("no mount"), "{msg}");
    // The syntax is checked first, on any board.
    assert_eq!(refused(&mut c, "mount slew 1").0, 3);
}

/// The solar telescope's German mount and a guide scope's fork on one board.
const TWO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/two-telescopes.toml"
);

#[test]
fn two_telescopes_answer_by_number_and_name_on_both_sides() {
    let tmp = tempfile::tempdir().unwrap();
    let config = std::fs::read_to_string(TWO).unwrap();
    let (_serve, mut c, http) = serve(tmp.path(), &config, true);
    let http = http.unwrap();
    // Alpaca numbers them in config order.
    for (n, name, german) in [(0, "Mount", true), (1, "Guide scope", false)] {
        let v = alpaca_to(&http, n, "GET", "name", "");
        assert_eq!(v["Value"], name, "{v}");
        let v = alpaca_to(&http, n, "PUT", "connected", "Connected=True");
        assert_eq!(v["ErrorNumber"], 0, "{v}");
        let v = alpaca_to(&http, n, "GET", "cansetpierside", "");
        assert_eq!(v["Value"], german, "{n}: {v}");
    }
    let dec = |c: &mut Client, line: &str| num(&status_of(c, line), "dec");
    // `mount` alone, `mount 0` and `mount ha` are the first; `mount 1` and `mount gha`
    // the guide scope, by number or by its polar axis.
    c.request("mount gha track on").unwrap();
    let lst = num(&status_of(&mut c, "mount 1"), "lst");
    let ra = (lst - 1.0).rem_euclid(24.0);
    c.request(&format!("mount 1 slew {ra} 20")).unwrap();
    let end = Instant::now() + Duration::from_secs(60);
    while status_of(&mut c, "mount gha")["slewing"] == "1" {
        assert!(Instant::now() < end, "the guide scope's slew did not end");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!((dec(&mut c, "mount 1") - 20.0).abs() < 1.0 / 3600.0);
    for line in ["mount", "mount 0", "mount ha"] {
        assert_eq!(dec(&mut c, line), 90.0, "{line}");
    }
    let v = alpaca_to(&http, 1, "GET", "declination", "");
    assert!(
        (v["Value"].as_f64().unwrap() - 20.0).abs() < 1.0 / 3600.0,
        "{v}"
    );
    let v = alpaca_to(&http, 0, "GET", "declination", "");
    assert_eq!(v["Value"].as_f64(), Some(90.0), "{v}");
    // The guide scope in altitude and azimuth through Alpaca, tracking off.
    c.request("mount 1 track off").unwrap();
    let v = alpaca_to(
        &http,
        1,
        "PUT",
        "slewtoaltazasync",
        "Altitude=45&Azimuth=200",
    );
    assert_eq!(v["ErrorNumber"], 0, "{v}");
    let end = Instant::now() + Duration::from_secs(60);
    while status_of(&mut c, "mount 1")["slewing"] == "1" {
        assert!(Instant::now() < end, "the alt-az slew did not end");
        std::thread::sleep(Duration::from_millis(20));
    }
    let s = status_of(&mut c, "mount 1");
    assert!((num(&s, "alt") - 45.0).abs() * 3600.0 < 3.0, "{s:?}");
    assert!((num(&s, "az") - 200.0).abs() * 3600.0 < 5.0, "{s:?}");
    // A fork has one side; a German mount's flip from the home pose is past ha_limit.
    let v = alpaca_to(&http, 1, "PUT", "sideofpier", "SideOfPier=1");
    assert_eq!(v["ErrorNumber"], 0x400, "{v}");
    for (line, says) in [
        ("mount 1 side west", "only a German"),
        ("mount side west", "ha_limit"),
        ("mount 2", "no telescope '2'"),
        ("mount guide park", "no telescope 'guide'"),
    ] {
        let (code, msg) = refused(&mut c, line);
        assert_eq!(code, 24, "{line}: {msg}");
        assert!(msg.contains(says), "{line}: {msg}");
    }
}
