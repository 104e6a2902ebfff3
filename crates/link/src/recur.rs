//! The per-step recurrence's piece fields (`ms_core.v` staging words 17–31, with
//! `RECUR = 1`): `2A`, `B`, the first step's `4M`, `4Den` and the last tick a walk may
//! visit, all found from the piece's kernel, so a piece split to fit the core gets its own.
//!
//! The kernel is `Y = A² + 4B·M` (`M` the step's target in 1/Den steps, `B = ±dv/2`,
//! `Y` rising by `dy = 4|B|·Den` a step), or `Y = 2M + A − 1` at constant speed
//! (`dv = 2A`, `dy = 2Den`); `k = B − A − 1` on Accel, `A + b − 1` on Decel (`b = −B`)
//! (`multistep_core::int::StepKernel`, the four papers' trapezoid in integers). Hence
//! `4M₀ = (y0 − A²)/B` or `2(y0 − A + 1)` and `4Den = dy/|B|` or `2dy`.

use crate::{PieceRegs, Widths};
use multistep_core::int::KernelMode;

/// One piece's fields for the recurrence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RecurRegs {
    pub two_a: u128,
    pub b: i128,
    /// `4M` of the piece's first step.
    pub m4: u128,
    /// `4M`'s increase a step.
    pub four_den: u128,
    /// The last tick a walk may visit, `D − 1` (the first is 1).
    pub hi: u32,
}

impl RecurRegs {
    /// The fields of `p`, or None where the core takes the closed form for every step:
    /// a piece of fewer than two ticks, or one whose numbers do not fit the core's widths.
    pub fn of(p: &PieceRegs, w: &Widths) -> Option<RecurRegs> {
        let k = &p.kernel;
        let half = k.dv / 2;
        let (a, b): (u128, i128) = match k.mode {
            KernelMode::Accel => {
                let b = i128::try_from(half).ok()?;
                (u128::try_from(b.checked_sub(1)?.checked_sub(k.k)?).ok()?, b)
            }
            KernelMode::Decel => {
                let b = i128::try_from(half).ok()?;
                (
                    u128::try_from(k.k.checked_add(1)?.checked_sub(b)?).ok()?,
                    -b,
                )
            }
            KernelMode::Cruise => (half, 0),
        };
        let (m4, four_den) = if b == 0 {
            let m4 = k.y0.checked_add(1)?.checked_sub(a)?.checked_mul(2)?;
            (m4, k.dy.checked_mul(2)?)
        } else {
            let ub = b.unsigned_abs();
            let sq = a.checked_mul(a)?;
            let num = if b > 0 {
                k.y0.checked_sub(sq)?
            } else {
                sq.checked_sub(k.y0)?
            };
            if !num.is_multiple_of(ub) || !k.dy.is_multiple_of(ub) {
                return None;
            }
            (num / ub, k.dy / ub)
        };
        let fits = |x: u128, bits: u32| bits >= 128 || x >> bits == 0;
        let last = four_den.checked_mul(u128::from(p.steps.checked_sub(1)?))?;
        let two_a = a.checked_mul(2)?;
        let (wa, wb, wu) = w.recur_bits();
        let hi = p.dur.checked_sub(1)?;
        let ok = p.dur >= 2
            && fits(two_a, wa)
            && b.unsigned_abs() >> (wb - 1) == 0
            && fits(m4.checked_add(last)?, wu)
            && fits(hi.into(), w.wq);
        ok.then_some(RecurRegs {
            two_a,
            b,
            m4,
            four_den,
            hi: hi as u32,
        })
    }

    /// Staging words 17–31: 2A (3 words), B (3, two's complement), 4M (4), 4Den (4), hi;
    /// all 0 (hi = 0: the closed form) for None.
    pub fn words(r: Option<&RecurRegs>) -> [u32; 15] {
        let mut w = [0u32; 15];
        if let Some(r) = r {
            for i in 0..3 {
                w[i] = (r.two_a >> (32 * i)) as u32;
                w[3 + i] = (r.b >> (32 * i)) as u32;
            }
            for i in 0..4 {
                w[6 + i] = (r.m4 >> (32 * i)) as u32;
                w[10 + i] = (r.four_den >> (32 * i)) as u32;
            }
            w[14] = r.hi;
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{AxisMove, CoreParams};
    use multistep_core::int::{IntClock, IntPhaseMove, IntProfile};

    /// Every field against the integer piece the kernel came from: 2A, B, 4M of its first
    /// step and 4Den, on each piece of a phase trapezoid with start and end speeds.
    #[test]
    fn the_fields_are_the_pieces_own() {
        let m = IntPhaseMove {
            steps: 300,
            accel_ticks: 40_000,
            cruise_ticks: 30_000,
            decel_ticks: 50_001,
            start_speed: 5_000,
            end_speed: 1_000,
        };
        let profile = IntProfile::phase(&m, IntClock::hz(50_000_000)).unwrap();
        let p = CoreParams {
            axes: 1,
            recurrence: Some(13),
            ..Default::default()
        };
        let w = p.widths().unwrap();
        let regs = AxisMove::from_profile(&profile, true, &p).unwrap();
        assert_eq!(regs.pieces.len(), 3);
        for (pr, ip) in regs.pieces.iter().zip(profile.pieces()) {
            let r = RecurRegs::of(pr, &w).expect("fits");
            let m0 = ip.den * u128::from(ip.first) - ip.c;
            assert_eq!(
                (r.two_a, r.b, r.m4, r.four_den, u64::from(r.hi)),
                (2 * ip.a, ip.b, 4 * m0, 4 * ip.den, ip.dur - 1)
            );
        }
    }

    /// A core with the recurrence gets 32 staging words a piece, the last 15 the piece's
    /// fields; one without, 17.
    #[test]
    fn a_core_with_the_recurrence_gets_its_words() {
        let m = IntPhaseMove {
            steps: 500,
            accel_ticks: 100_000,
            cruise_ticks: 50_000,
            decel_ticks: 100_000,
            start_speed: 0,
            end_speed: 0,
        };
        let profile = IntProfile::phase(&m, IntClock::hz(50_000_000)).unwrap();
        for recurrence in [None, Some(13)] {
            let p = CoreParams {
                recurrence,
                ..Default::default()
            };
            let regs = AxisMove::from_profile(&profile, false, &p).unwrap();
            let writes = crate::move_writes(&p, 1, &regs, 0).unwrap();
            let per_piece = if recurrence.is_some() { 33 } else { 18 };
            assert_eq!(writes.len(), 3 * per_piece + 1);
            if recurrence.is_some() {
                let w = p.widths().unwrap();
                let fields = RecurRegs::words(RecurRegs::of(&regs.pieces[1], &w).as_ref());
                let got: Vec<u32> = writes[33 + 17..33 + 32].iter().map(|w| w.data).collect();
                assert_eq!(got, fields);
                assert_ne!(fields[14], 0, "hi: the piece walks");
            }
        }
    }

    /// Words: little-endian, B's sign extended, and all 0 for the closed form.
    #[test]
    fn words_in_order() {
        let r = RecurRegs {
            two_a: (7u128 << 64) | 5,
            b: -2,
            m4: 1 << 100,
            four_den: 9,
            hi: 77,
        };
        let w = RecurRegs::words(Some(&r));
        assert_eq!(&w[..3], &[5, 0, 7]);
        assert_eq!(&w[3..6], &[u32::MAX - 1, u32::MAX, u32::MAX]);
        assert_eq!(w[9], 1 << 4);
        assert_eq!((w[10], w[14]), (9, 77));
        assert_eq!(RecurRegs::words(None), [0; 15]);
    }
}
