//! A profile planned on one clock (a board's) and played on another (the host's TDM
//! model): the integer move kept for exact ties belongs to the first clock and must not
//! be used on the second.

use multistep_core::tdm::{Axis, Board, TdmConfig};
use multistep_core::{EdgeGenerator, LimitsMove, Profile};

#[test]
fn a_profile_planned_on_another_clock_plays_rising_edges_and_times_on_the_tdm_model() {
    // an 18 MHz board's move, played at 50 MHz: it went backwards once and the TDM
    // model's period subtraction overflowed
    let p = Profile::limits_on_clock(&LimitsMove::trapezoid(120, 2000.0, 40000.0), 18e6).unwrap();
    for clock in [50e6, 25e6, 18e6, 12e6] {
        let edges: Vec<u64> = EdgeGenerator::new(&p, clock).unwrap().collect();
        assert_eq!(edges.len(), 120);
        assert!(edges.windows(2).all(|w| w[0] < w[1]), "{clock}: {edges:?}");
        let mut axes = [Axis::new(p.clone(), clock).unwrap()];
        let cfg = TdmConfig {
            clock_hz: clock,
            ..TdmConfig::default()
        };
        let mut rises = Vec::new();
        Board::new(cfg, &mut axes)
            .unwrap()
            .run(|s| rises.push(s.rise));
        assert_eq!(rises.len(), 120, "{clock}");
    }
}
