//! `multistep serve --http` as a process, without a browser: who may connect, and that the
//! JSON API answers exactly what the line protocol answers (one dispatcher behind both).

use multistep_controller::client::{Client, ClientError, Endpoint};
use serde_json::Value;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_multistep");
const TOKEN: &str = "s3cret-token-0123456789";

struct Service {
    child: Child,
    tcp: String,
    http: String,
}

impl Service {
    fn start(data: &Path, http_args: &[&str]) -> Service {
        let mut child = Command::new(BIN)
            .args(["serve", "--listen", "127.0.0.1:0", "--data"])
            .arg(data)
            .args(http_args)
            .env_remove("MULTISTEP_HTTP_TOKEN")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Only a service with --http says where its page is (first line on stderr).
        let mut http = String::new();
        if http_args.contains(&"--http") {
            let mut line = String::new();
            BufReader::new(child.stderr.take().unwrap())
                .read_line(&mut line)
                .unwrap();
            let addr = line
                .trim()
                .strip_prefix("web page on http://")
                .expect(&line);
            http = addr.trim_end_matches('/').to_string();
        }
        let mut first = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut first)
            .unwrap();
        let tcp = first.trim().rsplit("tcp://").next().unwrap().to_string();
        Service { child, tcp, http }
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// One HTTP/1.1 exchange: (status, body).
fn http(addr: &str, req: &str) -> (u16, String) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.write_all(req.as_bytes()).unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    let status = out[9..12].parse().unwrap();
    let body = out.split_once("\r\n\r\n").map_or("", |x| x.1).to_string();
    (status, body)
}

fn get(addr: &str, path: &str, host: &str, extra: &str) -> (u16, String) {
    http(
        addr,
        &format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n{extra}Connection: close\r\n\r\n"),
    )
}

fn post(addr: &str, path: &str, body: &str, ctype: &str, extra: &str) -> (u16, Value) {
    let (code, text) = http(
        addr,
        &format!(
            "POST {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: {ctype}\r\nContent-Length: {}\r\n{extra}Connection: close\r\n\r\n{body}",
            body.len()
        ),
    );
    (code, serde_json::from_str(&text).unwrap_or(Value::Null))
}

fn cmd(addr: &str, line: &str) -> Value {
    cmd_on(addr, 0, line)
}

fn cmd_on(addr: &str, board: usize, line: &str) -> Value {
    let body = serde_json::json!({ "board": board, "line": line }).to_string();
    let (code, v) = post(addr, "/api/cmd", &body, "application/json", "");
    assert_eq!(code, 200, "{v}");
    v
}

#[test]
fn non_loopback_needs_the_flag_and_a_token() {
    let tmp = tempfile::tempdir().unwrap();
    for (args, says) in [
        (vec!["--http", "0.0.0.0:0"], "--http-allow-remote"),
        (
            vec!["--http", "0.0.0.0:0", "--http-allow-remote"],
            "needs an access token",
        ),
        (
            vec![
                "--http",
                "0.0.0.0:0",
                "--http-allow-remote",
                "--http-token",
                "short",
            ],
            "16 to 256",
        ),
    ] {
        let out = Command::new(BIN)
            .args(["serve", "--listen", "127.0.0.1:0", "--data"])
            .arg(tmp.path().join("d"))
            .args(&args)
            .env_remove("MULTISTEP_HTTP_TOKEN")
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

#[test]
fn with_a_token_every_request_must_carry_it() {
    let tmp = tempfile::tempdir().unwrap();
    let svc = Service::start(
        &tmp.path().join("d"),
        &[
            "--http",
            "0.0.0.0:0",
            "--http-allow-remote",
            "--http-token",
            TOKEN,
        ],
    );
    let port = svc.http.rsplit(':').next().unwrap();
    let addr = format!("127.0.0.1:{port}");
    let host = format!("10.1.2.3:{port}");
    for path in ["/", "/app.js", "/api/status", "/api/boards", "/api/events"] {
        assert_eq!(get(&addr, path, &host, "").0, 403, "{path} without a token");
        assert_eq!(
            get(
                &addr,
                &format!("{path}?token=wrong-token-0123456789"),
                &host,
                ""
            )
            .0,
            403
        );
    }
    assert_eq!(get(&addr, &format!("/?token={TOKEN}"), &host, "").0, 200);
    let auth = format!("Authorization: Bearer {TOKEN}\r\n");
    let (code, body) = get(&addr, "/api/boards", &host, &auth);
    assert_eq!(code, 200);
    assert!(
        body.contains("\"axes\":[\"X\",\"Y\",\"Z\",\"A\"]"),
        "{body}"
    );
    let line = r#"{"line":"estop"}"#;
    assert_eq!(post(&addr, "/api/cmd", line, "application/json", "").0, 403);
    let (code, v) = post(&addr, "/api/cmd", line, "application/json", &auth);
    assert_eq!((code, v["ok"].as_bool()), (200, Some(true)));
}

#[test]
fn loopback_refuses_foreign_hosts_and_plain_form_posts() {
    let tmp = tempfile::tempdir().unwrap();
    let svc = Service::start(&tmp.path().join("d"), &["--http", "127.0.0.1:0"]);
    assert_eq!(get(&svc.http, "/", &svc.http, "").0, 200);
    assert_eq!(get(&svc.http, "/", "localhost:1", "").0, 200);
    // DNS rebinding: a page of another site whose name resolves to 127.0.0.1.
    assert_eq!(get(&svc.http, "/api/status", "attacker.example", "").0, 403);
    // A cross-site form can post text/plain without a CORS preflight; it is refused.
    let (code, _) = post(
        &svc.http,
        "/api/cmd",
        r#"{"line":"estop"}"#,
        "text/plain",
        "",
    );
    assert_eq!(code, 415);
    let (code, _) = post(
        &svc.http,
        "/api/cmd",
        r#"{"line":"estop\nreset"}"#,
        "application/json",
        "",
    );
    assert_eq!(code, 400);
    assert_eq!(get(&svc.http, "/nothing", &svc.http, "").0, 404);
}

#[test]
fn http_replies_are_the_line_protocol_replies() {
    let tmp = tempfile::tempdir().unwrap();
    let svc = Service::start(&tmp.path().join("d"), &["--http", "127.0.0.1:0"]);
    let mut tcp = Client::connect(&Endpoint::Tcp(svc.tcp.clone())).unwrap();
    cmd(&svc.http, "set X soft_max 5000");
    for line in [
        "get X vmax",
        "moveto X 9000",
        "set X vmax -1",
        "move Q 10",
        "bogus",
        "presets",
        "save p1",
        "positions",
        "group moveto X=100 X=200",
        "move Y 50 amax=1e9",
        "sim X slip x",
        "rate fast -2000",
        "rates",
        "track 1 fast lease=30",
        "track 1 abc",
        "track Y 1e9",
        "release 1",
        "release 2",
        "energize 2",
        "stop 1",
    ] {
        let web = cmd(&svc.http, line);
        match tcp.request(line) {
            Ok(data) => {
                assert_eq!(web["ok"], true, "{line}: {web}");
                assert_eq!(web["data"], serde_json::json!(data), "{line}");
            }
            Err(ClientError::Refused(r)) => {
                assert_eq!(web["ok"], false, "{line}: {web}");
                assert_eq!(web["error"]["code"], r.code, "{line}");
                assert_eq!(web["error"]["message"], r.message, "{line}");
            }
            Err(e) => panic!("{line}: {e}"),
        }
    }
}

#[test]
fn preview_plans_without_moving_and_reports_plan_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let svc = Service::start(&tmp.path().join("d"), &["--http", "127.0.0.1:0"]);
    let body =
        serde_json::json!({ "line": "group move X=4000 Y=-1000 sync profile=scurve" }).to_string();
    let (code, v) = post(&svc.http, "/api/preview", &body, "application/json", "");
    assert_eq!(code, 200);
    assert_eq!(v["ok"], true, "{v}");
    let axes = v["axes"].as_array().unwrap();
    assert_eq!(
        (axes[0]["target"].as_i64(), axes[1]["target"].as_i64()),
        (Some(4000), Some(-1000))
    );
    // Synchronous: both finish together.
    assert_eq!(axes[0]["duration"], axes[1]["duration"]);
    let pos = axes[1]["position"].as_array().unwrap();
    assert_eq!(pos.first().unwrap().as_f64(), Some(0.0));
    assert!((pos.last().unwrap().as_f64().unwrap() + 1000.0).abs() < 1e-6);
    // Nothing moved.
    let st = cmd(&svc.http, "status X");
    assert!(st["data"][0].as_str().unwrap().contains("pos=0 "), "{st}");
    let body = serde_json::json!({ "line": "move X 100 amax=1e9" }).to_string();
    let (_, v) = post(&svc.http, "/api/preview", &body, "application/json", "");
    let web = cmd(&svc.http, "move X 100 amax=1e9");
    assert_eq!(v["ok"], false);
    assert_eq!(v["error"], web["error"], "preview and move refuse alike");
    // by motor number, as by name
    let body = serde_json::json!({ "line": "move 1 -700" }).to_string();
    let (_, v) = post(&svc.http, "/api/preview", &body, "application/json", "");
    assert_eq!(v["axes"][0]["axis"], "Y", "{v}");
    assert_eq!(v["axes"][0]["target"], -700, "{v}");
    let body = serde_json::json!({ "line": "home X" }).to_string();
    let (_, v) = post(&svc.http, "/api/preview", &body, "application/json", "");
    assert!(
        v["error"]["message"]
            .as_str()
            .unwrap()
            .contains("preview works for"),
        "{v}"
    );
}

#[test]
fn the_event_stream_follows_a_move() {
    let tmp = tempfile::tempdir().unwrap();
    let svc = Service::start(&tmp.path().join("d"), &["--http", "127.0.0.1:0"]);
    let mut s = TcpStream::connect(&svc.http).unwrap();
    write!(s, "GET /api/events HTTP/1.1\r\nHost: {}\r\n\r\n", svc.http).unwrap();
    let mut r = BufReader::new(s);
    let mut head = String::new();
    r.read_line(&mut head).unwrap();
    assert!(head.starts_with("HTTP/1.1 200"), "{head}");
    cmd(&svc.http, "move X 3000");
    let t0 = std::time::Instant::now();
    let (mut moving, mut positions) = (0, Vec::new());
    for line in r.lines() {
        let line = line.unwrap();
        let Some(json) = line.strip_prefix("data: ") else {
            continue;
        };
        let v: Value = serde_json::from_str(json).unwrap();
        let x = &v["boards"][0]["axes"][0];
        assert_eq!(x["axis"], "X");
        if x["state"] == "moving" {
            moving += 1;
            positions.push(x["position"].as_i64().unwrap());
        } else if x["position"] == 3000 {
            break;
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "{moving} snapshots while moving in {secs:.2} s ({:.1}/s)",
        moving as f64 / secs
    );
    assert!(
        moving >= 5,
        "the stream did not follow the move: {positions:?}"
    );
    assert!(positions.windows(2).all(|w| w[0] <= w[1]), "{positions:?}");
}

#[test]
fn another_board_is_shown_and_driven_over_its_line_protocol() {
    let tmp = tempfile::tempdir().unwrap();
    let mut other = Service::start(&tmp.path().join("a"), &[]);
    let svc = Service::start(
        &tmp.path().join("b"),
        &["--http", "127.0.0.1:0", "--http-board", &other.tcp],
    );
    let (code, body) = get(&svc.http, "/api/boards", &svc.http, "");
    assert_eq!(code, 200);
    let v: Value = serde_json::from_str(&body).unwrap();
    assert_eq!(v["boards"].as_array().unwrap().len(), 2, "{v}");
    assert_eq!(v["boards"][1]["remote"], other.tcp.as_str());
    assert_eq!(
        v["boards"][1]["axes"],
        serde_json::json!(["X", "Y", "Z", "A"])
    );

    let r = cmd_on(&svc.http, 1, "move Y 500");
    assert_eq!(r["data"], serde_json::json!(["Y target=500"]), "{r}");
    let mut direct = Client::connect(&Endpoint::Tcp(other.tcp.clone())).unwrap();
    let t0 = std::time::Instant::now();
    let y = loop {
        let y = direct
            .status()
            .unwrap()
            .into_iter()
            .find(|s| s.axis == "Y")
            .unwrap();
        if y.state == multistep_controller::AxisState::Idle {
            break y;
        }
        assert!(t0.elapsed().as_secs() < 30, "Y never stopped: {y:?}");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    assert_eq!(y.position, 500);
    // The local board did not move.
    assert!(cmd(&svc.http, "status Y")["data"][0]
        .as_str()
        .unwrap()
        .contains("pos=0 "));
    // The other board's poller shows it within an update period or two.
    status_until(&svc.http, |s| s["boards"][1]["axes"][1]["position"] == 500);
    let e = cmd_on(&svc.http, 1, "move Q 1");
    assert_eq!(e["error"]["code"], 4, "{e}");

    other.child.kill().unwrap();
    other.child.wait().unwrap();
    let e = cmd_on(&svc.http, 1, "status");
    assert_eq!(e["ok"], false);
    assert_eq!(e["error"]["code"], 13, "{e}");
    let snap = status_until(&svc.http, |s| s["boards"][1]["error"].is_string());
    assert!(
        snap["boards"][1]["error"]
            .as_str()
            .unwrap()
            .contains("unreachable"),
        "{snap}"
    );
    assert_eq!(
        snap["boards"][0]["axes"].as_array().unwrap().len(),
        4,
        "the local board is still served"
    );
}

/// Polls `/api/status` until `done` holds (at most 30 s).
fn status_until(http: &str, done: impl Fn(&Value) -> bool) -> Value {
    let t0 = std::time::Instant::now();
    loop {
        let (_, body) = get(http, "/api/status", http, "");
        let snap: Value = serde_json::from_str(&body).unwrap();
        if done(&snap) {
            return snap;
        }
        assert!(
            t0.elapsed().as_secs() < 30,
            "status never got there: {snap}"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}
