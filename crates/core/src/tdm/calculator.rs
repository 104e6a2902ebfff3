//! The shared period calculator, modelled by its timing only.
//!
//! It runs the integer datapath of [`crate::int`] (issue 6): per step, with `M` the
//! step's target advanced by `M += Den`,
//!
//! ```text
//! 1. R = (4A² + 16·B·M) / 4^k     multiplier (128 × 128 bits, the wide one)
//! 2. s = ⌊√R⌋                     square-root unit: 126-bit radicand, 63-bit root
//! 3. q = ⌊(8M − 1)/(2A + s·2^k)⌋  divider: 127/64 bits, a 33-bit quotient (pieces < 2^32 ticks)
//! 4. keep q or q − 1              multiplier twice, with the narrow operand q
//! 5. edge = t0 + ⌊(q + 1)/2⌋, period = edge − previous edge → the axis's FIFO
//! ```
//!
//! — three multiplies, one square root, one divide, each needing the one before. The
//! values themselves come from [`EdgeGenerator`](crate::EdgeGenerator) (the integer
//! datapath gives the same edges), so only the cycles are modelled here.
//!
//! Default latencies ([`Latencies::RADIX4`]): radix-4 digit recurrences (2 result bits per
//! cycle): the 33-bit quotient in 17 cycles + 1 normalisation, the 63-bit root in 32; a
//! multiply in 4 (a pipelined 64 × 64 DSP multiplier, the wide product from its partial
//! products); 6 state-machine cycles (axis select and register load, `M += Den`, rounding,
//! subtract, FIFO write). In sequence that is 3·4 + 18 + 32 + 6 = 68 cycles per period.
//! The three units are separate (seed 000 §1.2: one multiplier, one divider, one square
//! root unit), so the state machine can also overlap different axes' periods, each in a
//! different unit (seed 000 §2.2 pipelines its flow): then a period is still 68 cycles
//! from start to FIFO, but a new one starts every 32 cycles, the busiest unit's occupancy.

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
    pub const MULS_PER_PERIOD: u32 = 3;

    /// Radix-4 units, one period at a time: 68 cycles per period.
    pub const RADIX4: Latencies = Latencies {
        mul: 4,
        div: 18,
        sqrt: 32,
        overhead: 6,
        pipelined: false,
    };

    /// Radix-4 units, periods of different axes overlapped: 68 cycles latency, one period
    /// every 32 cycles.
    pub const RADIX4_PIPELINED: Latencies = Latencies {
        pipelined: true,
        ..Latencies::RADIX4
    };

    /// The plain sequential datapath, one quotient bit and one root bit per cycle: 115 cycles.
    pub const RADIX2: Latencies = Latencies {
        mul: 4,
        div: 34,
        sqrt: 63,
        overhead: 6,
        pipelined: false,
    };

    /// Cycles from the start of a period's computation to its FIFO write.
    pub fn latency(&self) -> u64 {
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
        assert_eq!(Latencies::RADIX4.latency(), 3 * 4 + 18 + 32 + 6);
        assert_eq!(Latencies::RADIX4.interval(), 68);
        assert_eq!(Latencies::RADIX4_PIPELINED.latency(), 68);
        assert_eq!(Latencies::RADIX4_PIPELINED.interval(), 32);
        assert_eq!(Latencies::RADIX2.interval(), 3 * 4 + 34 + 63 + 6);
        assert_eq!(Latencies::default(), Latencies::RADIX4);
    }
}
