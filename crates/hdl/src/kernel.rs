//! STAND-IN until `multistep_core::int` exports its per-step kernel (the lead's
//! "int: exact-root kernel" commit): the same public shape (`KernelMode`, `StepKernel`,
//! `local_edge`), derived here from today's `IntPiece` fields. Deleted on merge.
//!
//! A piece is `Den·(p(τ) − p0) = A·τ + B·τ²`; step target `M = Den·i − C`; the edge is
//! `⌈τ* − ½⌉` with `Y = A² + 4BM`:
//! Accel `⌊(⌈√Y⌉ + B − A − 1)/2B⌋`, Decel `⌊(A + b − 1 − ⌊√Y⌋)/2b⌋`, Cruise `⌊(2M + A − 1)/2A⌋`.

use multistep_core::int::isqrt::isqrt_u128;
use multistep_core::int::IntPiece;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelMode {
    Accel,
    Decel,
    Cruise,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepKernel {
    pub mode: KernelMode,
    pub y0: u128,
    pub dy: u128,
    pub k: i128,
    pub dv: u128,
}

impl StepKernel {
    /// `⌊num/dv⌋` for the piece's j-th step (0-based).
    pub fn local_edge(&self, j: u64) -> u64 {
        let j = j as u128;
        let num = match self.mode {
            KernelMode::Accel => {
                let y = self.y0 + j * self.dy;
                let r = isqrt_u128(y);
                (r + u128::from(r * r != y)) as i128 + self.k
            }
            KernelMode::Decel => self.k - isqrt_u128(self.y0 - j * self.dy) as i128,
            KernelMode::Cruise => (self.y0 + j * self.dy) as i128,
        };
        (num as u128 / self.dv) as u64
    }
}

/// The kernel of `p` (None if it needs more than 128 bits), the 1-based index of its first
/// step and its step count.
pub fn piece_kernel(p: &IntPiece) -> (Option<StepKernel>, u64, u64) {
    let first = (p.c / p.den) as u64 + 1;
    let last = ((p.m_end + p.c) / p.den) as u64;
    let steps = (last + 1).saturating_sub(first);
    let kernel = (|| {
        let m0 = p.den.checked_mul(first as u128)?.checked_sub(p.c)?;
        let a = p.a;
        let b = p.b.unsigned_abs();
        let a2 = a.checked_mul(a)?;
        let four_b = b.checked_mul(4)?;
        let k = |x: u128| i128::try_from(x).ok();
        Some(match p.b.signum() {
            1 => StepKernel {
                mode: KernelMode::Accel,
                y0: a2.checked_add(four_b.checked_mul(m0)?)?,
                dy: four_b.checked_mul(p.den)?,
                k: k(b)? - k(a)? - 1,
                dv: 2 * b,
            },
            -1 => StepKernel {
                mode: KernelMode::Decel,
                y0: a2.checked_sub(four_b.checked_mul(m0)?)?,
                dy: four_b.checked_mul(p.den)?,
                k: k(a.checked_add(b)? - 1)?,
                dv: 2 * b,
            },
            _ => StepKernel {
                mode: KernelMode::Cruise,
                y0: (2 * m0).checked_add(a)? - 1,
                dy: 2 * p.den,
                k: 0,
                dv: a.checked_mul(2)?,
            },
        })
    })();
    (kernel, first, steps)
}
