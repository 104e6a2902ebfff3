//! Shared helpers: seeded random moves that the core can sustain without underrun.
#![allow(dead_code)]

use multistep_hdl::{AxisMove, CoreParams, SegRegs};

/// xorshift64*: reproducible test inputs without a dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// Uniform in lo..=hi.
    pub fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.next() % (hi - lo + 1)
    }
    pub fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A random chain of `segs` segments with speeds up to `vmax` steps/tick, each starting
/// near the previous one's end speed, from rest and back to rest when `rest` is set.
pub fn random_move(rng: &mut Rng, p: &CoreParams, segs: usize, vmax: f64, rest: bool) -> AxisMove {
    let q = f64::from(1u32 << p.frac_bits);
    loop {
        let mut v0 = if rest { 0.0 } else { rng.unit() * vmax };
        let mut out = Vec::new();
        for k in 0..segs {
            let d = rng.range(2_000, 30_000) as u32;
            let df = f64::from(d);
            let lo = (v0 * df / 2.0).ceil().max(1.0);
            let hi = if rest && k == segs - 1 {
                lo
            } else {
                ((v0 + vmax) * df / 2.0).floor()
            };
            if hi < lo {
                break;
            }
            let n = rng.range(lo as u64, hi as u64) as u32;
            let s = (v0 * q * df).round() as u32;
            let seg = SegRegs { n, d, s };
            if seg.check(p, k).is_err() {
                break;
            }
            v0 = f64::from((2 * n << p.frac_bits).saturating_sub(s)) / (q * df);
            out.push(seg);
        }
        if out.len() == segs {
            return AxisMove {
                dir: rng.next() & 1 == 1,
                segs: out,
            };
        }
    }
}

/// The default core with `axes` axes.
pub fn params(axes: u32) -> CoreParams {
    CoreParams {
        axes,
        ..Default::default()
    }
}
