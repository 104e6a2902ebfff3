//! The RTL's reference model against exact references: the step-edge contract checked in
//! integers (DESIGN.md section 1), and the core's integer datapath (`multistep_core::int`).

mod common;

use common::{random_move, Rng};
use multistep_core::int::{IntClock, IntEdgeGenerator, IntProfile, IntSegment};
use multistep_hdl::{AxisMove, CoreParams, SegRegs};
use proptest::prelude::*;

/// 4 C p(tau2 / 2) = 2 B tau2 + A tau2^2 for the segment (A signed).
fn scaled_position(seg: &SegRegs, f: u32, tau2: i128) -> i128 {
    let a = (i128::from(seg.n) << f) - i128::from(seg.s);
    let b = i128::from(seg.s) * i128::from(seg.d);
    2 * b * tau2 + a * tau2 * tau2
}

/// The core's integer edges of one segment: speeds in 1/d steps/s at a 2^F Hz clock make
/// its start speed register exactly `s`.
fn core_int_edges(seg: &SegRegs, f: u32) -> Vec<u64> {
    let clock = IntClock {
        clock_hz: 1 << f,
        speed_scale: u64::from(seg.d),
    };
    let s = IntSegment {
        v0: u64::from(seg.s),
        ticks: u64::from(seg.d),
        steps: u64::from(seg.n),
    };
    IntEdgeGenerator::new(IntProfile::segments(&[s], clock).expect("core plans it")).collect()
}

/// A valid segment of the default core: n <= d/4, start and end speeds <= 1/4 step/tick.
fn segment() -> impl Strategy<Value = SegRegs> {
    (16u32..(1 << 24) - 1, any::<u64>(), any::<u64>()).prop_map(|(d, x, y)| {
        let p = CoreParams::default();
        let q = 1u64 << p.frac_bits;
        let n = 1 + x % u64::from(d / 4).min((1 << p.step_bits) - 2);
        // s in [max(0, 2nQ - Qd/4), min(2nQ, Qd/4)]
        let lo = (2 * n * q).saturating_sub(q * u64::from(d) / 4);
        let hi = (2 * n * q).min(q * u64::from(d) / 4);
        let s = lo + y % (hi - lo + 1);
        SegRegs {
            n: n as u32,
            d,
            s: s as u32,
        }
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// p(e - 1/2) < i <= p(e + 1/2) for sampled steps, in exact integers.
    #[test]
    fn every_edge_is_the_nearest_tick(seg in segment(), pick in any::<u64>()) {
        let p = CoreParams::default();
        prop_assert!(seg.check(&p, 0).is_ok(), "{seg:?}");
        let f = p.frac_bits;
        let c4 = 4 * (i128::from(seg.d) * i128::from(seg.d) << f);
        let n = u64::from(seg.n);
        for i in [1, n, 1 + pick % n, 1 + (pick >> 20) % n, n / 2 + 1] {
            let e = i128::from(seg.local_edge(i as u32, f));
            let target = c4 * i128::from(i as u32);
            prop_assert!(scaled_position(&seg, f, 2 * e - 1) < target, "{seg:?} step {i} edge {e} too late");
            prop_assert!(target <= scaled_position(&seg, f, 2 * e + 1), "{seg:?} step {i} edge {e} too early");
        }
        prop_assert_eq!(seg.local_edge(seg.n, f), u64::from(seg.d));
    }

    /// The same edges as the core's integer datapath, on whole short segments.
    #[test]
    fn equals_core_integer_datapath(seg in segment()) {
        let f = CoreParams::default().frac_bits;
        let seg = SegRegs { n: seg.n.min(3000), ..seg };
        let seg = if seg.check(&CoreParams::default(), 0).is_ok() { seg } else { SegRegs { s: 0, ..seg } };
        prop_assume!(seg.check(&CoreParams::default(), 0).is_ok());
        let mine: Vec<u64> = (1..=seg.n).map(|i| seg.local_edge(i, f)).collect();
        prop_assert_eq!(mine, core_int_edges(&seg, f));
    }
}

/// Whole random moves (the co-simulation's kind) against the core, segment by segment.
#[test]
fn random_moves_equal_core_integer_datapath() {
    let p = CoreParams::default();
    let mut rng = Rng(7);
    for _ in 0..40 {
        let m: AxisMove = random_move(&mut rng, &p, 4, 0.2, false);
        let mut want = Vec::new();
        let mut t0 = 0;
        for seg in &m.segs {
            want.extend(core_int_edges(seg, p.frac_bits).iter().map(|e| e + t0));
            t0 += u64::from(seg.d);
        }
        assert_eq!(m.edges(p.frac_bits), want, "{m:?}");
    }
}

/// An exact half tick goes to the earlier tick: s = 0, n = 4, d = 2: tau_1 = 1/2... scaled
/// up: d = 6, n = 1 at constant speed puts step 1 at tau = 6; d = 3, n = 2 cruise puts
/// step 1 at 1.5 -> tick 1.
#[test]
fn half_tick_goes_down() {
    let f = 8;
    let cruise = SegRegs {
        n: 2,
        d: 3,
        s: 2 << f,
    };
    assert_eq!(cruise.local_edge(1, f), 1);
    assert_eq!(cruise.local_edge(2, f), 3);
}

#[test]
fn isqrt_is_floor_sqrt() {
    for x in [
        0u128,
        1,
        2,
        3,
        4,
        15,
        16,
        17,
        u64::MAX as u128,
        u128::MAX,
        (1u128 << 113) + 12345,
    ] {
        let (q, r) = multistep_hdl::model::isqrt(x);
        assert!(q * q <= x && r == x - q * q);
        assert!((q + 1).checked_mul(q + 1).map_or(true, |s| s > x));
    }
}
