//! The shared period calculator, modelled by its timing only.
//!
//! It runs the per-step kernel of [`crate::int`]'s integer datapath: every piece of a move is
//! `Den·(p(τ) − p0) = A·τ + B·τ²`, and the host precomputes per piece a kernel
//! `(y0, dy, k, dv)` so that the edge of the piece's j-th step, the nearest tick to the
//! exact root with an exact half tick going to the earlier one, is
//!
//! ```text
//! 1. Y = y0 ± j·dy               multiplier: one multiply with the narrow operand j
//! 2. root, rem = isqrt(Y)        square-root unit: Y = (Den·v)², up to 128 bits, 64-bit root
//! 3. num = ⌈√Y⌉ + k (Accel), k − ⌊√Y⌋ (Decel), Y (Cruise: the root is unused)
//! 4. q = ⌊num / dv⌋              divider: quotient ≤ the piece's ticks
//! 5. edge = t0 + q, period = edge − previous edge → the axis's FIFO
//! ```
//!
//! — one multiply, one square root, one divide, each needing the one before, and no
//! correction step. The values themselves come from [`EdgeGenerator`](crate::EdgeGenerator)
//! (the integer datapath gives the same edges), so only the cycles are modelled here.
//!
//! Default latencies ([`Latencies::RADIX4`]) are those of the Verilog core in
//! `crates/hdl` at its default parameters (`multistep_hdl::Widths::latencies`, checked by
//! a test there): the 20-bit step index in 16-bit digits (2 cycles), the 64-bit root at 2
//! bits per cycle (32), the 24-bit quotient at 2 bits per cycle (12), and 5 state-machine
//! cycles (select and piece-memory read, dy into the register before the multiplier,
//! radicand add, numerator, FIFO write): 51 cycles per period, so at 50 MHz one calculator
//! serves 9 axes at 100 000 steps/s by seed eq. (12). The three units are separate (seed
//! 000 §1.2: one multiplier, one divider, one square-root unit), so a state machine could
//! also overlap different axes' periods, each in a different unit (seed 000 §2.2 pipelines
//! its flow): then a period is still 51 cycles from start to FIFO, but a new one starts
//! every 32 cycles, the busiest unit's occupancy
//! ([`Latencies::RADIX4_PIPELINED`], a model only: the RTL runs one period at a time).

/// Operation latencies of the period calculator, in clock cycles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Latencies {
    /// One multiply (cycles); used [`Latencies::MULS_PER_PERIOD`] times per period.
    pub mul: u32,
    /// One divide (cycles).
    pub div: u32,
    /// One square root (cycles).
    pub sqrt: u32,
    /// State-machine cycles per period besides the three units.
    pub overhead: u32,
    /// Overlap periods of different axes across the units: a new period starts every
    /// [`interval`](Self::interval) cycles instead of after the previous one finished.
    pub pipelined: bool,
}

impl Latencies {
    pub const MULS_PER_PERIOD: u32 = 1;

    /// Radix-4 square root and divider, one period at a time: 2 + 32 + 12 + 5 = 51 cycles
    /// per period, the Verilog core at its default parameters.
    pub const RADIX4: Latencies = Latencies {
        mul: 2,
        div: 12,
        sqrt: 32,
        overhead: 5,
        pipelined: false,
    };

    /// Radix-4 units, periods of different axes overlapped: 51 cycles latency, one period
    /// every 32 cycles (a model only).
    pub const RADIX4_PIPELINED: Latencies = Latencies {
        pipelined: true,
        ..Latencies::RADIX4
    };

    /// One root bit and one quotient bit per cycle (the Verilog core with `radix_bits` 1):
    /// 2 + 64 + 24 + 5 = 95 cycles.
    pub const RADIX2: Latencies = Latencies {
        mul: 2,
        div: 24,
        sqrt: 64,
        overhead: 5,
        pipelined: false,
    };

    /// Cycles from the start of a period's computation to its FIFO write.
    pub const fn latency(&self) -> u64 {
        Self::MULS_PER_PERIOD as u64 * self.mul as u64
            + self.div as u64
            + self.sqrt as u64
            + self.overhead as u64
    }

    /// Cycles between the starts of two computations: the latency, or when pipelined the
    /// busiest unit's cycles per period. This is t_calc of seed eq. (12).
    pub fn interval(&self) -> u64 {
        if self.pipelined {
            (Self::MULS_PER_PERIOD as u64 * self.mul as u64)
                .max(self.div as u64)
                .max(self.sqrt as u64)
                .max(self.overhead as u64)
        } else {
            self.latency()
        }
    }
}

impl Default for Latencies {
    fn default() -> Self {
        Latencies::RADIX4
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cycle_counts_of_the_documented_datapaths() {
        assert_eq!(Latencies::RADIX4.latency(), 2 + 12 + 32 + 5);
        assert_eq!(Latencies::RADIX4.interval(), 51);
        assert_eq!(Latencies::RADIX4_PIPELINED.latency(), 51);
        assert_eq!(Latencies::RADIX4_PIPELINED.interval(), 32);
        assert_eq!(Latencies::RADIX2.interval(), 2 + 24 + 64 + 5);
        assert_eq!(Latencies::default(), Latencies::RADIX4);
    }
}
