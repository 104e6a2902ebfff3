//! A replica of seed 000's published datapath (Wu et al., §1.1): each constant-acceleration
//! segment `(ω0, T, θ)` gives per-step periods in clock ticks by eq. (10) (accel), eq. (11)
//! (decel) and eq. (5) (cruise):
//!
//! `Δt_i = f·(√(P² + i·K) − √(P² + (i−1)·K))`, `P = ω0·T² / (2(θ − ω0·T))`,
//! `K = T² / (θ − ω0·T)` (steps, so q = 1), and `Δt_i = f·T/n` at constant speed.
//!
//! As in the IP core, P and K are registers of a fixed-point width (`frac_bits` fractional
//! bits of seconds), the two roots are fixed-point square roots, and each period is an
//! integer tick count handed to the PWM unit, so edges are the running sum of periods.

use multistep_core::int::isqrt::isqrt_u128;

/// One segment of seed 000's register model, in SI units: start speed (steps/s),
/// duration (s) and steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seed000Segment {
    pub v0: f64,
    pub duration: f64,
    pub steps: u64,
}

/// Periods of one segment, by eq. (5), (10) or (11).
#[derive(Clone, Debug)]
pub struct Seed000Periods {
    /// Fixed-point registers (units of 2^-frac_bits s and s²).
    p2: i128,
    k: i128,
    cruise_period: u64,
    frac: u32,
    clock: u128,
    i: u64,
    n: u64,
    prev_root: u128,
}

/// Round-to-nearest of `x·2^frac` into an integer register.
fn fixed(x: f64, frac: u32) -> i128 {
    (x * (frac as f64).exp2()).round() as i128
}

impl Seed000Periods {
    pub fn new(s: &Seed000Segment, clock_hz: u64, frac_bits: u32) -> Self {
        let theta = s.steps as f64;
        let excess = theta - s.v0 * s.duration;
        let t2 = s.duration * s.duration;
        // registers: P² and K = T²/(θ − ω0T) (signed: negative on decel)
        // the mode is the sign of θ − ω0·T (eq. 2); equal within f64 rounding is cruise
        let (p2, k) = if excess.abs() <= 1e-9 * theta.max(1.0) {
            (0, 0)
        } else {
            let p = s.v0 * t2 / (2.0 * excess);
            let p_fx = fixed(p, frac_bits);
            ((p_fx * p_fx) >> frac_bits, fixed(t2 / excess, frac_bits))
        };
        let cruise_period = if s.steps == 0 {
            0
        } else {
            // eq. (5): f·T/n, with T a fixed-point register
            let t_fx = fixed(s.duration, frac_bits) as u128;
            ((clock_hz as u128 * t_fx / s.steps as u128 + (1 << (frac_bits - 1))) >> frac_bits)
                as u64
        };
        let mut it = Seed000Periods {
            p2,
            k,
            cruise_period,
            frac: frac_bits,
            clock: clock_hz as u128,
            i: 0,
            n: s.steps,
            prev_root: 0,
        };
        it.prev_root = it.root(0);
        it
    }

    /// `√(P² + i·K)` in fixed point (decel: K < 0 and the roots fall).
    fn root(&self, i: u64) -> u128 {
        let x = (self.p2 + i as i128 * self.k).max(0) as u128;
        isqrt_u128(x << self.frac)
    }
}

impl Iterator for Seed000Periods {
    type Item = u64;
    fn next(&mut self) -> Option<u64> {
        if self.i == self.n {
            return None;
        }
        self.i += 1;
        if self.k == 0 {
            return Some(self.cruise_period);
        }
        // eq. (10)/(11): the difference of two roots, the larger first
        let r = self.root(self.i);
        let d = r.abs_diff(self.prev_root);
        self.prev_root = r;
        Some(((self.clock * d + (1 << (self.frac - 1))) >> self.frac) as u64)
    }
}

/// Edges of a chain of segments: the running sum of integer periods.
pub fn edges(
    segs: &[Seed000Segment],
    clock_hz: u64,
    frac_bits: u32,
) -> impl Iterator<Item = u64> + '_ {
    segs.iter()
        .flat_map(move |s| Seed000Periods::new(s, clock_hz, frac_bits))
        .scan(0u64, |t, p| {
            *t += p;
            Some(*t)
        })
}
