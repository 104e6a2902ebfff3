//! The line protocol under random input: nothing panics, every line gets exactly one
//! answer, and well-formed commands read back as what was written.

use multistep_controller::protocol::{
    self, parse, parse_bytes, read_line, Amount, Command, Line, MoveOpts, MAX_LINE,
};
use multistep_controller::{service, BoardConfig, Controller};
use multistep_core::MoveParams;
use proptest::prelude::*;
use std::io::BufReader;

fn count_status_lines(out: &str) -> usize {
    out.lines()
        .filter(|l| protocol::parse_status_line(l).is_some())
        .count()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic_the_parser(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let _ = parse_bytes(&bytes);
    }

    #[test]
    fn random_words_never_panic_the_parser(words in proptest::collection::vec(
        prop_oneof![
            Just("move".to_string()), Just("moveto".to_string()), Just("group".to_string()),
            Just("X".to_string()), Just("sync".to_string()), Just("vmax=".to_string()),
            Just("set".to_string()), Just("home".to_string()), Just("-9223372036854775808".to_string()),
            "[a-z=.0-9u-]{0,12}", Just("1e999u".to_string()), Just("NaN".to_string()),
        ], 0..8)) {
        let _ = parse(&words.join(" "));
    }

    #[test]
    fn move_commands_read_back(axis in "[A-Za-z][A-Za-z0-9_]{0,8}", n in any::<i64>(),
                               vmax in proptest::option::of(1.0f64..1e6), amax in proptest::option::of(1.0f64..1e7),
                               profile in proptest::option::of(prop_oneof![Just("trapezoid"), Just("scurve")])) {
        prop_assume!(!axis.eq_ignore_ascii_case("ok") && !axis.eq_ignore_ascii_case("all"));
        let opts = MoveOpts { profile: profile.map(String::from), params: MoveParams { vmax, amax, ..MoveParams::default() }, ..MoveOpts::default() };
        let line = format!("move {axis} {n} {}", opts.words().join(" "));
        prop_assert_eq!(parse(&line).unwrap(), Command::Move { axis, by: Amount::Steps(n), opts });
    }

    #[test]
    fn reading_lines_never_holds_more_than_the_limit(len in 0usize..10_000, tail in "[a-z ]{0,20}") {
        let mut input = vec![b'a'; len];
        input.push(b'\n');
        input.extend_from_slice(tail.as_bytes());
        input.push(b'\n');
        let mut r = BufReader::with_capacity(64, &input[..]);
        let first = read_line(&mut r).unwrap();
        if len > MAX_LINE {
            prop_assert_eq!(first, Line::TooLong);
        } else {
            prop_assert_eq!(first, Line::Text(vec![b'a'; len]));
        }
        prop_assert_eq!(read_line(&mut r).unwrap(), Line::Text(tail.into_bytes()));
        prop_assert_eq!(read_line(&mut r).unwrap(), Line::Eof);
    }
}

/// A whole connection fed random bytes: one `ok`/`error:` line per input line, and the
/// connection still answers a real command afterwards.
#[test]
fn a_connection_answers_every_random_line_exactly_once() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: 300,
        ..ProptestConfig::default()
    });
    let lines = proptest::collection::vec(
        prop_oneof![
            proptest::collection::vec(
                any::<u8>().prop_filter("no newline", |b| *b != b'\n'),
                0..200
            ),
            proptest::collection::vec(Just(b'x'), 4000..4200),
            Just(b"status X".to_vec()),
            Just(b"get Y vmax".to_vec()),
            Just(b"\xff\xfe move".to_vec()),
        ],
        1..20,
    );
    runner
        .run(&lines, |lines| {
            let mut input = Vec::new();
            for l in &lines {
                input.extend_from_slice(l);
                input.push(b'\n');
            }
            input.extend_from_slice(b"version\n");
            let mut out = Vec::new();
            service::serve_stream(&ctl, &input[..], &mut out).unwrap();
            let out = String::from_utf8(out).unwrap();
            prop_assert_eq!(count_status_lines(&out), lines.len() + 1, "{}", out);
            prop_assert!(out.ends_with("ok\n"));
            prop_assert!(out.contains("multistep-controller"));
            Ok(())
        })
        .unwrap();
}

#[test]
fn arm_takes_the_group_syntax_and_fire_and_synctick_take_nothing() {
    let opts = MoveOpts {
        params: MoveParams {
            vmax: Some(500.0),
            ..MoveParams::default()
        },
        ..MoveOpts::default()
    };
    let want = Command::Arm {
        absolute: true,
        targets: vec![
            ("X".into(), Amount::Steps(-40)),
            ("Y".into(), Amount::Units(2.5)),
        ],
        sync: true,
        opts,
    };
    let cmd = parse("ARM moveto X=-40 Y=2.5u sync vmax=500").unwrap();
    assert_eq!(cmd, want);
    // the host client writes it back as the same line
    assert_eq!(parse(&cmd.to_string()).unwrap(), want);
    assert_eq!(parse("fire").unwrap(), Command::Fire);
    assert_eq!(parse("synctick").unwrap(), Command::SyncTick);
    assert_eq!(parse(&Command::Fire.to_string()).unwrap(), Command::Fire);
    assert_eq!(
        parse(&Command::SyncTick.to_string()).unwrap(),
        Command::SyncTick
    );
    for (bad, says) in [
        ("arm", "usage: arm move|moveto"),
        ("arm move", "usage: arm move|moveto"),
        ("arm go X=1", "'go': arm move|moveto"),
        ("arm move sync", "no axes given; arm move|moveto"),
        ("arm move X", "'X' is not AXIS=N; arm move|moveto"),
        ("arm move X=1.5", "'1.5' is not a whole number"),
        ("fire now", "unexpected 'now'; usage: fire"),
        ("synctick X", "unexpected 'X'; usage: synctick"),
    ] {
        let e = parse(bad).unwrap_err();
        assert_eq!(e.code(), 3, "{bad}: {e}");
        assert!(e.to_string().starts_with(says), "{bad}: {e}");
    }
}

#[test]
fn a_simulated_board_refuses_arm_fire_and_synctick_with_one_error_each() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    for line in ["arm move 0=100", "fire", "synctick"] {
        let text = ctl.execute_bytes(line.as_bytes()).to_text();
        assert_eq!(count_status_lines(&text), 1, "{line}: {text}");
        assert_eq!(text.lines().count(), 1, "{line}: {text}");
        assert!(
            text.starts_with("error:19 board") && text.contains("has no SYNC line"),
            "{line}: {text}"
        );
    }
    // the refused arm left the axis idle where it was
    let text = ctl.execute_bytes(b"status 0").to_text();
    assert!(
        text.contains(" pos=0 ") && text.contains(" state=idle ") && text.contains(" target=none "),
        "{text}"
    );
}

/// A preset's values are checked when it is stored, with the answer a move with those
/// values gets; values that only fail together with a move are left to the move.
#[test]
fn a_preset_with_a_value_no_move_takes_is_refused_as_the_move_is() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    let answer = |line: &str| ctl.execute_bytes(line.as_bytes()).to_text();
    for (values, family) in [
        ("accel=-1", ""),
        ("vs=-5 ve=-5 rho=1e308 phi=-1e308", "profile=scurve"),
        ("cruise=nan_is_not_a_number", ""),
        ("ve=-0.5", ""),
        ("amax=0", ""),
        ("vmax=-3", ""),
        ("profile=scurve jmax=-1", ""),
        ("profile=scurve4 smax=0 jmax=5", ""),
        ("psi=0.7", "profile=scurve4"),
        ("rho=0", "profile=exponential"),
        ("profile=bogus", ""),
    ] {
        let preset = answer(&format!("preset bad {values}"));
        let moved = answer(&format!("move X 100 {family} {values}"));
        assert!(preset.starts_with("error:"), "{values}: {preset}");
        assert_eq!(preset, moved, "{values}");
    }
    assert_eq!(answer("presets"), "ok\n", "nothing was stored");
    assert!(answer("status X").contains(" pos=0 "));
    // Values a move takes are stored, even where a given move may not suit them.
    for values in [
        "vmax=1e308",
        "vmax=500 amax=2000",
        "accel=0.1 decel=0.1 vs=10",
        "profile=scurve phi=0.25 jmax=1e5",
        "rho=1e308",
    ] {
        assert_eq!(answer(&format!("preset good {values}")), "ok\n", "{values}");
    }
}

/// `sim` is set key by key: the whole group as one value would reset the keys it omits.
#[test]
fn the_sim_group_is_refused_as_one_key_and_its_keys_are_kept() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    let answer = |line: &str| ctl.execute_bytes(line.as_bytes()).to_text();
    assert_eq!(answer("set X sim.seed 7"), "ok\n");
    for value in [r#"{"sensor_at":1}"#, "{}", "1"] {
        let text = answer(&format!("set X sim {value}"));
        assert!(
            text.starts_with("error:9 setting: 'sim' is a group") && text.contains("sim.sensor_at"),
            "{value}: {text}"
        );
    }
    assert_eq!(answer("get X sim.seed"), "sim.seed=7\nok\n");
    assert_eq!(answer("set X sim.sensor_at 1"), "ok\n");
    assert_eq!(answer("get X sim.sensor_at"), "sim.sensor_at=1\nok\n");
    assert_eq!(answer("get X sim.seed"), "sim.seed=7\nok\n");
}

/// A move's words (presets, the host client) give each value in its shortest exact form:
/// huge and tiny ones in e-notation, never hundreds of digits, and they parse back to the
/// same values.
#[test]
fn move_words_are_short_and_exact() {
    let line = "preset p vmax=1e300 amax=0.5 vs=1.25e-5 jmax=123456.789";
    let Command::Preset { opts, .. } = protocol::parse(line).unwrap() else {
        panic!("not a preset")
    };
    let words = opts.words().join(" ");
    assert_eq!(words, "vmax=1e300 amax=0.5 jmax=123456.789 vs=1.25e-5");
    let Command::Preset { opts: again, .. } =
        protocol::parse(&format!("preset p {words}")).unwrap()
    else {
        panic!("not a preset")
    };
    assert_eq!(again, opts);
}

/// An axis or stored name the protocol accepts.
fn name() -> impl Strategy<Value = String> {
    "[A-Za-z][A-Za-z0-9_-]{0,8}".prop_filter("reserved", |n| {
        !n.eq_ignore_ascii_case("ok")
            && !n.eq_ignore_ascii_case("all")
            && !multistep_controller::domain::is_move_option(n)
    })
}

fn amount() -> impl Strategy<Value = Amount> {
    prop_oneof![
        any::<i64>().prop_map(Amount::Steps),
        (-1e9f64..1e9).prop_map(Amount::Units)
    ]
}

fn move_opts() -> impl Strategy<Value = MoveOpts> {
    (
        proptest::option::of(name()),
        proptest::option::of(prop_oneof![Just("trapezoid"), Just("scurve4")]),
        proptest::option::of(1.0f64..1e6),
        proptest::option::of(0.001f64..10.0),
    )
        .prop_map(|(preset, profile, vmax, accel)| MoveOpts {
            preset,
            profile: profile.map(String::from),
            params: MoveParams {
                vmax,
                accel_time: accel,
                ..MoveParams::default()
            },
        })
}

/// Every command but `mount` (its own grammar) and `Nop`, with random fields.
fn command() -> impl Strategy<Value = Command> {
    use multistep_controller::protocol::{RateArg, SignedRate, TrackOpts};
    let rate = (any::<bool>(), 1u64..1_000_000, 1u64..1000, any::<bool>()).prop_map(
        |(negative, num, den, units)| {
            let w = format!(
                "{}{num}/{den}{}",
                if negative { "-" } else { "" },
                if units { "u" } else { "" }
            );
            SignedRate::parse(&w).unwrap().unwrap()
        },
    );
    let targets = || proptest::collection::vec((name(), amount()), 1..4);
    prop_oneof![
        Just(Command::Help),
        Just(Command::Version),
        Just(Command::Info),
        Just(Command::Fire),
        Just(Command::SyncTick),
        Just(Command::EStop),
        Just(Command::Reset),
        Just(Command::Positions),
        Just(Command::Devices),
        Just(Command::Presets),
        Just(Command::Rates),
        (proptest::collection::vec(name(), 0..3), any::<bool>())
            .prop_map(|(axes, json)| Command::Status { axes, json }),
        (name(), amount(), move_opts()).prop_map(|(axis, by, opts)| Command::Move {
            axis,
            by,
            opts
        }),
        (name(), amount(), move_opts()).prop_map(|(axis, to, opts)| Command::MoveTo {
            axis,
            to,
            opts
        }),
        (any::<bool>(), targets(), any::<bool>(), move_opts()).prop_map(
            |(absolute, targets, sync, opts)| Command::Group {
                absolute,
                targets,
                sync,
                opts
            }
        ),
        (any::<bool>(), targets(), any::<bool>(), move_opts()).prop_map(
            |(absolute, targets, sync, opts)| Command::Arm {
                absolute,
                targets,
                sync,
                opts
            }
        ),
        proptest::option::of(name()).prop_map(|axis| Command::Stop { axis }),
        name().prop_map(|axis| Command::Home { axis }),
        (name(), proptest::option::of("[a-z_.]{1,12}"))
            .prop_map(|(axis, key)| Command::Get { axis, key }),
        (name(), "[a-z_.]{1,12}", "[a-z0-9_.]{1,12}").prop_map(|(axis, key, value)| Command::Set {
            axis,
            key,
            value
        }),
        (name(), proptest::collection::vec(name(), 0..3))
            .prop_map(|(name, axes)| Command::Save { name, axes }),
        (name(), move_opts()).prop_map(|(name, opts)| Command::Goto { name, opts }),
        name().prop_map(|name| Command::Forget { name }),
        // a preset holds at least one value and names no other preset
        (
            name(),
            move_opts().prop_filter("empty", |o| o.profile.is_some()
                || o.params != MoveParams::default())
        )
            .prop_map(|(name, mut opts)| {
                opts.preset = None;
                Command::Preset { name, opts }
            }),
        (name(), any::<i64>()).prop_map(|(axis, steps)| Command::SimSlip { axis, steps }),
        (
            name(),
            prop_oneof![
                rate.clone().prop_map(RateArg::Value),
                name().prop_map(RateArg::Preset)
            ],
            proptest::option::of(1.0f64..1e6),
            proptest::option::of(0.5f64..60.0),
        )
            .prop_map(|(axis, rate, amax, lease)| Command::Track {
                axis,
                rate,
                opts: TrackOpts { amax, lease },
            }),
        (name(), rate).prop_map(|(name, rate)| Command::RatePreset { name, rate }),
        name().prop_map(|axis| Command::Release { axis }),
        name().prop_map(|axis| Command::Energize { axis }),
        (name(), amount()).prop_map(|(axis, to)| Command::SetPos { axis, to }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 3000, ..ProptestConfig::default() })]

    /// The host client's line for a command is the line the board reads back as that
    /// command, for every verb; every free word the client checks is on that line.
    #[test]
    fn every_command_reads_back_as_written(cmd in command()) {
        let line = cmd.to_string();
        prop_assert_eq!(parse(&line).unwrap(), cmd.clone(), "line: {}", line);
        let words: Vec<&str> = line.split_whitespace().collect();
        for w in protocol::free_words(&cmd) {
            prop_assert!(words.iter().any(|l| l.contains(w.as_str())), "{} not on {}", w, line);
        }
    }
}

/// A connection's answer (a text `status` written straight into the reply) is the reply's
/// text, line for line, on status and on everything else.
#[test]
fn a_connection_answers_every_line_as_the_reply_reads() {
    let dir = tempfile::tempdir().unwrap();
    let ctl = Controller::open(&BoardConfig::default(), dir.path(), 1.0).unwrap();
    let lines = [
        "status",
        "STATUS X y",
        "s 0 A",
        "status json",
        "status json X",
        "status nosuch",
        "status X X",
        "version",
        "get X vmax",
        "bogus words",
        "",
        "set X backlash 3",
        "status X",
    ];
    for line in lines {
        let mut text = String::from("left over");
        text.clear();
        ctl.answer_bytes(line.as_bytes(), &mut text);
        assert_eq!(text, ctl.execute_bytes(line.as_bytes()).to_text(), "{line}");
        assert!(
            text.ends_with("ok\n") || text.contains("error:"),
            "{line}: {text}"
        );
    }
    // appended, not replaced
    let mut text = String::from("before\n");
    ctl.answer_bytes(b"status Z", &mut text);
    assert!(
        text.starts_with("before\nZ pos=0 ") && text.ends_with(" num=2\nok\n"),
        "{text}"
    );
}
