//! One run of one generator on one move, for instruction counting under valgrind:
//! `gen_probe FAMILY [float|int|none] [STEPS]`. FAMILY is trapezoid, nocruise, halftick,
//! parabolic, exponential, sine, scurve or scurve4 (phase mode at 50 MHz, 0.2/0.6/0.2 of
//! the move's time accelerating, cruising, decelerating; halftick cruises at 32 000 steps/s,
//! 1562.5 ticks a step). `none` plans and stops: its count is the fixed cost to subtract.
use multistep_core::int::{IntClock, IntEdgeGenerator, IntPhaseMove, IntProfile};
use multistep_core::{EdgeGenerator, Family, PhaseMove, Profile};
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let fam = a.get(1).map_or("trapezoid", |s| s.as_str());
    let imp = a.get(2).map_or("float", |s| s.as_str());
    let steps: u64 = a.get(3).map_or(1_000_000, |s| s.parse().unwrap());
    // halftick: 32 000 steps/s cruise, so the move lasts steps/32 000 / 0.8 s
    let (family, total) = match fam {
        "parabolic" => (Family::Parabolic, 10.0),
        "exponential" => (Family::Exponential { rho: 0.25 }, 10.0),
        "sine" => (Family::Sine, 10.0),
        "scurve" => (Family::SCurve { phi: 0.5 }, 10.0),
        "scurve4" => (Family::SCurve4 { phi: 0.5, psi: 0.5 }, 10.0),
        "halftick" => (Family::Trapezoid, steps as f64 / 32_000.0 / 0.8),
        "nocruise" => (Family::Trapezoid, 10.0),
        _ => (Family::Trapezoid, 10.0),
    };
    let (ta, tc) = if fam == "nocruise" {
        (0.5, 0.0)
    } else {
        (0.2, 0.6)
    };
    let m = PhaseMove {
        steps,
        accel_time: ta * total,
        cruise_time: tc * total,
        decel_time: ta * total,
        start_speed: 0.0,
        end_speed: 0.0,
        family,
    };
    let mut s = 0u64;
    match imp {
        "int" => {
            let t = |x: f64| (x * 50e6).round() as u64;
            let p = IntProfile::phase(
                &IntPhaseMove {
                    steps,
                    accel_ticks: t(m.accel_time),
                    cruise_ticks: t(m.cruise_time),
                    decel_ticks: t(m.decel_time),
                    start_speed: 0,
                    end_speed: 0,
                },
                IntClock::hz(50_000_000),
            )
            .unwrap();
            s = IntEdgeGenerator::new(p).fold(0u64, |a, e| a.rotate_left(5) ^ e);
        }
        "float" => {
            let p = Profile::phase(&m).unwrap();
            s = EdgeGenerator::new(p, 50e6)
                .unwrap()
                .fold(0u64, |a, e| a.rotate_left(5) ^ e);
        }
        _ => {
            let p = Profile::phase(&m).unwrap();
            s += EdgeGenerator::new(p, 50e6).unwrap().remaining();
        }
    }
    println!("{s}");
}
