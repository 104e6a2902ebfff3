//! The shared period calculator, modelled by its latency only.
//!
//! Datapath for one period of a constant-acceleration segment (DESIGN.md §2, seed 000
//! eq. (10)/(11) merged, no cancellation):
//!
//! ```text
//! edge_i = round( 2·f·i / (v0 + √(v0² + 2a·i)) )    (in ticks, from the segment start)
//! 1. m1 = 2a·i            multiplier            (v0² latched once per segment)
//! 2. s  = √(v0² + m1)     square-root unit      64-bit radicand → 32-bit root
//! 3. m2 = 2f·i            multiplier (the same one, second use)
//! 4. q  = m2 / (v0 + s)   divider               48-bit quotient + 1 rounding bit
//! 5. period = t0 + q − previous edge, written to the axis's FIFO
//! ```
//!
//! Two multiplies, one square root and one divide per period, in sequence (each step needs
//! the previous result), plus the state machine's own cycles (axis select and register load,
//! the adds, rounding, subtract, FIFO write, step counter and segment switch).
//! The values themselves come from [`EdgeGenerator`](crate::EdgeGenerator); issue 6's
//! integer datapath is the bit-exact version of this sequence.

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
}

impl Latencies {
    pub const MULS_PER_PERIOD: u32 = 2;

    /// Default datapath: radix-4 digit recurrences (2 result bits per cycle) — a 48-bit
    /// quotient in 24 cycles + 1 rounding cycle, a 32-bit root in 16 cycles + 1 correction
    /// cycle, a 3-stage pipelined 64×64 multiplier, 6 cycles of state machine: 54 cycles.
    pub const RADIX4: Latencies = Latencies {
        mul: 3,
        div: 25,
        sqrt: 17,
        overhead: 6,
    };

    /// The plain sequential datapath: one quotient bit and one root bit per cycle: 94 cycles.
    pub const RADIX2: Latencies = Latencies {
        mul: 3,
        div: 49,
        sqrt: 33,
        overhead: 6,
    };

    /// Cycles the calculator is busy for one period (t_calc of seed eq. (12), in ticks).
    pub fn cycles_per_period(&self) -> u64 {
        Self::MULS_PER_PERIOD as u64 * self.mul as u64
            + self.div as u64
            + self.sqrt as u64
            + self.overhead as u64
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
        assert_eq!(Latencies::RADIX4.cycles_per_period(), 2 * 3 + 25 + 17 + 6);
        assert_eq!(Latencies::RADIX2.cycles_per_period(), 2 * 3 + 49 + 33 + 6);
        assert_eq!(Latencies::default(), Latencies::RADIX4);
    }
}
