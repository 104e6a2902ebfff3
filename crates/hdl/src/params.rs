//! Core parameters (axis count, FIFO depth, bit widths, clock and speed range), their
//! validation, and the internal bit widths derived from them.

use crate::HdlError;

/// What the user chooses. Every check runs in [`CoreParams::widths`], before any Verilog.
#[derive(Clone, Debug, PartialEq)]
pub struct CoreParams {
    /// Axes sharing the calculator (K), 1..=32 (the start mask is one 32-bit bus word).
    pub axes: u32,
    /// Periods per axis FIFO, a power of two >= 2.
    pub fifo_depth: u32,
    /// Segments per axis move, a power of two >= 2.
    pub segments: u32,
    /// Bits of a segment's step count (n < 2^step_bits).
    pub step_bits: u32,
    /// Bits of a segment's duration in ticks (d < 2^tick_bits); also the period width.
    pub tick_bits: u32,
    /// Fraction bits of the start-speed register s = v0 * 2^frac_bits * d.
    pub frac_bits: u32,
    /// Clock (ticks per second).
    pub clock_hz: f64,
    /// Highest step rate the core must produce (steps/s).
    pub max_rate: f64,
    /// Longest segment (s).
    pub max_segment_s: f64,
}

impl Default for CoreParams {
    fn default() -> Self {
        CoreParams {
            axes: 2,
            fifo_depth: 16,
            segments: 4,
            step_bits: 20,
            tick_bits: 24,
            frac_bits: 8,
            clock_hz: multistep_core::DEFAULT_CLOCK_HZ,
            max_rate: 200_000.0,
            max_segment_s: 0.3,
        }
    }
}

/// Internal widths of the RTL (the Verilog parameters of `ms_core`). Every zero-extension
/// in the RTL pads by at least one bit, so each width is one more than its largest operand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Widths {
    pub lk: u32,
    pub ls: u32,
    pub lf: u32,
    pub wn: u32,
    pub wd: u32,
    pub wf: u32,
    /// multiplier operand
    pub wm: u32,
    /// radicand
    pub wx: u32,
    /// divider numerator
    pub wnu: u32,
    /// divider denominator
    pub wde: u32,
    /// local edge (quotient)
    pub wq: u32,
    /// move tick
    pub wt: u32,
    /// bus address
    pub aw: u32,
}

fn bad(msg: String) -> HdlError {
    HdlError::Param(msg)
}

/// Bits to index `n` things (at least 1).
fn index_bits(n: u32) -> u32 {
    (32 - n.saturating_sub(1).leading_zeros()).max(1)
}

impl CoreParams {
    /// Checks every parameter and derives the RTL widths.
    pub fn widths(&self) -> Result<Widths, HdlError> {
        if self.axes == 0 || self.axes > 32 {
            return Err(bad(format!("axes must be 1..=32, got {}", self.axes)));
        }
        for (name, v) in [("fifo depth", self.fifo_depth), ("segments", self.segments)] {
            if v < 2 || !v.is_power_of_two() {
                return Err(bad(format!("{name} must be a power of two >= 2, got {v}")));
            }
        }
        if !(8..=32).contains(&self.tick_bits) {
            return Err(bad(format!(
                "tick bits must be 8..=32, got {}",
                self.tick_bits
            )));
        }
        if self.step_bits == 0 || self.step_bits > self.tick_bits {
            return Err(bad(format!(
                "step bits must be 1..=tick bits ({}), got {}",
                self.tick_bits, self.step_bits
            )));
        }
        if self.tick_bits + self.frac_bits > 32 {
            return Err(bad(format!(
                "tick bits + fraction bits must be <= 32 (the start-speed register is one bus word), got {}",
                self.tick_bits + self.frac_bits
            )));
        }
        let finite = [self.clock_hz, self.max_rate, self.max_segment_s];
        if finite.iter().any(|v| !v.is_finite() || *v <= 0.0) {
            return Err(bad(
                "clock, max rate and max segment time must be positive and finite".into(),
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
        let seg_ticks = (self.max_segment_s * self.clock_hz).ceil();
        if seg_ticks >= 2f64.powi(self.tick_bits as i32) {
            return Err(bad(format!(
                "tick bits {} too narrow: a {} s segment at {} Hz is {} ticks",
                self.tick_bits, self.max_segment_s, self.clock_hz, seg_ticks
            )));
        }
        let seg_steps = (self.max_segment_s * self.max_rate).ceil();
        if seg_steps >= 2f64.powi(self.step_bits as i32) {
            return Err(bad(format!(
                "step bits {} too narrow: a {} s segment at {} steps/s is {} steps",
                self.step_bits, self.max_segment_s, self.max_rate, seg_steps
            )));
        }
        let (wn, wd, wf) = (self.step_bits, self.tick_bits, self.frac_bits);
        let ls = index_bits(self.segments);
        let lk = index_bits(self.axes);
        // the same names as ms_calc.v: s < 2^WS, |A| < 2^WA, B = s d < 2^WB
        let ws = wd + wf;
        let wa = ws + 1;
        let wb = ws + wd;
        let wm = wb.max(wa + wn).max(2 * wd) + 1;
        let wx_need = (2 * wb).max(wa + wn + 2 * wd + wf + 2) + 2;
        let wx = wx_need + (wx_need & 1);
        if wx > 128 {
            return Err(bad(format!(
                "radicand needs {wx} bits, the reference model handles 128: lower tick or fraction bits"
            )));
        }
        let wnu = (wx / 2).max(wb).max(wa + 1).max(wd + wn + 1) + 2;
        let wde = (wn + 2).max(wa + 2) + 1;
        Ok(Widths {
            lk,
            ls,
            lf: self.fifo_depth.trailing_zeros(),
            wn,
            wd,
            wf,
            wm,
            wx,
            wnu,
            wde,
            wq: wd + 1,
            wt: wd + ls + 1,
            aw: 1 + lk + ls + 2,
        })
    }
}

impl Widths {
    /// Cycles of one multiply (`ms_mul.v`): launch, one per 16-bit digit, capture.
    pub fn mul_cycles(&self) -> u32 {
        self.wm.div_ceil(16) + 2
    }

    /// Cycles the calculator is busy for one period (`ms_calc.v`): 6 multiplies, the
    /// square root (launch, WX/2 rounds, capture) and the divide (launch, WQ rounds,
    /// capture). The scheduler adds 2 per period (start, FIFO write): one period every
    /// `calc_busy_cycles() + 2` cycles.
    pub fn calc_busy_cycles(&self) -> u32 {
        6 * self.mul_cycles() + (self.wx / 2 + 2) + (self.wq + 2)
    }

    /// The RTL's latencies in the core's TDM model's terms: its multiplies per period
    /// stand for our six (the remainder goes to the overhead), plus the scheduler's two
    /// cycles per period (start, FIFO write); one period at a time, not pipelined.
    pub fn latencies(&self) -> multistep_core::tdm::Latencies {
        use multistep_core::tdm::Latencies;
        let muls = 6 * self.mul_cycles();
        let mul = muls / Latencies::MULS_PER_PERIOD;
        Latencies {
            mul,
            sqrt: self.wx / 2 + 2,
            div: self.wq + 2,
            overhead: 2 + muls - mul * Latencies::MULS_PER_PERIOD,
            pipelined: false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_widths() {
        let w = CoreParams::default().widths().unwrap();
        assert_eq!((w.wm, w.wx, w.wq, w.wt, w.aw), (57, 114, 25, 27, 6));
        assert_eq!(w.calc_busy_cycles(), 6 * 6 + 59 + 27);
        assert_eq!(w.latencies().latency(), 124);
        assert_eq!(w.latencies().interval(), 124);
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
        ] {
            assert!(matches!(q.widths(), Err(HdlError::Param(_))), "{q:?}");
        }
    }
}
