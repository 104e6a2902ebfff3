//! Core parameters (axis count, FIFO depth, bit widths, radix, clock and speed range), their
//! validation, and the internal bit widths and cycle counts derived from them.

use crate::FitError;

/// What the user chooses. Every check runs in [`CoreParams::widths`], before any Verilog.
#[derive(Clone, Debug, PartialEq)]
pub struct CoreParams {
    /// Axes sharing the calculator (K), 1..=32 (the start mask is one 32-bit bus word).
    pub axes: u32,
    /// Periods per axis FIFO, a power of two >= 2.
    pub fifo_depth: u32,
    /// Piece slots per axis, a power of two >= 2 (a trapezoid needs 3).
    pub pieces: u32,
    /// Bits of a piece's step count (and of the step index j, the multiplier's narrow operand).
    pub step_bits: u32,
    /// Bits of a piece's duration in ticks: the local edge (quotient) and a period.
    pub tick_bits: u32,
    /// Bits of the radicand Y = A² + 4BM (even, at most 128).
    pub radicand_bits: u32,
    /// Bits of the divisor dv (k is one bit wider, signed).
    pub kernel_bits: u32,
    /// Result bits per cycle of the square root and the divider: 1 = radix 2, 2 = radix 4.
    pub radix_bits: u32,
    /// Clock (ticks per second).
    pub clock_hz: f64,
    /// Highest step rate the core must produce (steps/s).
    pub max_rate: f64,
    /// Longest piece (s).
    pub max_piece_s: f64,
    /// The per-step recurrence beside the closed form (`ms_recur` in `ms_core`): its
    /// multiplier's digit bits, 0 for full-width multiplies or 1..=15; None: the closed
    /// form alone.
    pub recurrence: Option<u32>,
}

impl Default for CoreParams {
    fn default() -> Self {
        CoreParams {
            axes: 2,
            fifo_depth: 16,
            pieces: 4,
            step_bits: 20,
            tick_bits: 24,
            radicand_bits: 128,
            kernel_bits: 68,
            radix_bits: 2,
            clock_hz: multistep_core::DEFAULT_CLOCK_HZ,
            max_rate: 200_000.0,
            max_piece_s: 0.3,
            recurrence: None,
        }
    }
}

/// Internal widths of the RTL (the Verilog parameters of `ms_core`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Widths {
    /// axis index bits
    pub lk: u32,
    /// piece slot bits
    pub ls: u32,
    /// FIFO depth bits
    pub lf: u32,
    /// steps per piece, step index j
    pub wn: u32,
    /// period
    pub wd: u32,
    /// local edge (quotient), a multiple of `rb`
    pub wq: u32,
    /// move tick (t0, edges)
    pub wt: u32,
    /// radicand
    pub wy: u32,
    /// divisor (k has one more bit)
    pub wk: u32,
    /// result bits per cycle of the root and the divider
    pub rb: u32,
    /// multiplier digit bits
    pub md: u32,
    /// bus address bits: 1 + lk + 5
    pub aw: u32,
    /// the recurrence's multiplier digit bits (0: full width); None without it
    pub recur: Option<u32>,
}

fn bad(msg: String) -> FitError {
    FitError::Param(msg)
}

/// Bits to index `n` things (at least 1).
fn index_bits(n: u32) -> u32 {
    (32 - n.saturating_sub(1).leading_zeros()).max(1)
}

/// The multiplier's digit: one DSP-sized slice of the narrow operand per cycle.
const MUL_DIGIT_BITS: u32 = 16;

/// The core's parameters as a board reports them (its build id): what the board was
/// built with, the longest piece the tick counter holds, the rest at their defaults.
impl From<&crate::BuildId> for CoreParams {
    fn from(id: &crate::BuildId) -> Self {
        CoreParams {
            axes: id.axes,
            fifo_depth: 1 << id.fifo_depth_bits,
            pieces: 1 << id.slot_bits,
            step_bits: id.step_bits,
            tick_bits: id.tick_bits,
            radicand_bits: id.radicand_bits,
            kernel_bits: id.kernel_bits,
            radix_bits: id.radix_bits,
            clock_hz: f64::from(id.clock_hz),
            // the default 0.3 s needs 24 bits at 50 MHz
            max_piece_s: ((1u64 << id.tick_bits.min(63)) - 1) as f64
                / f64::from(id.clock_hz.max(1)),
            recurrence: id.recurrence,
            ..CoreParams::default()
        }
    }
}

impl CoreParams {
    /// Checks every parameter and derives the RTL widths.
    pub fn widths(&self) -> Result<Widths, FitError> {
        if self.axes == 0 || self.axes > 32 {
            return Err(bad(format!("axes must be 1..=32, got {}", self.axes)));
        }
        for (name, v) in [("fifo depth", self.fifo_depth), ("pieces", self.pieces)] {
            if v < 2 || !v.is_power_of_two() {
                return Err(bad(format!("{name} must be a power of two >= 2, got {v}")));
            }
        }
        if !(1..=4).contains(&self.radix_bits) {
            return Err(bad(format!(
                "radix bits must be 1..=4 (radix 2..16), got {}",
                self.radix_bits
            )));
        }
        let ls = index_bits(self.pieces);
        if !(8..=32 - ls - 1).contains(&self.tick_bits) {
            return Err(bad(format!(
                "tick bits must be 8..={} (a move tick is one bus word), got {}",
                32 - ls - 1,
                self.tick_bits
            )));
        }
        if self.step_bits < 2 || self.step_bits > self.tick_bits {
            return Err(bad(format!(
                "step bits must be 2..=tick bits ({}), got {}",
                self.tick_bits, self.step_bits
            )));
        }
        let rb = self.radix_bits;
        if self.radicand_bits > 128 || !self.radicand_bits.is_multiple_of(2 * rb) {
            return Err(bad(format!(
                "radicand bits must be a multiple of {} up to 128, got {}",
                2 * rb,
                self.radicand_bits
            )));
        }
        if !(self.tick_bits + 2..=95).contains(&self.kernel_bits) {
            return Err(bad(format!(
                "kernel bits must be {}..=95 (k is three bus words), got {}",
                self.tick_bits + 2,
                self.kernel_bits
            )));
        }
        if self.radicand_bits < 2 * self.tick_bits {
            return Err(bad(format!(
                "radicand bits {} too narrow for {} tick bits",
                self.radicand_bits, self.tick_bits
            )));
        }
        let finite = [self.clock_hz, self.max_rate, self.max_piece_s];
        if finite.iter().any(|v| !v.is_finite() || *v <= 0.0) {
            return Err(bad(
                "clock, max rate and max piece time must be positive and finite".into(),
            ));
        }
        // Periods of 4 ticks or more keep every rounded period >= 2, so the 50 % duty
        // STEP pulse is at least one tick high and one tick low.
        if self.max_rate * 4.0 > self.clock_hz {
            return Err(bad(format!(
                "max rate {} steps/s needs a clock of at least {} Hz (4 ticks per step), got {}",
                self.max_rate,
                self.max_rate * 4.0,
                self.clock_hz
            )));
        }
        let piece_ticks = (self.max_piece_s * self.clock_hz).ceil();
        if piece_ticks >= 2f64.powi(self.tick_bits as i32) {
            return Err(bad(format!(
                "tick bits {} too narrow: a {} s piece at {} Hz is {} ticks",
                self.tick_bits, self.max_piece_s, self.clock_hz, piece_ticks
            )));
        }
        let piece_steps = (self.max_piece_s * self.max_rate).ceil();
        if piece_steps >= 2f64.powi(self.step_bits as i32) {
            return Err(bad(format!(
                "step bits {} too narrow: a {} s piece at {} steps/s is {} steps",
                self.step_bits, self.max_piece_s, self.max_rate, piece_steps
            )));
        }
        let wq = self.tick_bits.div_ceil(rb) * rb;
        // the digit is 4 bits of the Config register
        if let Some(md) = self.recurrence.filter(|&md| md > 15) {
            return Err(bad(format!(
                "recurrence digit bits must be 0..=15 (0: full width), got {md}"
            )));
        }
        let lk = index_bits(self.axes);
        Ok(Widths {
            lk,
            ls,
            lf: self.fifo_depth.trailing_zeros(),
            wn: self.step_bits,
            wd: self.tick_bits,
            wq,
            wt: self.tick_bits + ls + 1,
            wy: self.radicand_bits,
            wk: self.kernel_bits,
            rb,
            md: MUL_DIGIT_BITS,
            aw: 1 + lk + 5,
            recur: self.recurrence,
        })
    }
}

impl Widths {
    /// `ms_core`'s parameters and their values for `axes` axes indexed by `lk` bits (the
    /// bus address: command bit, axis index, 5 word bits).
    pub fn core_param_list(&self, axes: u32, lk: u32) -> Vec<(&'static str, u32)> {
        let mut list = vec![
            ("K", axes),
            ("LK", lk),
            ("LS", self.ls),
            ("LF", self.lf),
            ("WN", self.wn),
            ("WD", self.wd),
            ("WQ", self.wq),
            ("WT", self.wt),
            ("WY", self.wy),
            ("WK", self.wk),
            ("RB", self.rb),
            ("MD", self.md),
            ("AW", 1 + lk + 5),
        ];
        if let Some(md) = self.recur {
            let (wa, wb, wu) = self.recur_bits();
            list.extend([
                ("RECUR", 1),
                ("MR", md),
                ("WRA", wa),
                ("WRB", wb),
                ("WRU", wu),
            ]);
        }
        list
    }

    /// The recurrence's `2A`, `B` and `4M` bits (`ms_core.v`'s WRA, WRB, WRU): fewer than
    /// the closed form's, which squares A. Phase moves at 50 MHz have B below 2^25 and 4M
    /// below 2^58, limits moves B up to 2^36 and 4M up to 2^76 (3 000 random ones); a
    /// piece beyond them takes the closed form.
    pub fn recur_bits(&self) -> (u32, u32, u32) {
        ((self.wk - 2).min(56), self.wk.min(40), self.wy.min(80))
    }

    /// Clocks of `ms_recur` from its start to `U(e0)` (its LAT): 5 at full width, two
    /// digit-serial products of ⌈(wq + 1) / md⌉ digits plus 4 otherwise.
    pub fn recur_jump_cycles(&self) -> Option<u32> {
        self.recur.map(|md| {
            if md == 0 {
                5
            } else {
                2 * (self.wq + 1).div_ceil(md) + 4
            }
        })
    }

    /// The core's clocks per recurrence step in the core TDM model's terms (`ms_core.v`):
    /// select, the prediction, the unit's jump and its answer, the FIFO write; a tick a
    /// move; a closed-form period as without the recurrence.
    pub fn recurrence_clocks(&self) -> Option<multistep_core::int::recurrence::RecurrenceClocks> {
        Some(multistep_core::int::recurrence::RecurrenceClocks {
            jump: self.recur_jump_cycles()? + 4,
            tick: 1,
            closed: self.period_cycles(),
        })
    }

    /// Cycles of the multiply j·dy (`ms_nmul.v`): one per digit of j.
    pub fn mul_cycles(&self) -> u32 {
        self.wn.div_ceil(self.md)
    }

    /// Cycles of the square root's iterations (`ms_isqrt.v`): WY/2 root bits, RB per cycle.
    pub fn sqrt_cycles(&self) -> u32 {
        self.wy / 2 / self.rb
    }

    /// Cycles of the divider's iterations (`ms_div.v`): WQ quotient bits, RB per cycle.
    pub fn div_cycles(&self) -> u32 {
        self.wq / self.rb
    }

    /// The RTL's cycles per period besides the three units (`ms_core.v`): select (piece
    /// memory read), dy into its register (out of block RAM, before the multiplier), the
    /// radicand add (square-root load), the numerator (divider load), the FIFO write.
    pub const OVERHEAD_CYCLES: u32 = 5;

    /// Cycles from one period's select to the next select (the same for every mode).
    pub fn period_cycles(&self) -> u32 {
        self.mul_cycles() + self.sqrt_cycles() + self.div_cycles() + Self::OVERHEAD_CYCLES
    }

    /// The RTL's latencies in the core TDM model's terms: one multiply, one square root,
    /// one divide, the overhead; one period at a time (not pipelined).
    pub fn latencies(&self) -> multistep_core::tdm::Latencies {
        multistep_core::tdm::Latencies {
            mul: self.mul_cycles(),
            sqrt: self.sqrt_cycles(),
            div: self.div_cycles(),
            overhead: Self::OVERHEAD_CYCLES,
            pipelined: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_build_id_gives_the_params_the_board_was_built_with() {
        let id = crate::BuildId {
            version: 1,
            axes: 2,
            fifo_depth_bits: 4,
            slot_bits: 2,
            radix_bits: 4,
            step_bits: 32,
            tick_bits: 24,
            radicand_bits: 68,
            kernel_bits: 72,
            clock_hz: 50_000_000,
            baud: 3_000_000,
            recurrence: Some(13),
        };
        let p = CoreParams::from(&id);
        assert_eq!((p.axes, p.fifo_depth, p.pieces), (2, 16, 4));
        assert_eq!(p.recurrence, Some(13));
        assert_eq!((p.tick_bits, p.kernel_bits, p.radix_bits), (24, 72, 4));
        // 2^24 − 1 ticks at 50 MHz
        assert!(
            (p.max_piece_s - 0.335_544_3).abs() < 1e-7,
            "{}",
            p.max_piece_s
        );
        assert_eq!(p.max_rate, CoreParams::default().max_rate);
    }

    /// The recurrence in the Config register's low byte, beside the radix bits, both ways;
    /// a digit beyond the register's 4 bits is refused.
    #[test]
    fn the_recurrence_is_in_the_build_id() {
        for recurrence in [None, Some(0), Some(13), Some(15)] {
            let p = CoreParams {
                recurrence,
                ..Default::default()
            };
            let id = crate::BuildId::of(&p, 3_000_000).unwrap();
            let byte = id.radix_bits | recurrence.map_or(0, |md| 0x80 | md << 3);
            let config = 2 << 24 | 4 << 16 | 2 << 8 | byte;
            let back =
                crate::BuildId::decode(0x4D53_0001, config, 0x1418_8044, 50_000_000, 3).unwrap();
            assert_eq!((back.radix_bits, back.recurrence), (2, recurrence));
        }
        let p = CoreParams {
            recurrence: Some(16),
            ..Default::default()
        };
        assert!(p.widths().is_err());
    }

    #[test]
    fn default_widths_and_cycles() {
        let w = CoreParams::default().widths().unwrap();
        assert_eq!((w.wy, w.wk, w.wq, w.wt, w.aw), (128, 68, 24, 27, 7));
        assert_eq!(
            (w.mul_cycles(), w.sqrt_cycles(), w.div_cycles()),
            (2, 32, 12)
        );
        assert_eq!(w.period_cycles(), 51);
        assert_eq!(w.latencies().latency(), 51);
        assert_eq!(w.latencies().interval(), 51);
        let r2 = CoreParams {
            radix_bits: 1,
            ..Default::default()
        };
        assert_eq!(r2.widths().unwrap().period_cycles(), 2 + 64 + 24 + 5);
    }

    /// The core TDM model's default calculator is this RTL at its default parameters.
    #[test]
    fn default_latencies_are_the_core_models() -> Result<(), FitError> {
        use multistep_core::tdm::Latencies;
        assert_eq!(
            CoreParams::default().widths()?.latencies(),
            Latencies::default()
        );
        let r2 = CoreParams {
            radix_bits: 1,
            ..Default::default()
        };
        assert_eq!(r2.widths()?.latencies(), Latencies::RADIX2);
        Ok(())
    }

    #[test]
    fn rejects_bad_parameters() {
        let p = CoreParams::default();
        for q in [
            CoreParams {
                axes: 0,
                ..p.clone()
            },
            CoreParams {
                fifo_depth: 0,
                ..p.clone()
            },
            CoreParams {
                fifo_depth: 12,
                ..p.clone()
            },
            CoreParams {
                tick_bits: 20,
                ..p.clone()
            }, // 0.3 s at 50 MHz = 15e6 ticks
            CoreParams {
                step_bits: 10,
                ..p.clone()
            },
            CoreParams {
                clock_hz: 1e5,
                ..p.clone()
            },
            CoreParams {
                radicand_bits: 126,
                ..p.clone()
            },
            CoreParams {
                radix_bits: 0,
                ..p.clone()
            },
            CoreParams {
                kernel_bits: 20,
                ..p.clone()
            },
        ] {
            assert!(matches!(q.widths(), Err(FitError::Param(_))), "{q:?}");
        }
    }
}
