use super::*;
use crate::motion::EdgeSource;
use multistep_core::stream::StreamDecoder;
use multistep_core::{Family, PhaseMove, Profile};

fn profile(steps: u64) -> Profile {
    Profile::phase(&PhaseMove {
        steps,
        accel_time: 0.01,
        cruise_time: 0.01,
        decel_time: 0.01,
        start_speed: 0.0,
        end_speed: 0.0,
        family: Family::Parabolic,
    })
    .unwrap()
}

/// The frames decode to exactly the generator's edges.
#[test]
fn frames_carry_the_exact_edges() {
    let p = profile(1500);
    let want: Vec<u64> = multistep_core::EdgeGenerator::new(p.clone(), 50e6)
        .unwrap()
        .collect();
    let src = EdgeSource::new(p, 50e6, 777).unwrap();
    let mut f = Feed::new(Box::new(src), 777, 24, false);
    let mut bytes = Vec::new();
    loop {
        f.fill(200, u64::MAX).unwrap();
        let Some(n) = f.next_frame(100) else { break };
        assert!(n >= MIN_FRAME || f.ended, "{n}");
        bytes.extend(f.take(n));
    }
    assert!(f.ended && f.pending() == 0);
    let mut d = StreamDecoder::new();
    let mut got = Vec::new();
    let mut t = 0u64;
    for b in bytes {
        d.byte(b, &mut |p| {
            t += u64::from(p);
            got.push(t)
        })
        .unwrap();
    }
    assert_eq!(got, want);
    assert_eq!(f.coded(), 1500);
}

/// The feed's frames so far, after coding up to `max_steps`.
fn drain(f: &mut Feed, max_steps: u64, bytes: &mut Vec<u8>) {
    f.fill(100_000, max_steps).unwrap();
    while let Some(n) = f.next_frame(usize::MAX) {
        bytes.extend(f.take(n));
    }
}

/// The edge ticks the replay unit decodes from `bytes`.
fn decode(bytes: &[u8]) -> Vec<u64> {
    let mut d = StreamDecoder::new();
    let (mut got, mut t) = (Vec::new(), 0u64);
    for &b in bytes {
        d.byte(b, &mut |p| {
            t += u64::from(p);
            got.push(t)
        })
        .unwrap();
    }
    got
}

/// A fast search cut short: the search's edges up to the lead, then the stop ramp
/// at amax from the speed there, continuing from the last edge coded.
#[test]
fn a_lead_limited_search_ramps_down_after_its_last_coded_edge() {
    let (clock, amax) = (50e6, 20_000.0);
    let search = multistep_core::MoveSpec {
        steps: Some(100_000),
        params: multistep_core::MoveParams {
            vmax: Some(2000.0),
            amax: Some(amax),
            ..Default::default()
        },
        ..Default::default()
    }
    .plan_on_clock(clock)
    .unwrap();
    let want: Vec<u64> = multistep_core::EdgeGenerator::new(search.clone(), clock)
        .unwrap()
        .collect();
    let mut f = Feed::new(
        Box::new(EdgeSource::new(search, clock, 0).unwrap()),
        0,
        24,
        false,
    );
    f.lead_limited = true;
    // the board has made 400 steps (in cruise): 50 ms at 2000 steps/s are coded beyond
    let mut bytes = Vec::new();
    drain(&mut f, 400, &mut bytes);
    let lead = f.lead_limit(400);
    assert_eq!(lead, 500);
    drain(&mut f, lead, &mut bytes);
    assert_eq!(decode(&bytes), want[..500]);
    let total = f.ramp_down(amax, clock).unwrap();
    // 2000² / (2 · 20 000) = 100 steps to stop
    assert_eq!(total, 600);
    let limit = f.lead_limit(500);
    drain(&mut f, limit, &mut bytes);
    assert!(f.ended);
    let got = decode(&bytes);
    assert_eq!(got.len(), 600);
    let ramp: Vec<u64> =
        multistep_core::EdgeGenerator::new(stop_profile(2000.0, amax).unwrap(), clock)
            .unwrap()
            .map(|e| want[499] + e)
            .collect();
    assert_eq!(got[500..], ramp);
    // the speed carries on through the splice (the first ramp step already slows by
    // amax · period: 10 steps/s), then only falls
    let periods: Vec<u64> = got.windows(2).map(|w| w[1] - w[0]).collect();
    assert_eq!(periods[498], 25_000);
    assert!((25_001..25_250).contains(&periods[499]), "{}", periods[499]);
    assert!(periods[499..].windows(2).all(|w| w[1] + 1 >= w[0]));
    assert!(periods[598] > 5 * periods[498]);
}

#[test]
fn a_period_beyond_the_tick_bits_is_refused_by_step() {
    // 1500 steps in 0.03 s: the first period is far above 2^10 ticks
    let src = EdgeSource::new(profile(1500), 50e6, 0).unwrap();
    let mut f = Feed::new(Box::new(src), 0, 10, false);
    let e = f.fill(100, u64::MAX).unwrap_err();
    assert!(e.starts_with("step 1: a period of"), "{e}");
}

#[test]
fn a_tracking_stream_stays_within_its_lead() {
    use multistep_core::{Rate, TrackLimits};
    let limits = TrackLimits {
        amax: 1e5,
        jmax: None,
    };
    let src = TrackSource::new(50e6, limits, Rate::new(20_000, 1).unwrap(), 0).unwrap();
    let mut f = Feed::new(Box::new(src), 0, 24, true);
    f.fill(10_000, f.lead_limit(0)).unwrap();
    assert_eq!(f.coded(), TRACK_LEAD_MIN);
    // at speed: 50 ms at 20 000 steps/s ahead of the board
    f.fill(100_000, 5000).unwrap();
    assert_eq!(f.lead_limit(1000), 2000);
    assert!(!f.ended);
}

/// A board's stream buffer behind the link's framing: bulk writes append to
/// `committed`; a chosen copy of a chosen frame arrives with a byte damaged (refused
/// as a bad CRC), one frame may be refused as not fitting; a retransmission of the
/// frame executed last is answered from its kept reply (as `ms_link.v`).
#[derive(Default)]
struct Board {
    committed: Vec<u8>,
    out: Vec<u8>,
    /// Copies of bulk frames received so far.
    copies: usize,
    /// (copy, byte) to damage.
    damage: Vec<(usize, usize)>,
    /// Refuse this copy as not fitting.
    full: Option<usize>,
    kept: Option<(Vec<u8>, Reply)>,
}

use multistep_link::{BulkWrite, Reply};

impl Write for Board {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        let mut f = b.to_vec();
        let copy = self.copies;
        self.copies += 1;
        for &(c, i) in &self.damage {
            if c == copy {
                f[i] ^= 0x10;
            }
        }
        let reply = match (BulkWrite::decode(&f), &self.kept) {
            (Err(_), _) => Reply {
                seq: f[1],
                status: Status::BadCrc,
                data: 0,
            },
            (Ok(_), Some((k, r))) if *k == f => *r,
            (Ok(w), _) => {
                let status = if self.full == Some(copy) {
                    Status::StreamFull
                } else {
                    self.committed.extend(&w.data);
                    Status::Ok
                };
                let r = Reply {
                    seq: w.seq,
                    status,
                    data: 512,
                };
                self.kept = Some((f, r));
                r
            }
        };
        self.out.extend(reply.encode());
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Read for Board {
    fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
        super::super::model::read_out(&mut self.out, b)
    }
}

/// A 1500-step parabolic move's feed, and its edges.
fn feed() -> (Feed, Vec<u64>) {
    let p = profile(1500);
    let want = multistep_core::EdgeGenerator::new(p.clone(), 50e6)
        .unwrap()
        .collect();
    let f = Feed::new(Box::new(EdgeSource::new(p, 50e6, 0).unwrap()), 0, 24, false);
    (f, want)
}

/// Sends the whole feed in frames of up to 100 bytes; the first error ends it.
fn send_all(l: &mut HostLink<Board>, f: &mut Feed) -> Result<(), LinkError> {
    loop {
        f.fill(100, u64::MAX).unwrap();
        let Some(n) = f.next_frame(100) else {
            return Ok(());
        };
        send_frame(l, f, 0, n)?;
    }
}

#[test]
fn a_damaged_bulk_write_is_sent_again_and_the_code_arrives_whole() {
    for byte in [0, 5, 40, 107] {
        let (mut f, want) = feed();
        let mut l = HostLink::new(Board {
            damage: vec![(2, byte)],
            ..Board::default()
        });
        send_all(&mut l, &mut f).unwrap();
        assert_eq!(decode(&l.into_inner().committed), want, "byte {byte}");
        assert_eq!((f.resent, f.lost.is_none()), (1, true), "byte {byte}");
    }
}

#[test]
fn a_refused_bulk_write_keeps_its_bytes_for_the_next_try() {
    let (mut f, want) = feed();
    let mut l = HostLink::new(Board {
        full: Some(1),
        ..Board::default()
    });
    let e = send_all(&mut l, &mut f).unwrap_err();
    assert!(!e.in_doubt(), "{e}");
    assert_eq!(f.free, 0, "the free count is read again");
    f.free = 512;
    send_all(&mut l, &mut f).unwrap();
    assert_eq!(decode(&l.into_inner().committed), want);
}

#[test]
fn a_bulk_write_whose_every_copy_is_damaged_loses_the_stream() {
    let (mut f, _) = feed();
    let mut l = HostLink::new(Board {
        damage: (2..5).map(|c| (c, 40)).collect(),
        ..Board::default()
    });
    let e = send_all(&mut l, &mut f).unwrap_err();
    assert!(e.in_doubt(), "{e}");
    let why = f.lost.clone().unwrap_or_default();
    assert!(why.contains("after 200 was lost"), "{why}");
    assert_eq!(
        l.into_inner().committed.len(),
        200,
        "two frames of 100 bytes"
    );
}
