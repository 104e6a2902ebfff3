//! Shared helpers: seeded random integer moves (segments, phase and limits trapezoids,
//! with start and end speeds), their float twins for the core's TDM board, and params.
#![allow(dead_code)]

use multistep_core::int::{IntClock, IntLimitsMove, IntPhaseMove, IntProfile, IntSegment};
use multistep_core::{Family, LimitsMove, Move, PhaseMove, Profile, Segment};
use multistep_hdl::{AxisMove, CoreParams};

pub mod host;

pub const HZ: u64 = 50_000_000;
pub const CLOCK: IntClock = IntClock::hz(HZ);

/// xorshift64*: reproducible test inputs without a dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// 0 half of the time, else uniform in lo..=hi (a speed or phase that may be absent).
    pub fn zero_or(&mut self, lo: u64, hi: u64) -> u64 {
        if self.next() & 1 == 0 {
            0
        } else {
            self.range(lo, hi)
        }
    }
    /// Uniform in lo..=hi.
    pub fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.next() % (hi - lo + 1)
    }
}

/// One integer move and its float twin (the same move for `Profile`).
#[derive(Clone, Debug)]
pub enum IntMove {
    Segments(Vec<IntSegment>),
    Phase(IntPhaseMove),
    Limits(IntLimitsMove),
}

impl IntMove {
    pub fn try_profile(&self) -> Result<IntProfile, multistep_core::int::IntError> {
        match self {
            IntMove::Segments(s) => IntProfile::segments(s, CLOCK),
            IntMove::Phase(m) => IntProfile::phase(m, CLOCK),
            IntMove::Limits(m) => IntProfile::limits(m, CLOCK),
        }
    }

    pub fn profile(&self) -> IntProfile {
        self.try_profile().expect("core plans it")
    }

    /// The same move for the core's float planner (speeds in steps/s, times in s), planned
    /// on the clock as the command line plans it.
    pub fn float_profile(&self) -> Profile {
        let s = |ticks: u64| ticks as f64 / HZ as f64;
        let phase = |m: &IntPhaseMove| PhaseMove {
            steps: m.steps,
            accel_time: s(m.accel_ticks),
            cruise_time: s(m.cruise_ticks),
            decel_time: s(m.decel_ticks),
            start_speed: m.start_speed as f64,
            end_speed: m.end_speed as f64,
            family: Family::Trapezoid,
        };
        let segs: Vec<Segment>;
        let m = match self {
            IntMove::Segments(v) => {
                segs = v
                    .iter()
                    .map(|g| Segment {
                        v0: g.v0 as f64,
                        duration: s(g.ticks),
                        steps: g.steps,
                    })
                    .collect();
                Move::Segments(&segs)
            }
            IntMove::Phase(m) => Move::Phase(phase(m)),
            IntMove::Limits(m) => Move::Limits(LimitsMove {
                start_speed: m.start_speed as f64,
                end_speed: m.end_speed as f64,
                ..LimitsMove::trapezoid(m.steps, m.vmax as f64, m.amax as f64)
            }),
        };
        Profile::plan_on_clock(&m, HZ as f64).expect("float planner")
    }
}

/// A random move of one of the three kinds with speeds up to `vmax` steps/s, lasting about
/// `ticks` ticks, that fits core `p` (retries until it does).
pub fn random_move(rng: &mut Rng, p: &CoreParams, vmax: u64, ticks: u64) -> (IntMove, AxisMove) {
    loop {
        let m = match rng.range(0, 2) {
            0 => random_segments(rng, p, vmax, ticks),
            1 => random_phase(rng, vmax, ticks),
            _ => random_limits(rng, vmax, ticks),
        };
        let Some(m) = m else { continue };
        let dir = rng.next() & 1 == 1;
        let Ok(profile) = m.try_profile() else {
            continue;
        };
        if let Ok(a) = AxisMove::from_profile(&profile, dir, p) {
            return (m, a);
        }
    }
}

/// A random move of kind `kind` (0 segments, 1 phase trapezoid, 2 limits trapezoid),
/// otherwise as [`random_move`].
pub fn random_move_of(
    rng: &mut Rng,
    p: &CoreParams,
    vmax: u64,
    ticks: u64,
    kind: u64,
) -> (IntMove, AxisMove) {
    loop {
        let m = match kind % 3 {
            0 => random_segments(rng, p, vmax, ticks),
            1 => random_phase(rng, vmax, ticks),
            _ => random_limits(rng, vmax, ticks),
        };
        let Some(m) = m else { continue };
        let dir = rng.next() & 1 == 1;
        let Ok(profile) = m.try_profile() else {
            continue;
        };
        if let Ok(a) = AxisMove::from_profile(&profile, dir, p) {
            return (m, a);
        }
    }
}

fn random_segments(rng: &mut Rng, p: &CoreParams, vmax: u64, ticks: u64) -> Option<IntMove> {
    let n = rng.range(1, u64::from(p.pieces));
    let mut v0 = rng.zero_or(0, vmax);
    let mut segs = Vec::new();
    for k in 0..n {
        let d = rng.range(ticks / (2 * n), 2 * ticks / n).max(400);
        // n steps end at speed 2n/T − v0 in [0, vmax]
        let lo = (v0 * d).div_ceil(2 * HZ).max(1);
        let hi = ((v0 + vmax) * d) / (2 * HZ);
        let hi = if k + 1 == n && rng.next() & 1 == 0 {
            lo
        } else {
            hi
        };
        if hi < lo {
            return None;
        }
        let steps = rng.range(lo, hi);
        segs.push(IntSegment {
            v0,
            ticks: d,
            steps,
        });
        v0 = (2 * steps * HZ).saturating_sub(v0 * d) / d;
    }
    Some(IntMove::Segments(segs))
}

fn random_phase(rng: &mut Rng, vmax: u64, ticks: u64) -> Option<IntMove> {
    let ta = rng.range(ticks / 8, ticks / 3);
    let tc = rng.range(ticks / 8, ticks / 3);
    let tb = rng.zero_or(1, ticks / 3);
    let vs = rng.zero_or(0, vmax / 2);
    let ve = rng.zero_or(0, vmax / 2);
    let vm = rng.range(vmax / 2, vmax);
    // 2N·F = vs·Ta + ve·Tc + vm·(Ta + 2Tb + Tc)
    let steps = (vs * ta + ve * tc + vm * (ta + 2 * tb + tc)) / (2 * HZ);
    (steps > 0).then_some(IntMove::Phase(IntPhaseMove {
        steps,
        accel_ticks: ta,
        cruise_ticks: tb,
        decel_ticks: tc,
        start_speed: vs,
        end_speed: ve,
    }))
}

fn random_limits(rng: &mut Rng, vmax: u64, ticks: u64) -> Option<IntMove> {
    let vm = rng.range(vmax / 2, vmax);
    let vs = rng.zero_or(0, vm / 2);
    let ve = rng.zero_or(0, vm / 2);
    // reach vm in about a third of the move
    let amax = (vm * HZ * 3 / ticks).max(1);
    let steps = rng.range(1, vm * ticks / HZ);
    Some(IntMove::Limits(IntLimitsMove {
        steps,
        vmax: vm,
        amax,
        start_speed: vs,
        end_speed: ve,
    }))
}

/// The nine kinds of [`board_move`]: phase mode of the six families, then limits-mode
/// trapezoid, scurve and scurve4.
pub const BOARD_MOVE_KINDS: u64 = 9;

/// Family `k` of the six, in `plan`'s order.
pub fn family(k: u64) -> Family {
    match k % 6 {
        0 => Family::Trapezoid,
        1 => Family::Parabolic,
        2 => Family::Exponential { rho: 0.4 },
        3 => Family::Sine,
        4 => Family::SCurve { phi: 0.5 },
        _ => Family::SCurve4 { phi: 0.5, psi: 0.5 },
    }
}

/// A random move of kind `kind` (0-5: phase mode of [`family`] `kind`, 6-8: limits-mode
/// trapezoid, scurve, scurve4) of one to four milliseconds, or 100 to 300 steps, at up to
/// `vmax` steps/s with random start and end speeds: short enough to co-simulate the
/// whole board. `plan` may refuse it (the caller draws again).
pub fn board_move(rng: &mut Rng, kind: u64, vmax: u64) -> Move<'static> {
    let v = rng.range(vmax / 3, vmax) as f64;
    let v0 = rng.zero_or(1000, vmax / 3) as f64;
    let v1 = rng.zero_or(1000, vmax / 3) as f64;
    if kind < 6 {
        let ms = |r: &mut Rng| r.range(3, 12) as f64 * 1e-4;
        let (ta, tb, tc) = (ms(rng), ms(rng), ms(rng));
        let steps = ((v + v0) * ta / 2.0 + v * tb + (v + v1) * tc / 2.0).round() as u64;
        Move::Phase(PhaseMove::new(steps, family(kind), ta, tb, tc).with_speeds(v0, v1))
    } else {
        let steps = rng.range(100, 300);
        let a = rng.range(20, 80) as f64 * 1e6;
        let j = a * rng.range(2, 10) as f64 * 1e3;
        let m = match kind {
            6 => LimitsMove::trapezoid(steps, v, a),
            7 => LimitsMove::scurve(steps, v, a, j),
            _ => LimitsMove::scurve4(steps, v, a, j, j * rng.range(2, 10) as f64 * 1e3),
        };
        Move::Limits(m.with_speeds(v0, v1))
    }
}

/// The default core with `axes` axes.
pub fn params(axes: u32) -> CoreParams {
    CoreParams {
        axes,
        ..Default::default()
    }
}

/// A narrow core: 10 step bits, 16 tick bits, a 72-bit radicand, 40-bit kernels, radix 8.
pub fn narrow_params(axes: u32, fifo_depth: u32, pieces: u32) -> CoreParams {
    CoreParams {
        axes,
        fifo_depth,
        pieces,
        step_bits: 10,
        tick_bits: 16,
        radicand_bits: 72,
        kernel_bits: 40,
        radix_bits: 3,
        clock_hz: 1e6,
        max_rate: 5e3,
        max_piece_s: 0.05,
        recurrence: None,
    }
}
