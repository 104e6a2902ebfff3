use super::*;
use std::io::{Read, Write};

#[test]
fn a_streamed_search_halts_on_the_board_only_within_amax() {
    // sqrt(2 * 40000) = 282.84…
    assert!(halts_within_amax(250.0, 40_000.0));
    assert!(halts_within_amax(282.0, 40_000.0));
    assert!(!halts_within_amax(283.0, 40_000.0));
}

#[test]
fn link_specs_parse_or_say_what_is_expected() {
    assert_eq!(
        LinkSpec::parse("serial:/dev/ttyUSB0").unwrap(),
        LinkSpec {
            device: "/dev/ttyUSB0".into(),
            baud: DEFAULT_BAUD,
            timeout: REPLY_TIMEOUT,
        }
    );
    let slow = LinkSpec::parse("serial:/dev/pts/3@115200,timeout=2.5").unwrap();
    assert_eq!(
        (slow.baud, slow.timeout),
        (115_200, Duration::from_millis(2500))
    );
    assert_eq!(LinkSpec::parse(&slow.to_string()).unwrap(), slow);
    assert_eq!(
        LinkSpec::parse("serial:/dev/x,timeout=0.01")
            .unwrap()
            .timeout,
        Duration::from_millis(10)
    );
    assert_eq!(
        LinkSpec::parse("serial:/dev/pts/3@115200").unwrap().baud,
        115_200
    );
    for bad in [
        "",
        "serial:",
        "tcp:x",
        "serial:/dev/x@",
        "serial:/dev/x@12",
        "/dev/x",
        "serial:/dev/x,timeout=0",
        "serial:/dev/x,timeout=61",
        "serial:/dev/x,timeout=NaN",
        "serial:/dev/x@9600,timeout=",
    ] {
        let e = LinkSpec::parse(bad).unwrap_err().to_string();
        assert!(e.contains("serial:DEVICE"), "{bad}: {e}");
    }
}

#[test]
fn a_new_line_is_listened_to_a_tenth_of_the_reply_timeout_from_50_ms_to_half_a_second() {
    let ms = |t: u64| stale_reply_wait(Duration::from_millis(t)).as_millis();
    assert_eq!([ms(10), ms(500), ms(3000), ms(60_000)], [50, 50, 300, 500]);
}

/// A stream that never answers: the link fails with an I/O error (the port's timeout).
struct Silent;
impl Read for Silent {
    fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
        Err(std::io::ErrorKind::TimedOut.into())
    }
}
impl Write for Silent {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_board_that_does_not_answer_is_one_clear_error() {
    let open: Opener = Box::new(|| Ok(Box::new(Silent) as Box<dyn Port>));
    let e = FpgaBackend::with_opener("test".into(), open, 2)
        .err()
        .expect("no board, no backend")
        .to_string();
    assert!(e.contains("board link") && e.contains("I/O"), "{e}");
    let open: Opener = Box::new(|| Err("no such device".into()));
    let e = FpgaBackend::with_opener("test".into(), open, 2)
        .err()
        .expect("no device")
        .to_string();
    assert_eq!(e, "no such device");
}

#[test]
fn garbage_instead_of_replies_is_an_error_not_a_panic() {
    struct Noise(u8);
    impl Read for Noise {
        fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
            for x in b.iter_mut() {
                self.0 = self.0.wrapping_mul(73).wrapping_add(41);
                *x = self.0;
            }
            Ok(b.len())
        }
    }
    impl Write for Noise {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let open: Opener = Box::new(|| Ok(Box::new(Noise(1)) as Box<dyn Port>));
    assert!(FpgaBackend::with_opener("noise".into(), open, 1).is_err());
}
