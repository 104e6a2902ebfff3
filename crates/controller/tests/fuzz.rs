//! A random-sequence fuzz of the board behind the protocol: random command lines, random
//! settings (in range, at the bounds, out of range, garbage) and random bytes, run on a
//! live controller. Nothing panics, every line gets exactly one status line, and no
//! command does more simulation work than the budget allows or takes long.
//!
//! `PROPTEST_CASES=N` runs more sequences (the default is kept small for CI).

use multistep_controller::axis::RANGES;
use multistep_controller::controller::WORK_BUDGET;
use multistep_controller::protocol::{parse_status_line, Line, LineReader, MAX_LINE};
use multistep_controller::{BoardConfig, Controller};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::io::BufReader;
use std::time::{Duration, Instant};

const AXES: [&str; 4] = ["X", "Y", "Z", "A"];

fn axis() -> impl Strategy<Value = String> {
    prop_oneof![
        8 => proptest::sample::select(&AXES[..]).prop_map(String::from),
        1 => Just("Q".to_string()),
    ]
}

/// A number as text: small, at a range bound, huge, negative, fractional, odd forms.
fn number() -> impl Strategy<Value = String> {
    let bounds: Vec<String> = RANGES
        .iter()
        .flat_map(|r| [r.min, r.max, r.min - 1.0, r.max * 10.0 + 1.0])
        .map(|v| format!("{v}"))
        .collect();
    prop_oneof![
        (-5000i64..5000).prop_map(|n| n.to_string()),
        proptest::sample::select(bounds),
        any::<i64>().prop_map(|n| n.to_string()),
        any::<u64>().prop_map(|n| n.to_string()),
        any::<f64>().prop_map(|x| format!("{x}")),
        proptest::sample::select(vec![
            "0",
            "-0",
            "1e-320",
            "1e308",
            "nan",
            "inf",
            "-inf",
            "none",
            "0x10",
            "",
            "1.5u",
            "-9223372036854775808",
            "9223372036854775807",
            "18446744073709551615",
        ])
        .prop_map(String::from),
    ]
}

fn setting_key() -> impl Strategy<Value = String> {
    let mut keys: Vec<&str> = RANGES.iter().map(|r| r.key).collect();
    keys.extend([
        "profile",
        "invert_dir",
        "sim.seed",
        "nope",
        "sim.nope",
        "enable_active_high",
        "release_keeps_position",
    ]);
    proptest::sample::select(keys).prop_map(String::from)
}

fn amount() -> impl Strategy<Value = String> {
    prop_oneof![
        (-20_000i64..20_000).prop_map(|n| n.to_string()),
        (-100.0f64..100.0).prop_map(|u| format!("{u}u")),
        number(),
    ]
}

fn opts() -> impl Strategy<Value = String> {
    proptest::collection::vec(
        (
            proptest::sample::select(vec![
                "vmax", "amax", "jmax", "accel", "cruise", "decel", "vs", "ve", "profile",
                "preset", "rho",
            ]),
            prop_oneof![number(), Just("scurve".to_string()), Just("p1".to_string())],
        )
            .prop_map(|(k, v)| format!("{k}={v}")),
        0..3,
    )
    .prop_map(|w| w.join(" "))
}

/// A tracking rate: steps/s, units/s, fractions, names, and anything `number` makes.
fn rate() -> impl Strategy<Value = String> {
    prop_oneof![
        (-5000.0f64..5000.0).prop_map(|v| format!("{v}")),
        (-50.0f64..50.0).prop_map(|v| format!("{v}u")),
        (1u64..100_000, 1u64..1000).prop_map(|(n, d)| format!("-{n}/{d}")),
        proptest::sample::select(vec!["fast", "slow", "15041/324", "1/0", "abc", "-"])
            .prop_map(String::from),
        number(),
    ]
}

fn track_opts() -> impl Strategy<Value = String> {
    proptest::collection::vec(
        (
            proptest::sample::select(vec!["accel", "lease", "amax", "x"]),
            number(),
        )
            .prop_map(|(k, v)| format!("{k}={v}")),
        0..2,
    )
    .prop_map(|w| w.join(" "))
}

fn line() -> impl Strategy<Value = Vec<u8>> {
    let text = prop_oneof![
        4 => (axis(), amount(), opts()).prop_map(|(a, n, o)| format!("move {a} {n} {o}")),
        2 => (axis(), amount(), opts()).prop_map(|(a, n, o)| format!("moveto {a} {n} {o}")),
        2 => (axis(), amount(), axis(), amount(), any::<bool>())
            .prop_map(|(a, n, b, m, s)| format!("group move {a}={n} {b}={m} {}", if s { "sync" } else { "" })),
        5 => (axis(), setting_key(), number()).prop_map(|(a, k, v)| format!("set {a} {k} {v}")),
        2 => axis().prop_map(|a| format!("home {a}")),
        1 => axis().prop_map(|a| format!("stop {a}")),
        1 => Just("stop".to_string()),
        2 => Just("estop".to_string()),
        2 => Just("reset".to_string()),
        2 => Just("status".to_string()),
        1 => Just("status json".to_string()),
        1 => Just("info".to_string()),
        1 => (axis(), setting_key()).prop_map(|(a, k)| format!("get {a} {k}")),
        1 => (axis(), number()).prop_map(|(a, n)| format!("sim {a} slip {n}")),
        1 => Just("save p1".to_string()),
        1 => opts().prop_map(|o| format!("goto p1 {o}")),
        1 => opts().prop_map(|o| format!("preset p1 vmax=100 {o}")),
        1 => Just("auth whatever".to_string()),
        3 => (axis(), rate(), track_opts()).prop_map(|(a, r, o)| format!("track {a} {r} {o}")),
        1 => rate().prop_map(|r| format!("rate fast {r}")),
        1 => Just("rates".to_string()),
        1 => axis().prop_map(|a| format!("release {a}")),
        1 => axis().prop_map(|a| format!("energize {a}")),
    ];
    prop_oneof![
        9 => text.prop_map(String::into_bytes),
        1 => proptest::collection::vec(any::<u8>().prop_filter("no newline", |b| *b != b'\n'), 0..64),
    ]
}

/// No answer may take this long (generous: the machine is shared and the build is debug).
const SLOW: Duration = Duration::from_secs(5);

#[test]
fn random_command_sequences_with_random_settings() {
    let mut runner = TestRunner::new(Config {
        cases: std::env::var("PROPTEST_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(24),
        failure_persistence: None,
        ..Config::default()
    });
    let t0 = Instant::now();
    let seqs = (1.0f64..2000.0, proptest::collection::vec(line(), 1..40));
    let commands = std::sync::atomic::AtomicUsize::new(0);
    runner
        .run(&seqs, |(time_scale, lines)| {
            let dir = tempfile::tempdir().unwrap();
            let ctl = Controller::open(&BoardConfig::default(), dir.path(), time_scale).unwrap();
            for l in &lines {
                let t = Instant::now();
                let reply = ctl.execute_bytes(l);
                let took = t.elapsed();
                commands.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let text = reply.to_text();
                let status: Vec<&str> = text
                    .lines()
                    .filter(|x| parse_status_line(x).is_some())
                    .collect();
                prop_assert_eq!(
                    status.len(),
                    1,
                    "{:?} → {}",
                    String::from_utf8_lossy(l),
                    text
                );
                prop_assert!(parse_status_line(text.lines().last().unwrap()).is_some());
                prop_assert!(
                    took < SLOW,
                    "{:?} took {:?}",
                    String::from_utf8_lossy(l),
                    took
                );
            }
            // Work, counted: no single advance did more than the budget and one slice.
            let (_, most) = ctl.with_board(|b, _| b.work());
            prop_assert!(
                most <= 2 * WORK_BUDGET,
                "one advance did {} units of work",
                most
            );
            let t = Instant::now();
            ctl.execute_bytes(b"estop");
            prop_assert!(t.elapsed() < SLOW);
            Ok(())
        })
        .unwrap();
    eprintln!(
        "fuzz: {} commands in {:?}",
        commands.into_inner(),
        t0.elapsed()
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, ..ProptestConfig::default() })]

    /// Lines split across reads in any way: the complete lines come out whole (the limit
    /// counted without `\n` or `\r\n`), and a last line without `\n` never does.
    #[test]
    fn lines_come_out_whole_however_the_bytes_arrive(
        lines in proptest::collection::vec((proptest::collection::vec(
            any::<u8>().prop_filter("no newline", |b| *b != b'\n' && *b != b'\r'), 0..50),
            0usize..4100, any::<bool>()), 0..8),
        tail in proptest::collection::vec(any::<u8>().prop_filter("no newline", |b| *b != b'\n'), 0..20),
        cap in 1usize..64,
    ) {
        let mut input = Vec::new();
        let mut want = Vec::new();
        for (bytes, pad, crlf) in &lines {
            let mut l = bytes.clone();
            l.extend(std::iter::repeat_n(b'p', *pad));
            input.extend_from_slice(&l);
            input.extend_from_slice(if *crlf { b"\r\n" } else { b"\n" });
            want.push(if l.len() > MAX_LINE { Line::TooLong } else { Line::Text(l) });
        }
        input.extend_from_slice(&tail);
        let mut r = BufReader::with_capacity(cap, &input[..]);
        let mut lr = LineReader::new();
        for w in want {
            prop_assert_eq!(lr.read(&mut r).unwrap(), w);
        }
        prop_assert_eq!(lr.read(&mut r).unwrap(), Line::Eof);
    }
}
