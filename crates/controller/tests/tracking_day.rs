//! The evidence for tracking on the simulated board, in virtual time: 24 simulated hours
//! at the sidereal rate of a mount with 4,000,000 microsteps per revolution (15.041″/s =
//! 15041/324 ≈ 46.42 steps/s) and one simulated hour at 31,999.9 steps/s. At every sampled
//! tick the board's position equals the count of the core tracker's edges up to that tick
//! (the edges `multistep plan --track` prints), and the last edge lies on the tick nearest
//! to its exact time: no error accumulates. The wall time of the simulated day is printed
//! (docs/BENCHMARKS.md), not asserted.

use multistep_controller::config::{AxisConfig, BoardConfig, BoardSection};
use multistep_controller::protocol::{RateArg, SignedRate, TrackOpts};
use multistep_controller::store::Store;
use multistep_controller::{AxisSettings, AxisState, Board};
use multistep_core::track::TrackSegment;
use multistep_core::{Rate, TrackLimits, Tracker};
use std::time::Instant;

const F: u64 = 50_000_000;

fn board(dir: &std::path::Path, amax: f64) -> Board {
    let c = BoardConfig {
        board: BoardSection {
            name: "mount".into(),
            clock_hz: F as f64,
            fifo_depth: 4,
            link: None,
            sync_line: None,
        },
        axes: vec![AxisConfig {
            name: "ra".into(),
            settings: AxisSettings {
                vmax: 40_000.0,
                amax,
                // 4,000,000 microsteps per 1,296,000″
                steps_per_unit: 4e6 / 1.296e6,
                ..AxisSettings::default()
            },
        }],
        alpaca: None,
    };
    Board::open(&c, Store::open(dir).unwrap()).unwrap()
}

/// Runs the board tracking `rate` for `seconds`, sampling every `every` seconds (plus an
/// odd offset so samples fall anywhere between edges); returns (samples, edges, the
/// reference tracker at the end, the wall time of the board's run).
fn run(rate: &str, amax: f64, seconds: u64, every: u64) -> (u64, u64, Tracker, f64) {
    let dir = tempfile::tempdir().unwrap();
    let mut b = board(dir.path(), amax);
    let arg = RateArg::Value(SignedRate::parse(rate).unwrap().unwrap());
    b.track("ra", &arg, &TrackOpts::default(), None, 0).unwrap();
    let limits = TrackLimits { amax, jmax: None };
    let mut reference = Tracker::new(F as f64, limits, 0.0, Rate::parse(rate).unwrap()).unwrap();
    let (mut taken, mut ahead) = (0u64, reference.next());
    let (mut samples, mut board_s) = (0u64, 0.0);
    let end = seconds * F;
    let mut k = 0u64;
    loop {
        k += 1;
        let t = (k * every * F + k * 12_347 % F).min(end);
        let t0 = Instant::now();
        b.advance(t);
        board_s += t0.elapsed().as_secs_f64();
        while let Some(e) = ahead.filter(|&e| e <= t) {
            let _ = e;
            taken += 1;
            ahead = reference.next();
        }
        let s = b.status(&["ra".into()], t).unwrap().remove(0);
        assert_eq!(s.position as u64, taken, "position at tick {t}");
        assert_eq!(s.state, AxisState::Tracking);
        samples += 1;
        if t == end {
            break;
        }
    }
    (samples, taken, reference, board_s)
}

/// `|2^(b+1)·num·(e − X₀ − k·f·den/num)| ≤ 2^b·num`: edge `e` of cruise step `k` is the
/// nearest tick to its exact time (seed 000: edges on the nearest tick, no drift).
fn nearest_tick(tr: &Tracker, e: u64) {
    let TrackSegment::Cruise {
        rate,
        start_step,
        origin_tick,
        frac_num,
        frac_bits,
    } = tr.segment()
    else {
        panic!("not cruising");
    };
    let k = (tr.steps() - start_step) as i128;
    let (num, den) = (rate.num() as i128, rate.den() as i128);
    let s = 1i128.checked_shl(frac_bits).unwrap();
    let err = (2 * s * num)
        .checked_mul(e as i128 - origin_tick as i128)
        .and_then(|x| x.checked_sub(2 * num * frac_num as i128))
        .and_then(|x| x.checked_sub((2 * s * k).checked_mul(F as i128 * den)?))
        .expect("fits i128");
    let half = s * num;
    assert!(
        -half <= err && err < half,
        "edge {e} is {err}/{} ticks off",
        2 * half
    );
}

#[test]
fn a_day_of_sidereal_tracking_on_the_board_is_exact() {
    let (samples, edges, tr, wall) = run("15041/324", 200.0, 24 * 3600, 60);
    assert!(samples >= 1440, "{samples}");
    // 86 400 s × 15041/324 steps/s, less the half step lost to the ramp from rest
    assert!((4_010_900..4_010_930).contains(&edges), "{edges} edges");
    nearest_tick(&tr, tr.last_edge());
    println!(
        "24 h sidereal: {edges} edges, {samples} samples, board simulation {wall:.2} s wall \
         ({:.0}x real time)",
        86_400.0 / wall
    );
}

#[test]
fn an_hour_at_31999_9_steps_per_second_on_the_board_is_exact() {
    let (samples, edges, tr, wall) = run("31999.9", 64_000.0, 3600, 9);
    assert!(samples >= 400, "{samples}");
    assert!(edges > 115_190_000, "{edges} edges");
    nearest_tick(&tr, tr.last_edge());
    println!("1 h at 31999.9 steps/s: {edges} edges, board simulation {wall:.2} s wall");
}
