//! `indi_multistep` under INDI's own `indiserver`, driven only by INDI's clients
//! `indi_getprop`, `indi_setprop` and `indi_eval`, against the controller's line-protocol
//! service (the one `multistep serve` runs) on the optics example board. Without
//! indiserver the tests skip with a message, except under CI=true, where they fail.

use multistep_controller::client::{Client, Endpoint};
use multistep_controller::{service, BoardConfig, Controller};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const DRIVER: &str = env!("CARGO_BIN_EXE_indi_multistep");
const CONFIG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/alpaca-optics.toml"
);
/// The controller wants it first on every connection, the driver's too.
const TOKEN: &str = "indi-test-token-0123456789";
/// The same optics beside a German equatorial mount, "Mount".
const MOUNT_CONFIG: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/telescope-mount.toml"
);
const F: &str = "Focus";
const R: &str = "Field rotator";
const W: &str = "Line filters";
/// The telescope of MOUNT_CONFIG.
const M: &str = "Mount";

/// indiserver and INDI's clients on the PATH? In CI (CI=true) their absence fails.
fn indi_present() -> bool {
    let ok = ["indiserver", "indi_getprop", "indi_setprop", "indi_eval"]
        .iter()
        .all(|t| {
            Command::new("sh")
                .args(["-c", &format!("command -v {t}")])
                .output()
                .is_ok_and(|o| o.status.success())
        });
    if !ok {
        let why = "indiserver and INDI's clients are missing (apt-get install indi-bin)";
        assert!(std::env::var("CI").as_deref() != Ok("true"), "{why}");
        eprintln!("skipped: {why}");
    }
    ok
}

/// A TCP relay in front of the controller that can be cut: the controller "goes away".
struct Relay {
    port: u16,
    cut: Arc<AtomicBool>,
    /// Connections are accepted and held open, never answered.
    mute: Arc<AtomicBool>,
    open: Arc<Mutex<Vec<TcpStream>>>,
}

impl Relay {
    fn start(to: u16) -> Relay {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = l.local_addr().unwrap().port();
        let cut = Arc::new(AtomicBool::new(false));
        let mute = Arc::new(AtomicBool::new(false));
        let open: Arc<Mutex<Vec<TcpStream>>> = Arc::default();
        let (c, m, o) = (cut.clone(), mute.clone(), open.clone());
        std::thread::spawn(move || {
            let mut held = Vec::new();
            for s in l.incoming().flatten() {
                if c.load(Ordering::SeqCst) {
                    continue; // dropped: closed at once
                }
                if m.load(Ordering::SeqCst) {
                    held.push(s);
                    continue;
                }
                let Ok(up) = TcpStream::connect(("127.0.0.1", to)) else {
                    continue;
                };
                o.lock()
                    .unwrap()
                    .extend([s.try_clone().unwrap(), up.try_clone().unwrap()]);
                pipe(s.try_clone().unwrap(), up.try_clone().unwrap());
                pipe(up, s);
            }
        });
        Relay {
            port,
            cut,
            mute,
            open,
        }
    }

    /// Mute: the connections under way are closed and new ones are held open but never
    /// answered (a controller that accepts and hangs).
    fn set_mute(&self, mute: bool) {
        self.mute.store(mute, Ordering::SeqCst);
        if mute {
            for s in self.open.lock().unwrap().drain(..) {
                let _ = s.shutdown(Shutdown::Both);
            }
        }
    }

    fn set_cut(&self, cut: bool) {
        self.cut.store(cut, Ordering::SeqCst);
        if cut {
            for s in self.open.lock().unwrap().drain(..) {
                let _ = s.shutdown(Shutdown::Both);
            }
        }
    }
}

fn pipe(mut from: TcpStream, mut to: TcpStream) {
    std::thread::spawn(move || {
        let mut buf = [0u8; 4096];
        while let Ok(n) = from.read(&mut buf) {
            if n == 0 || to.write_all(&buf[..n]).is_err() {
                break;
            }
        }
        let _ = to.shutdown(Shutdown::Both);
    });
}

/// The controller's service, the relay, and indiserver running the driver.
struct Rig {
    _dir: tempfile::TempDir,
    ctl_port: u16,
    relay: Relay,
    port: u16,
    server: Child,
}

impl Drop for Rig {
    fn drop(&mut self) {
        let _ = self.server.kill();
        let _ = self.server.wait();
    }
}

impl Rig {
    /// The controller's service in this process (as `multistep serve` runs it).
    fn start() -> Rig {
        Rig::start_with(&std::fs::read_to_string(CONFIG).unwrap())
    }

    /// The same, on the board config `text`.
    fn start_with(text: &str) -> Rig {
        Rig::start_env(text, &[])
    }

    /// On MOUNT_CONFIG, the telescope connected too.
    fn with_mount() -> Rig {
        let rig = Rig::start_env(&std::fs::read_to_string(MOUNT_CONFIG).unwrap(), &[]);
        rig.set(&format!("{M}.CONNECTION.CONNECT=On"));
        rig.wait(&format!("\"{M}.CONNECTION._STATE\"==1"));
        rig
    }

    /// The same, with `env` added to the driver's environment.
    fn start_env(text: &str, env: &[(&str, &str)]) -> Rig {
        let dir = tempfile::tempdir().unwrap();
        let config = BoardConfig::parse(text).unwrap();
        let ctl = Arc::new(Controller::open(&config, &dir.path().join("d"), 1.0).unwrap());
        // As `serve` does: the mount opened once, for the `mount` command.
        let section = multistep_alpaca::AlpacaSection::from_board(&config).unwrap();
        ctl.attach_mounts(&section.telescope).unwrap();
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        let ctl_port = l.local_addr().unwrap().port();
        let opts = service::TcpOptions {
            token: Some(TOKEN.into()),
            ..Default::default()
        };
        std::thread::spawn(move || service::serve_tcp_with(ctl, l, opts));
        Rig::around(dir, ctl_port, env)
    }

    /// indiserver and the driver for the controller listening on `ctl_port`.
    fn around(dir: tempfile::TempDir, ctl_port: u16, env: &[(&str, &str)]) -> Rig {
        let relay = Relay::start(ctl_port);
        let port = TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let mut server = Command::new("indiserver")
            // its own local socket name (abstract), so servers of parallel tests do not
            // collide; -r 0: a driver that dies is not restarted, the test sees it
            .args(["-p", &port.to_string(), "-r", "0"])
            .args(["-u", &format!("/tmp/indiserver-multistep-{port}"), DRIVER])
            .env("MULTISTEP_INDI_TOKEN", TOKEN)
            .env(
                "MULTISTEP_INDI_CONTROLLER",
                format!("tcp://127.0.0.1:{}", relay.port),
            )
            // a machine loaded by other tests can take seconds to answer (the service's
            // database commits): a generous deadline, which a test may set shorter
            .env("MULTISTEP_INDI_TIMEOUT", "30")
            .envs(env.iter().copied())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // indiserver's log (and the driver's stderr) under the test's output
        let err = server.stderr.take().unwrap();
        std::thread::spawn(move || {
            for l in BufReader::new(err).lines().map_while(Result::ok) {
                eprintln!("indiserver: {l}");
            }
        });
        let rig = Rig {
            _dir: dir,
            ctl_port,
            relay,
            port,
            server,
        };
        let end = Instant::now() + Duration::from_secs(60);
        while rig.get(&format!("{W}.CONNECTION.CONNECT")).is_none() {
            assert!(Instant::now() < end, "the driver's devices never showed");
        }
        for d in [F, R, W] {
            rig.set(&format!("{d}.CONNECTION.CONNECT=On"));
        }
        rig.wait(&format!("\"{W}.CONNECTION._STATE\"==1 && \"{R}.CONNECTION._STATE\"==1 && \"{F}.CONNECTION._STATE\"==1"));
        rig
    }

    fn tool(&self, tool: &str, args: &[&str]) -> std::process::Output {
        Command::new(tool)
            .args(["-p", &self.port.to_string()])
            .args(args)
            .output()
            .unwrap()
    }

    /// `indi_getprop`: one value, None when nothing answered within 10 s (it returns as
    /// soon as the value came).
    fn get(&self, spec: &str) -> Option<String> {
        self.get_within(spec, 10)
    }

    fn get_within(&self, spec: &str, seconds: u32) -> Option<String> {
        let o = self.tool("indi_getprop", &["-t", &seconds.to_string(), "-1", spec]);
        let v = String::from_utf8_lossy(&o.stdout).trim().to_string();
        (o.status.success() && !v.is_empty()).then_some(v)
    }

    fn num(&self, spec: &str) -> f64 {
        let v = self.get(spec).unwrap_or_else(|| panic!("{spec}: no value"));
        v.parse().unwrap_or_else(|_| panic!("{spec}={v}"))
    }

    /// Every property of `device` as `prop.element=value` lines.
    fn all(&self, device: &str) -> Vec<String> {
        let o = self.tool("indi_getprop", &["-t", "2", &format!("{device}.*.*")]);
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(|l| {
                l.strip_prefix(&format!("{device}."))
                    .unwrap_or(l)
                    .to_string()
            })
            .collect()
    }

    fn set(&self, spec: &str) {
        let o = self.tool("indi_setprop", &["-t", "20", spec]);
        assert!(o.status.success(), "indi_setprop {spec}: {o:?}");
    }

    /// `indi_eval -w`: waits (generous deadline) until `expr` holds; the operands as they
    /// changed on the way.
    fn wait(&self, expr: &str) -> String {
        let o = self.tool("indi_eval", &["-t", "90", "-o", "-w", expr]);
        // indi_eval prints the operands on stderr
        let s = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "indi_eval {expr}: {o:?}");
        s
    }

    /// Turns switch `element` of `prop` On and waits until it is, the property Ok.
    fn switch_on(&self, prop: &str, element: &str) {
        self.set(&format!("{prop}.{element}=On"));
        self.wait(&format!("\"{prop}._STATE\"==1 && \"{prop}.{element}\"==1"));
    }

    /// The line protocol's `status` position of `axis`.
    fn pos(&self, axis: &str) -> i64 {
        self.client()
            .status()
            .unwrap()
            .into_iter()
            .find(|s| s.axis == axis)
            .unwrap()
            .position
    }

    /// Polls the line protocol (generous deadline) until `axis` rests at `at`.
    fn settle(&self, axis: &str, at: i64) {
        let end = Instant::now() + Duration::from_secs(60);
        loop {
            let l = self.line(&format!("status {axis}")).join(" ");
            if l.contains("state=idle") && l.contains(&format!(" pos={at} ")) {
                return;
            }
            assert!(Instant::now() < end, "{l}");
        }
    }

    fn line(&self, line: &str) -> Vec<String> {
        self.client().request(line).unwrap()
    }

    /// The value of `key` in the line protocol's `mount` status line.
    fn mount(&self, key: &str) -> String {
        let l = self.line("mount").join(" ");
        let v = l
            .split(' ')
            .find_map(|kv| kv.strip_prefix(&format!("{key}=")));
        v.expect(&l).to_string()
    }

    /// [`Rig::mount`] as a number.
    fn mount_num(&self, key: &str) -> f64 {
        let v = self.mount(key);
        v.parse().unwrap_or_else(|_| panic!("mount {key}={v}"))
    }

    /// Sets the rotator's angle and waits for it; the angles shown on the way.
    fn turn_to(&self, a: f64) -> Vec<f64> {
        let abs = format!("{R}.ABS_ROTATOR_ANGLE");
        let angle = format!("{abs}.ANGLE");
        self.set(&format!("{angle}={a}"));
        let out = self.wait(&format!(
            "\"{abs}._STATE\"==1 && abs(\"{angle}\"-{a})<0.001"
        ));
        trail(&out, &angle)
    }

    /// A raw INDI client of `device`'s messages, registered (its properties defined to
    /// it) when this returns.
    fn watch(&self, device: &str) -> Watch {
        let mut s = TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        write!(s, "<getProperties version=\"1.7\" device=\"{device}\"/>").unwrap();
        let text: Arc<Mutex<String>> = Arc::default();
        let t = text.clone();
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while let Ok(n @ 1..) = s.read(&mut buf) {
                t.lock()
                    .unwrap()
                    .push_str(&String::from_utf8_lossy(&buf[..n]));
            }
        });
        let end = Instant::now() + Duration::from_secs(60);
        while !text.lock().unwrap().contains("defNumberVector") {
            assert!(Instant::now() < end, "no definitions for {device}");
            std::thread::sleep(Duration::from_millis(10));
        }
        Watch(text)
    }

    fn client(&self) -> Client {
        let at = Endpoint::Tcp(format!("127.0.0.1:{}", self.ctl_port));
        let mut c = Client::connect(&at).unwrap();
        c.authenticate(TOKEN).unwrap();
        c
    }
}

/// What indiserver sends one client about a device, collected from the moment
/// [`Rig::watch`] returns (a client registered before the change it looks at).
struct Watch(Arc<Mutex<String>>);

impl Watch {
    /// Every value `element` was given by a `setNumberVector`, in order.
    fn numbers(&self, element: &str) -> Vec<f64> {
        let key = format!("<oneNumber name=\"{element}\"");
        let text = self.0.lock().unwrap().clone();
        text.split("<setNumberVector")
            .skip(1)
            .filter_map(|m| {
                let (_, r) = m.split_once(&key)?;
                r.split_once('>')?.1.split('<').next()?.trim().parse().ok()
            })
            .collect()
    }
}

/// The trail of a number in `indi_eval -o` output.
fn trail(out: &str, spec: &str) -> Vec<f64> {
    out.lines()
        .filter_map(|l| l.strip_prefix(&format!("{spec}="))?.parse().ok())
        .collect()
}

#[test]
fn every_property_is_listed_with_its_type_and_permission() {
    if !indi_present() {
        return;
    }
    // The optics beside the mount: every kind of device.
    let rig = Rig::with_mount();
    // (device, property, perm, element names, kind)
    let want: [(&str, &str, &str, &[&str], char); 39] = [
        (F, "CONNECTION", "rw", &["CONNECT", "DISCONNECT"], 's'),
        (
            F,
            "DRIVER_INFO",
            "ro",
            &[
                "DRIVER_NAME",
                "DRIVER_EXEC",
                "DRIVER_VERSION",
                "DRIVER_INTERFACE",
            ],
            't',
        ),
        (
            F,
            "ABS_FOCUS_POSITION",
            "rw",
            &["FOCUS_ABSOLUTE_POSITION"],
            'n',
        ),
        (
            F,
            "REL_FOCUS_POSITION",
            "rw",
            &["FOCUS_RELATIVE_POSITION"],
            'n',
        ),
        (
            F,
            "FOCUS_MOTION",
            "rw",
            &["FOCUS_INWARD", "FOCUS_OUTWARD"],
            's',
        ),
        (F, "FOCUS_ABORT_MOTION", "rw", &["ABORT"], 's'),
        (F, "FOCUS_SYNC", "rw", &["FOCUS_SYNC_VALUE"], 'n'),
        (F, "FOCUS_MAX", "ro", &["FOCUS_MAX_VALUE"], 'n'),
        (
            F,
            "FOCUS_BACKLASH_TOGGLE",
            "rw",
            &["INDI_ENABLED", "INDI_DISABLED"],
            's',
        ),
        (
            F,
            "FOCUS_BACKLASH_STEPS",
            "rw",
            &["FOCUS_BACKLASH_VALUE"],
            'n',
        ),
        (R, "CONNECTION", "rw", &["CONNECT", "DISCONNECT"], 's'),
        (R, "DRIVER_INFO", "ro", &["DRIVER_INTERFACE"], 't'),
        (R, "ABS_ROTATOR_ANGLE", "rw", &["ANGLE"], 'n'),
        (R, "SYNC_ROTATOR_ANGLE", "rw", &["ANGLE"], 'n'),
        (
            R,
            "ROTATOR_REVERSE",
            "rw",
            &["INDI_ENABLED", "INDI_DISABLED"],
            's',
        ),
        (R, "ROTATOR_ABORT_MOTION", "rw", &["ABORT"], 's'),
        (R, "ROTATOR_TRAVEL", "ro", &["MIN", "MAX"], 'n'),
        (W, "CONNECTION", "rw", &["CONNECT", "DISCONNECT"], 's'),
        (W, "DRIVER_INFO", "ro", &["DRIVER_INTERFACE"], 't'),
        (W, "FILTER_SLOT", "rw", &["FILTER_SLOT_VALUE"], 'n'),
        (
            W,
            "FILTER_NAME",
            "ro",
            &["FILTER_SLOT_NAME_1", "FILTER_SLOT_NAME_5"],
            't',
        ),
        (M, "CONNECTION", "rw", &["CONNECT", "DISCONNECT"], 's'),
        (M, "DRIVER_INFO", "ro", &["DRIVER_INTERFACE"], 't'),
        (M, "EQUATORIAL_EOD_COORD", "rw", &["RA", "DEC"], 'n'),
        (M, "ON_COORD_SET", "rw", &["TRACK", "SLEW", "SYNC"], 's'),
        (M, "TELESCOPE_ABORT_MOTION", "rw", &["ABORT"], 's'),
        (
            M,
            "TELESCOPE_TRACK_STATE",
            "rw",
            &["TRACK_ON", "TRACK_OFF"],
            's',
        ),
        (
            M,
            "TELESCOPE_TRACK_MODE",
            "rw",
            &[
                "TRACK_SIDEREAL",
                "TRACK_SOLAR",
                "TRACK_LUNAR",
                "TRACK_KING",
                "TRACK_CUSTOM",
            ],
            's',
        ),
        (
            M,
            "TELESCOPE_TRACK_RATE",
            "rw",
            &["TRACK_RATE_RA", "TRACK_RATE_DE"],
            'n',
        ),
        (
            M,
            "TELESCOPE_SLEW_RATE",
            "rw",
            &["SLEW_GUIDE", "SLEW_CENTERING", "SLEW_FIND", "SLEW_MAX"],
            's',
        ),
        (
            M,
            "TELESCOPE_MOTION_NS",
            "rw",
            &["MOTION_NORTH", "MOTION_SOUTH"],
            's',
        ),
        (
            M,
            "TELESCOPE_MOTION_WE",
            "rw",
            &["MOTION_WEST", "MOTION_EAST"],
            's',
        ),
        (M, "TELESCOPE_PARK", "rw", &["PARK", "UNPARK"], 's'),
        (
            M,
            "TELESCOPE_TIMED_GUIDE_NS",
            "rw",
            &["TIMED_GUIDE_N", "TIMED_GUIDE_S"],
            'n',
        ),
        (
            M,
            "TELESCOPE_TIMED_GUIDE_WE",
            "rw",
            &["TIMED_GUIDE_W", "TIMED_GUIDE_E"],
            'n',
        ),
        (M, "GEOGRAPHIC_COORD", "ro", &["LAT", "LONG", "ELEV"], 'n'),
        (M, "TIME_UTC", "rw", &["UTC"], 't'),
        (M, "HORIZONTAL_COORD", "ro", &["ALT", "AZ"], 'n'),
        (
            M,
            "TELESCOPE_PIER_SIDE",
            "ro",
            &["PIER_WEST", "PIER_EAST"],
            's',
        ),
    ];
    for (d, p, perm, elements, kind) in want {
        assert_eq!(
            rig.get(&format!("{d}.{p}._PERM")).as_deref(),
            Some(perm),
            "{d}.{p}"
        );
        for e in elements {
            let v = rig
                .get(&format!("{d}.{p}.{e}"))
                .unwrap_or_else(|| panic!("{d}.{p}.{e} missing"));
            match kind {
                's' => assert!(v == "On" || v == "Off", "{d}.{p}.{e}={v}"),
                'n' => assert!(v.parse::<f64>().is_ok(), "{d}.{p}.{e}={v}"),
                _ => assert!(
                    v.parse::<f64>().is_err() || p == "DRIVER_INFO",
                    "{d}.{p}.{e}={v}"
                ),
            }
        }
    }
    // nothing else: every property of each device is one of those
    for d in [F, R, W, M] {
        for l in rig.all(d) {
            let p = l.split('.').next().unwrap();
            assert!(
                want.iter().any(|w| w.0 == d && w.1 == p),
                "{d}: unexpected {l}"
            );
        }
    }
    assert_eq!(
        rig.get(&format!("{F}.DRIVER_INFO.DRIVER_INTERFACE"))
            .as_deref(),
        Some("8")
    );
    assert_eq!(
        rig.get(&format!("{R}.DRIVER_INFO.DRIVER_INTERFACE"))
            .as_deref(),
        Some("4096")
    );
    assert_eq!(
        rig.get(&format!("{W}.DRIVER_INFO.DRIVER_INTERFACE"))
            .as_deref(),
        Some("16")
    );
    assert_eq!(rig.num(&format!("{F}.FOCUS_MAX.FOCUS_MAX_VALUE")), 32000.0);
    // INDI's UTC: ISO 8601 without a zone; the offset in hours.
    let utc = rig.get(&format!("{M}.TIME_UTC.UTC")).unwrap();
    assert!(utc.len() == 19 && utc.as_bytes()[10] == b'T', "{utc}");
    assert_eq!(rig.num(&format!("{M}.TIME_UTC.OFFSET")), 0.0);
    assert_eq!(
        rig.get(&format!("{W}.FILTER_NAME.FILTER_SLOT_NAME_2"))
            .as_deref(),
        Some("CaII K 393.4")
    );
    // DISCONNECT takes the device's own properties away, CONNECT brings them back
    rig.set(&format!("{F}.CONNECTION.DISCONNECT=On"));
    rig.wait(&format!("\"{F}.CONNECTION._STATE\"==0"));
    assert_eq!(
        // gone: nothing answers (2 s)
        rig.get_within(
            &format!("{F}.ABS_FOCUS_POSITION.FOCUS_ABSOLUTE_POSITION"),
            2
        ),
        None
    );
    rig.set(&format!("{F}.CONNECTION.CONNECT=On"));
    rig.wait(&format!("\"{F}.CONNECTION._STATE\"==1"));
    assert_eq!(
        rig.num(&format!("{F}.ABS_FOCUS_POSITION.FOCUS_ABSOLUTE_POSITION")),
        0.0
    );
}

#[test]
fn focus_sync_renames_the_position_without_moving() {
    if !indi_present() {
        return;
    }
    let rig = Rig::start();
    let abs = format!("{F}.ABS_FOCUS_POSITION");
    let sync = format!("{F}.FOCUS_SYNC");
    rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=16000"));
    rig.wait(&format!(
        "\"{abs}._STATE\"==1 && \"{abs}.FOCUS_ABSOLUTE_POSITION\"==16000"
    ));
    let status = || rig.client().status_of(&["focus".into()]).unwrap().remove(0);
    let before = status();
    rig.set(&format!("{sync}.FOCUS_SYNC_VALUE=10000"));
    rig.wait(&format!(
        "\"{sync}._STATE\"==1 && \"{abs}.FOCUS_ABSOLUTE_POSITION\"==10000"
    ));
    let after = status();
    // renamed, not moved: the last move is still the one to 16000
    assert_eq!(after.position, 10000);
    assert_eq!(
        (after.move_start, after.move_end, after.target),
        (before.move_start, before.move_end, None)
    );
    // beyond FOCUS_MAX or a fraction: Alert, the position stays
    for bad in ["40000", "12.5"] {
        rig.set(&format!("{sync}.FOCUS_SYNC_VALUE={bad}"));
        rig.wait(&format!("\"{sync}._STATE\"==3"));
        assert_eq!(rig.pos("focus"), 10000, "{bad}");
    }
    // a move from the new numbers
    rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=10500"));
    rig.wait(&format!(
        "\"{abs}._STATE\"==1 && \"{abs}.FOCUS_ABSOLUTE_POSITION\"==10500"
    ));
    assert_eq!(rig.pos("focus"), 10500);
}

#[test]
fn the_focuser_moves_and_agrees_with_status_and_bad_values_get_alert() {
    if !indi_present() {
        return;
    }
    let rig = Rig::start();
    let abs = format!("{F}.ABS_FOCUS_POSITION");
    rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=16000"));
    let out = rig.wait(&format!(
        "\"{abs}._STATE\"==1 && \"{abs}.FOCUS_ABSOLUTE_POSITION\"==16000"
    ));
    // Busy while it moved, through positions between
    assert!(out.contains(&format!("{abs}._STATE=2")), "{out}");
    let t = trail(&out, &format!("{abs}.FOCUS_ABSOLUTE_POSITION"));
    assert!(t.iter().any(|&x| x > 0.0 && x < 16000.0), "{t:?}");
    assert_eq!(rig.pos("focus"), 16000);
    // relative, outward (toward larger counts)
    rig.set(&format!("{F}.FOCUS_MOTION.FOCUS_OUTWARD=On"));
    rig.set(&format!(
        "{F}.REL_FOCUS_POSITION.FOCUS_RELATIVE_POSITION=1000"
    ));
    rig.wait(&format!(
        "\"{abs}._STATE\"==1 && \"{abs}.FOCUS_ABSOLUTE_POSITION\"==17000"
    ));
    assert_eq!(rig.pos("focus"), 17000);
    // beyond FOCUS_MAX, not a number, a fraction: Alert, nothing moves, the driver lives
    for bad in ["40000", "-1", "abc", "12.5"] {
        rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION={bad}"));
        rig.wait(&format!("\"{abs}._STATE\"==3"));
        assert_eq!(rig.pos("focus"), 17000, "{bad}");
        rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=17000"));
        rig.wait(&format!("\"{abs}._STATE\"==1"));
    }
    // abort stops a move on the way
    rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=0"));
    rig.wait(&format!("\"{abs}._STATE\"==2"));
    // the abort goes once the focuser has left 17000, however slowly a loaded machine got
    // the move going (an abort before the first step would rightly leave it at 17000)
    let end = Instant::now() + Duration::from_secs(60);
    while rig.pos("focus") == 17000 {
        assert!(Instant::now() < end, "the move to 0 never started");
    }
    rig.set(&format!("{F}.FOCUS_ABORT_MOTION.ABORT=On"));
    rig.wait(&format!("\"{abs}._STATE\"!=2"));
    let end = Instant::now() + Duration::from_secs(60);
    while !rig.line("status focus")[0].contains("state=idle") {
        assert!(Instant::now() < end);
    }
    let at = rig.pos("focus");
    assert!(at > 0 && at < 17000, "aborted at {at}");
    rig.wait(&format!("\"{abs}.FOCUS_ABSOLUTE_POSITION\"=={at}"));
}

#[test]
fn focus_backlash_is_the_controllers_setting_and_every_move_ends_on_its_target() {
    if !indi_present() {
        return;
    }
    let rig = Rig::start();
    let abs = format!("{F}.ABS_FOCUS_POSITION");
    let pos = format!("{abs}.FOCUS_ABSOLUTE_POSITION");
    let toggle = format!("{F}.FOCUS_BACKLASH_TOGGLE");
    // The focuser as the controller has it: load position, slack, motor (simulated).
    let focus = || {
        let s = rig.client().status().unwrap();
        let s = s.into_iter().find(|s| s.axis == "focus").unwrap();
        (s.position, s.slack, s.sim_position)
    };
    let backlash = || rig.line("get focus backlash")[0].clone();
    // The positions shown on the way to `n`.
    let to = |n: i64| {
        let w = rig.watch(F);
        rig.set(&format!("{pos}={n}"));
        rig.wait(&format!("\"{abs}._STATE\"==1 && \"{pos}\"=={n}"));
        assert_eq!(rig.pos("focus"), n);
        w.numbers("FOCUS_ABSOLUTE_POSITION")
    };
    let steps = format!("{F}.FOCUS_BACKLASH_STEPS");
    assert_eq!(
        rig.get(&format!("{toggle}.INDI_DISABLED")).as_deref(),
        Some("On")
    );
    rig.set(&format!("{steps}.FOCUS_BACKLASH_VALUE=300"));
    rig.wait(&format!(
        "\"{steps}._STATE\"==1 && \"{steps}.FOCUS_BACKLASH_VALUE\"==300"
    ));
    // Off: the controller's backlash stays 0.
    assert_eq!(backlash(), "backlash=0");
    to(3000);
    rig.set(&format!("{toggle}.INDI_ENABLED=On"));
    rig.wait(&format!("\"{toggle}._STATE\"==1"));
    assert_eq!(backlash(), "backlash=300");
    // On: a move that reverses turns the motor 300 more within the one move; the
    // position shown never leaves the stretch between start and target.
    let (_, slack, m0) = focus();
    assert_eq!(slack, 300, "from no backlash the side is the last move's");
    let t = to(2000);
    assert!(t.iter().all(|&x| (2000.0..=3000.0).contains(&x)), "{t:?}");
    let (at, slack, m1) = focus();
    assert_eq!((at, slack, m0 - m1), (2000, 0, 1300));
    let t = to(2500);
    assert!(t.iter().all(|&x| (2000.0..=2500.0).contains(&x)), "{t:?}");
    let (_, slack, m2) = focus();
    assert_eq!((slack, m2 - m1), (300, 800));
    // the same way again: exactly the distance
    let _ = to(2600);
    assert_eq!(focus(), (2600, 300, m2 + 100));
    // a relative move inward reverses too
    rig.set(&format!("{F}.FOCUS_MOTION.FOCUS_INWARD=On"));
    rig.set(&format!(
        "{F}.REL_FOCUS_POSITION.FOCUS_RELATIVE_POSITION=600"
    ));
    rig.wait(&format!("\"{abs}._STATE\"==1 && \"{pos}\"==2000"));
    assert_eq!(focus(), (2000, 0, m2 + 100 - 900));
    // Beyond the controller's range, a fraction, negative: Alert, the value stays.
    for bad in ["1000001", "2.5", "-1"] {
        rig.set(&format!("{steps}.FOCUS_BACKLASH_VALUE={bad}"));
        rig.wait(&format!("\"{steps}._STATE\"==3"));
        assert_eq!(rig.num(&format!("{steps}.FOCUS_BACKLASH_VALUE")), 300.0);
        assert_eq!(backlash(), "backlash=300");
    }
    // A new value goes to the controller while on.
    rig.set(&format!("{steps}.FOCUS_BACKLASH_VALUE=120"));
    rig.wait(&format!("\"{steps}._STATE\"==1"));
    assert_eq!(backlash(), "backlash=120");
    // Off again: the controller's backlash is 0, moves are their distance.
    rig.set(&format!("{toggle}.INDI_DISABLED=On"));
    rig.wait(&format!("\"{toggle}._STATE\"==1"));
    assert_eq!(backlash(), "backlash=0");
    let (_, _, m3) = focus();
    let _ = to(2400);
    assert_eq!(focus(), (2400, 0, m3 + 400));
}

#[test]
fn the_telescope_slews_aborts_tracks_guides_and_parks() {
    if !indi_present() {
        return;
    }
    let rig = Rig::with_mount();
    assert_eq!(
        rig.get(&format!("{M}.DRIVER_INFO.DRIVER_INTERFACE"))
            .as_deref(),
        Some("5")
    );
    // The site is the config's, read-only.
    assert_eq!(
        rig.get(&format!("{M}.GEOGRAPHIC_COORD._PERM")).as_deref(),
        Some("ro")
    );
    for (e, want) in [("LAT", 52.1), ("LONG", 4.4), ("ELEV", 10.0)] {
        let got = rig.num(&format!("{M}.GEOGRAPHIC_COORD.{e}"));
        assert!((got - want).abs() < 1e-9, "{e}={got}");
    }
    let on = |spec: &str| rig.get(&format!("{M}.{spec}")).as_deref() == Some("On");
    assert!(on("TELESCOPE_TRACK_STATE.TRACK_OFF") && on("TELESCOPE_PARK.UNPARK"));
    let mount = |k: &str| rig.mount(k);
    // One hour west of the meridian at Dec 30°: ON_COORD_SET TRACK slews and tracks.
    let lst: f64 = mount("lst").parse().unwrap();
    let ra = (lst - 1.0).rem_euclid(24.0);
    let eod = format!("{M}.EQUATORIAL_EOD_COORD");
    rig.set(&format!("{eod}.RA;DEC={ra};30"));
    rig.wait(&format!(
        "\"{eod}._STATE\"==1 && abs(\"{eod}.DEC\"-30)<0.001 && abs(\"{eod}.RA\"-{ra})<0.0001"
    ));
    assert!(on("TELESCOPE_TRACK_STATE.TRACK_ON"));
    assert_eq!(mount("tracking"), "1");
    let dec: f64 = mount("dec").parse().unwrap();
    assert!((dec - 30.0).abs() < 1.0 / 3600.0, "{dec}");

    // Abort on the way to Dec −20°: it stops short.
    rig.set(&format!("{eod}.RA;DEC={ra};-20"));
    rig.wait(&format!("\"{eod}._STATE\"==2 && \"{eod}.DEC\"<29"));
    rig.set(&format!("{M}.TELESCOPE_ABORT_MOTION.ABORT=On"));
    rig.wait(&format!("\"{eod}._STATE\"!=2"));
    let end = Instant::now() + Duration::from_secs(60);
    while mount("slewing") == "1" {
        assert!(Instant::now() < end, "the abort did not stop the slew");
    }
    // short of the target (a finished slew ends within 1"); on a loaded machine the
    // abort has come as late as 0.125 degrees before it
    let dec: f64 = mount("dec").parse().unwrap();
    assert!(dec < 29.0 && dec > -20.0 + 0.01, "{dec}");

    // Guiding: Busy for the pulse, Ok after, the duration back at 0.
    let ns = format!("{M}.TELESCOPE_TIMED_GUIDE_NS");
    rig.set(&format!("{ns}.TIMED_GUIDE_N;TIMED_GUIDE_S=1500;0"));
    rig.wait(&format!("\"{ns}._STATE\"==2"));
    rig.wait(&format!("\"{ns}._STATE\"==1 && \"{ns}.TIMED_GUIDE_N\"==0"));
    assert_eq!(mount("guiding"), "0");

    // Track mode and state.
    rig.set(&format!("{M}.TELESCOPE_TRACK_MODE.TRACK_LUNAR=On"));
    rig.wait(&format!("\"{M}.TELESCOPE_TRACK_MODE._STATE\"==1"));
    assert_eq!(mount("rate"), "lunar");
    rig.set(&format!("{M}.TELESCOPE_TRACK_STATE.TRACK_OFF=On"));
    rig.wait(&format!("\"{M}.TELESCOPE_TRACK_STATE._STATE\"==1"));
    assert_eq!(mount("tracking"), "0");

    // ON_COORD_SET SLEW: there, then tracking off.
    rig.set(&format!("{M}.ON_COORD_SET.SLEW=On"));
    rig.set(&format!("{eod}.RA;DEC={ra};40"));
    rig.wait(&format!(
        "\"{eod}._STATE\"==1 && abs(\"{eod}.DEC\"-40)<0.001"
    ));
    let end = Instant::now() + Duration::from_secs(60);
    while mount("tracking") == "1" {
        assert!(Instant::now() < end, "tracking stayed on after SLEW");
    }
    rig.wait(&format!("\"{M}.TELESCOPE_TRACK_STATE.TRACK_OFF\"==1"));

    // A target below the horizon: Alert, nothing moves.
    rig.set(&format!("{M}.ON_COORD_SET.TRACK=On"));
    rig.set(&format!(
        "{eod}.RA;DEC={};-50",
        (lst - 6.0).rem_euclid(24.0)
    ));
    rig.wait(&format!("\"{eod}._STATE\"==3"));
    assert_eq!(mount("slewing"), "0");

    // Park, then unpark.
    let park = format!("{M}.TELESCOPE_PARK");
    rig.set(&format!("{park}.PARK=On"));
    rig.wait(&format!("\"{park}._STATE\"==1 && \"{park}.PARK\"==1"));
    assert_eq!(mount("parked"), "1");
    assert_eq!(mount("tracking"), "0");
    rig.set(&format!("{park}.UNPARK=On"));
    rig.wait(&format!("\"{park}._STATE\"==1 && \"{park}.UNPARK\"==1"));
    assert_eq!(mount("parked"), "0");
}

#[test]
fn the_telescope_keeps_utc_moves_by_hand_and_tracks_at_each_rate() {
    if !indi_present() {
        return;
    }
    let rig = Rig::with_mount();

    // TIME_UTC sets the mount's clock; the zone offset is the client's, kept.
    let time = format!("{M}.TIME_UTC");
    rig.set(&format!("{time}.UTC;OFFSET=2030-06-15T12:00:00;2"));
    let end = Instant::now() + Duration::from_secs(60);
    while !rig.mount("utc").starts_with("2030-06-15T12:00:0") {
        assert!(Instant::now() < end, "utc={}", rig.mount("utc"));
    }
    rig.wait(&format!("\"{time}._STATE\"==1"));
    let utc = rig.get(&format!("{time}.UTC")).unwrap();
    assert!(utc.starts_with("2030-06-15T12:00:0"), "{utc}");
    assert_eq!(rig.num(&format!("{time}.OFFSET")), 2.0);
    // A time that is none, an offset beyond 14 h: Alert, the clock kept.
    for bad in ["UTC=noon", "UTC=2030-13-01T00:00:00", "OFFSET=15"] {
        rig.set(&format!("{time}.{bad}"));
        rig.wait(&format!("\"{time}._STATE\"==3"));
        assert!(rig.mount("utc").starts_with("2030-06-15T12:0"), "{bad}");
        rig.set(&format!("{time}.OFFSET=2"));
        rig.wait(&format!("\"{time}._STATE\"==1"));
    }

    // One hour west at Dec 30°, tracking; then north at the find rate for a second.
    let ra = (rig.mount_num("lst") - 1.0).rem_euclid(24.0);
    let eod = format!("{M}.EQUATORIAL_EOD_COORD");
    rig.set(&format!("{eod}.RA;DEC={ra};30"));
    rig.wait(&format!(
        "\"{eod}._STATE\"==1 && abs(\"{eod}.DEC\"-30)<0.001"
    ));
    rig.switch_on(&format!("{M}.TELESCOPE_SLEW_RATE"), "SLEW_FIND");
    let ns = format!("{M}.TELESCOPE_MOTION_NS");
    let dec0 = rig.mount_num("dec");
    rig.set(&format!("{ns}.MOTION_NORTH=On"));
    rig.wait(&format!("\"{ns}._STATE\"==2"));
    assert_eq!(rig.mount("slewing"), "1");
    std::thread::sleep(Duration::from_secs(1));
    rig.set(&format!("{ns}.MOTION_NORTH=Off"));
    rig.wait(&format!("\"{ns}._STATE\"==0 && \"{ns}.MOTION_NORTH\"==0"));
    // The axis slows to rest after the mount's move ends.
    let end = Instant::now() + Duration::from_secs(60);
    while rig.mount("slewing") == "1" || !rig.line("status dec").join(" ").contains("state=idle") {
        assert!(Instant::now() < end, "the motion did not stop");
    }
    let dec1 = rig.mount_num("dec");
    // 64 × sidereal is 0.267°/s: at least a second of it.
    assert!(dec1 - dec0 > 0.25 && dec1 - dec0 < 2.0, "{dec0} → {dec1}");
    std::thread::sleep(Duration::from_millis(500));
    let dec2 = rig.mount_num("dec");
    assert!(
        (dec2 - dec1).abs() < 1e-6,
        "Dec still moves: {dec1} → {dec2}"
    );
    // South comes back; an abort ends it.
    rig.set(&format!("{ns}.MOTION_SOUTH=On"));
    rig.wait(&format!("\"{ns}._STATE\"==2"));
    std::thread::sleep(Duration::from_millis(500));
    rig.set(&format!("{M}.TELESCOPE_ABORT_MOTION.ABORT=On"));
    rig.wait(&format!("\"{ns}._STATE\"==0 && \"{ns}.MOTION_SOUTH\"==0"));
    let end = Instant::now() + Duration::from_secs(60);
    while rig.mount("slewing") == "1" {
        assert!(Instant::now() < end, "the abort did not stop the motion");
    }
    assert!(rig.mount_num("dec") < dec1 - 0.05);
    // West: the hour angle grows (tracking alone keeps it).
    let we = format!("{M}.TELESCOPE_MOTION_WE");
    let ha0 = rig.mount_num("ha");
    rig.set(&format!("{we}.MOTION_WEST=On"));
    rig.wait(&format!("\"{we}._STATE\"==2"));
    std::thread::sleep(Duration::from_millis(500));
    rig.set(&format!("{we}.MOTION_WEST=Off"));
    rig.wait(&format!("\"{we}._STATE\"==0"));
    let ha1 = rig.mount_num("ha");
    assert!(ha1 - ha0 > 0.1 && ha1 - ha0 < 1.0, "{ha0} → {ha1}");

    // Each track mode sets the mount's drive rate, with no offsets.
    let mode = format!("{M}.TELESCOPE_TRACK_MODE");
    for (m, rate) in [
        ("TRACK_LUNAR", "lunar"),
        ("TRACK_SOLAR", "solar"),
        ("TRACK_KING", "king"),
        ("TRACK_SIDEREAL", "sidereal"),
    ] {
        rig.switch_on(&mode, m);
        assert_eq!(rig.mount("rate"), rate, "{m}");
        assert_eq!(
            (rig.mount_num("raoffset"), rig.mount_num("decoffset")),
            (0.0, 0.0)
        );
    }
    // Custom: sidereal less the RA offset that gives TRACK_RATE_RA, Dec's rate as given.
    let rate = format!("{M}.TELESCOPE_TRACK_RATE");
    rig.set(&format!("{rate}.TRACK_RATE_RA;TRACK_RATE_DE=15;2.5"));
    rig.wait(&format!(
        "\"{rate}._STATE\"==1 && \"{rate}.TRACK_RATE_DE\"==2.5"
    ));
    // Kept until the mode is custom.
    assert_eq!(rig.mount_num("decoffset"), 0.0);
    rig.switch_on(&mode, "TRACK_CUSTOM");
    assert_eq!(rig.mount("rate"), "sidereal");
    let want = (15.041_067 - 15.0) * 0.997_269_566_3 / 15.0;
    assert!((rig.mount_num("raoffset") - want).abs() < 1e-9);
    assert_eq!(rig.mount_num("decoffset"), 2.5);
    // In custom mode a new rate goes to the mount at once.
    rig.set(&format!("{rate}.TRACK_RATE_DE=-1"));
    rig.wait(&format!(
        "\"{rate}._STATE\"==1 && \"{rate}.TRACK_RATE_DE\"==-1"
    ));
    assert_eq!(rig.mount_num("decoffset"), -1.0);
    // Beyond twice sidereal, not a number: Alert, the rates kept.
    for bad in ["TRACK_RATE_RA=100", "TRACK_RATE_DE=fast"] {
        rig.set(&format!("{rate}.{bad}"));
        rig.wait(&format!("\"{rate}._STATE\"==3"));
        assert_eq!(rig.mount_num("decoffset"), -1.0, "{bad}");
        assert!((rig.num(&format!("{rate}.TRACK_RATE_RA")) - 15.0).abs() < 1e-9);
        rig.set(&format!("{rate}.TRACK_RATE_DE=-1"));
        rig.wait(&format!("\"{rate}._STATE\"==1"));
    }
    // Back to sidereal: the offsets go.
    rig.switch_on(&mode, "TRACK_SIDEREAL");
    assert_eq!(
        (rig.mount_num("raoffset"), rig.mount_num("decoffset")),
        (0.0, 0.0)
    );
}

/// The solar telescope's mount and a guide scope's fork on one board.
const TWO_TELESCOPES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../examples/two-telescopes.toml"
);

#[test]
fn two_telescopes_are_two_devices_each_driving_its_own_mount() {
    if !indi_present() {
        return;
    }
    let rig = Rig::start_env(&std::fs::read_to_string(TWO_TELESCOPES).unwrap(), &[]);
    const G: &str = "Guide scope";
    for d in [M, G] {
        rig.set(&format!("{d}.CONNECTION.CONNECT=On"));
        rig.wait(&format!("\"{d}.CONNECTION._STATE\"==1"));
        assert_eq!(
            rig.get(&format!("{d}.DRIVER_INFO.DRIVER_INTERFACE"))
                .as_deref(),
            Some("5"),
            "{d}"
        );
    }
    let status = |k: usize, key: &str| -> f64 {
        let l = rig.line(&format!("mount {k}")).join(" ");
        let v = l
            .split(' ')
            .find_map(|kv| kv.strip_prefix(&format!("{key}=")));
        v.and_then(|v| v.parse().ok()).expect(&l)
    };
    // The guide scope slews to one hour west at Dec 20°; the main mount stays home.
    let lst = status(1, "lst");
    let ra = (lst - 1.0).rem_euclid(24.0);
    let eod = format!("{G}.EQUATORIAL_EOD_COORD");
    rig.set(&format!("{eod}.RA;DEC={ra};20"));
    rig.wait(&format!(
        "\"{eod}._STATE\"==1 && abs(\"{eod}.DEC\"-20)<0.001"
    ));
    assert!((status(1, "dec") - 20.0).abs() < 1.0 / 3600.0);
    assert_eq!(status(0, "dec"), 90.0);
    assert_eq!((rig.pos("ha"), rig.pos("dec")), (0, 0));
    assert_ne!(rig.pos("gdec"), 0);
    // Each device reads its own mount.
    assert!((rig.num(&format!("{M}.EQUATORIAL_EOD_COORD.DEC")) - 90.0).abs() < 1e-6);
    assert!((rig.num(&format!("{eod}.DEC")) - 20.0).abs() < 0.001);
}

#[test]
fn the_rotator_turns_inside_its_travel_and_the_wheel_changes_filter() {
    if !indi_present() {
        return;
    }
    let rig = Rig::start();
    let abs = format!("{R}.ABS_ROTATOR_ANGLE");
    let angle = format!("{abs}.ANGLE");
    let goto = |a: f64| rig.turn_to(a);
    // free: 350 -> 10 the short way, through 0
    goto(350.0);
    let t = goto(10.0);
    assert!(t.iter().all(|&x| !(10.5..349.5).contains(&x)), "{t:?}");
    assert_eq!(rig.pos("rot"), 400);
    // sync: the sky angle moves, the axis does not
    rig.set(&format!("{R}.SYNC_ROTATOR_ANGLE.ANGLE=100"));
    rig.wait(&format!("abs(\"{angle}\"-100)<0.001"));
    assert_eq!(rig.pos("rot"), 400);

    // the wheel: slot 3 is at 2560
    let slot = format!("{W}.FILTER_SLOT");
    rig.set(&format!("{slot}.FILTER_SLOT_VALUE=3"));
    rig.wait(&format!(
        "\"{slot}._STATE\"==1 && \"{slot}.FILTER_SLOT_VALUE\"==3"
    ));
    assert_eq!(rig.pos("wheel"), 2560);
    // "Clear" is a named position not yet saved; 0 and 6 are not slots
    for bad in ["5", "0", "6", "x"] {
        rig.set(&format!("{slot}.FILTER_SLOT_VALUE={bad}"));
        rig.wait(&format!("\"{slot}._STATE\"==3"));
        assert_eq!(rig.pos("wheel"), 2560, "{bad}");
        rig.set(&format!("{slot}.FILTER_SLOT_VALUE=3"));
        rig.wait(&format!("\"{slot}._STATE\"==1"));
    }
    rig.line("moveto wheel 5120");
    rig.settle("wheel", 5120);
    rig.line("save Clear wheel");
    rig.line("moveto wheel 0");
    rig.settle("wheel", 0);
    rig.set(&format!("{slot}.FILTER_SLOT_VALUE=5"));
    rig.wait(&format!(
        "\"{slot}._STATE\"==1 && \"{slot}.FILTER_SLOT_VALUE\"==5"
    ));
    assert_eq!(rig.pos("wheel"), 5120);
}

#[test]
fn the_rotator_keeps_inside_the_travel_of_the_board_config() {
    if !indi_present() {
        return;
    }
    let text = std::fs::read_to_string(CONFIG).unwrap().replace(
        "name = \"Field rotator\"\n",
        "name = \"Field rotator\"\nmin_deg = 0.0\nmax_deg = 300.0\n",
    );
    let rig = Rig::start_with(&text);
    let abs = format!("{R}.ABS_ROTATOR_ANGLE");
    let angle = format!("{abs}.ANGLE");
    let goto = |a: f64| rig.turn_to(a);
    // the travel is the config's, shown read-only
    let travel = format!("{R}.ROTATOR_TRAVEL");
    assert_eq!(rig.num(&format!("{travel}.MIN")), 0.0);
    assert_eq!(rig.num(&format!("{travel}.MAX")), 300.0);
    // 10 -> 290 the long way (+280), never through 300..360
    goto(10.0);
    let t = goto(290.0);
    assert!(t.iter().all(|&x| (9.99..=290.01).contains(&x)), "{t:?}");
    assert!(t.iter().any(|&x| x > 100.0 && x < 200.0), "{t:?}");
    assert_eq!(rig.pos("rot"), 290 * 40);
    // and back the same side
    let t = goto(10.0);
    assert!(t.iter().all(|&x| (9.99..=290.01).contains(&x)), "{t:?}");
    // an angle beyond the travel: Alert, no move
    rig.set(&format!("{angle}=330"));
    rig.wait(&format!("\"{abs}._STATE\"==3"));
    assert_eq!(rig.pos("rot"), 400);
}

#[test]
fn the_driver_reports_the_controller_going_away_and_comes_back() {
    if !indi_present() {
        return;
    }
    let rig = Rig::start();
    let abs = format!("{F}.ABS_FOCUS_POSITION");
    rig.relay.set_cut(true);
    rig.wait(&format!(
        "\"{abs}._STATE\"==3 && \"{W}.FILTER_SLOT._STATE\"==3"
    ));
    // a move asked for meanwhile is refused with Alert, and the driver still answers
    rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=1000"));
    rig.wait(&format!("\"{abs}._STATE\"==3"));
    assert_eq!(rig.pos("focus"), 0);
    rig.relay.set_cut(false);
    rig.wait(&format!("\"{abs}._STATE\"==1"));
    rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=1000"));
    rig.wait(&format!(
        "\"{abs}._STATE\"==1 && \"{abs}.FOCUS_ABSOLUTE_POSITION\"==1000"
    ));
    assert_eq!(rig.pos("focus"), 1000);
}

#[test]
fn a_controller_that_never_answers_puts_the_properties_in_alert_saying_so() {
    if !indi_present() {
        return;
    }
    let text = std::fs::read_to_string(CONFIG).unwrap();
    let rig = Rig::start_env(&text, &[("MULTISTEP_INDI_TIMEOUT", "1")]);
    let abs = format!("{F}.ABS_FOCUS_POSITION");
    // A client of indiserver that sees every message of the focuser, with its text.
    let mut watch = TcpStream::connect(("127.0.0.1", rig.port)).unwrap();
    write!(watch, "<getProperties version=\"1.7\" device=\"{F}\"/>").unwrap();
    watch
        .set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    rig.relay.set_mute(true);
    rig.wait(&format!(
        "\"{abs}._STATE\"==3 && \"{W}.FILTER_SLOT._STATE\"==3"
    ));
    // A move asked for meanwhile gets its Alert too, and the driver still answers.
    rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=1000"));
    let mut seen = Vec::new();
    let end = Instant::now() + Duration::from_secs(60);
    // The reconnect's `auth` (its token not shown) or the request, unanswered (the
    // quotes are XML's `&apos;`).
    let says = |s: &str| s.contains("no answer to &apos;") && s.contains(" within 1 s");
    while !says(&String::from_utf8_lossy(&seen)) {
        assert!(Instant::now() < end, "{}", String::from_utf8_lossy(&seen));
        let mut buf = [0u8; 4096];
        match watch.read(&mut buf) {
            Ok(n) => seen.extend_from_slice(&buf[..n]),
            Err(e) => assert!(
                matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ),
                "{e}"
            ),
        }
    }
    let seen = String::from_utf8_lossy(&seen);
    assert!(seen.contains("state=\"Alert\""), "{seen}");
    assert!(rig.get(&format!("{F}.CONNECTION.CONNECT")).is_some());
    // Answered again: back to Ok, and the move never reached the controller.
    rig.relay.set_mute(false);
    rig.wait(&format!("\"{abs}._STATE\"==1"));
    assert_eq!(rig.pos("focus"), 0);
}

#[test]
fn the_devices_command_answers_the_boards_alpaca_section_as_json() {
    let dir = tempfile::tempdir().unwrap();
    let config = BoardConfig::load(std::path::Path::new(CONFIG)).unwrap();
    let ctl = Controller::open(&config, &dir.path().join("d"), 1.0).unwrap();
    let r = ctl.execute_bytes(b"devices");
    assert!(r.result.is_ok() && r.data.len() == 1, "{r:?}");
    let json: serde_json::Value = serde_json::from_str(&r.data[0]).unwrap();
    assert_eq!(json["focuser"][0]["axis"], "focus");
    assert_eq!(json["filterwheel"][0]["slots"][4]["name"], "Clear");
    let bare = BoardConfig::parse("[[axis]]\nname = \"X\"\n").unwrap();
    let ctl = Controller::open(&bare, &dir.path().join("e"), 1.0).unwrap();
    assert_eq!(ctl.execute_bytes(b"devices").data, vec!["{}".to_string()]);
    let e = ctl
        .execute_bytes(b"devices x")
        .result
        .unwrap_err()
        .to_string();
    assert!(e.contains("usage: devices"), "{e}");
}

/// `multistep serve` beside this driver in the target directory, as the workspace's
/// build leaves it; None (skipped with a message, a failure under CI=true) without it.
fn multistep_serve() -> Option<std::path::PathBuf> {
    let bin = std::path::Path::new(DRIVER).with_file_name("multistep");
    let ok = bin.exists();
    if !ok {
        let why = format!("{} is not built (cargo build -p multistep)", bin.display());
        assert!(std::env::var("CI").as_deref() != Ok("true"), "{why}");
        eprintln!("skipped: {why}");
    }
    ok.then_some(bin)
}

struct Serve(Child);

impl Drop for Serve {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn under_multistep_serve_the_focuser_moves_to_where_status_says() {
    if !indi_present() {
        return;
    }
    let Some(bin) = multistep_serve() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(bin)
        .args(["serve", "--listen", "127.0.0.1:0", "--listen-token", TOKEN])
        .arg("--data")
        .arg(dir.path().join("d"))
        .args(["--board-config", CONFIG])
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    // "board optics listening on tcp://127.0.0.1:PORT"
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    let _serve = Serve(child);
    let port: u16 = first
        .trim()
        .rsplit(':')
        .next()
        .unwrap()
        .parse()
        .expect(&first);
    let rig = Rig::around(dir, port, &[]);
    let abs = format!("{F}.ABS_FOCUS_POSITION");
    rig.set(&format!("{abs}.FOCUS_ABSOLUTE_POSITION=2500"));
    rig.wait(&format!(
        "\"{abs}._STATE\"==1 && \"{abs}.FOCUS_ABSOLUTE_POSITION\"==2500"
    ));
    assert_eq!(rig.pos("focus"), 2500);
    rig.set(&format!("{W}.FILTER_SLOT.FILTER_SLOT_VALUE=2"));
    rig.wait(&format!(
        "\"{W}.FILTER_SLOT._STATE\"==1 && \"{W}.FILTER_SLOT.FILTER_SLOT_VALUE\"==2"
    ));
    assert_eq!(rig.pos("wheel"), 1280);
}
