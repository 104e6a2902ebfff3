//! Piece records for the per-axis forward-difference chain (`rtl/board/ms_chain.v`):
//! `multistep_core::int::chain`'s pieces at the unit's register widths, as the bytes the
//! unit shifts in (little-endian, lo first: lo, hi, count, R, Δ¹ … Δ⁴, M = Δ¹ − K: the unit
//! keeps M, advanced as Δ¹ is, so an edge's `R += Δ¹ − K` is one carry chain).

use crate::FitError;
use crate::{AxisReg, BulkWrite, Reg, RegWrite, BULK_MAX};
use multistep_core::int::{chain_pieces, ChainEdges, ChainValue, ChainWidths};
use multistep_core::tdm::chain::{chain_timeline, ChainSpan, ChainTimeline};
use multistep_core::{Move, Profile};
use std::ops::Range;

/// The chain unit's register widths (its Verilog parameters).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainLayout {
    /// R, Δ¹ … Δ⁴ and K (the sum a multiple of 8); M = Δ¹ − K is R's width.
    pub widths: ChainWidths,
    /// Tick and step-count fields.
    pub tick_bits: u32,
    pub count_bits: u32,
}

/// The widths `ms_chain.v` defaults to: phase-mode scurve4 moves of 0.1/0.3/0.1 s at
/// 50 MHz need R 290, Δ¹ 269 … Δ⁴ 207 and K 278 bits (`widths_of_typical_moves`); pieces
/// of a few hundred microseconds need wider high differences (Δ⁴ 228 bits).
pub const CHAIN_LAYOUT: ChainLayout = ChainLayout {
    widths: ChainWidths {
        r: 304,
        diff: [280, 264, 248, 240],
        k: 288,
    },
    tick_bits: 40,
    count_bits: 32,
};

impl ChainLayout {
    /// Bytes of one record.
    pub fn record_bytes(&self) -> usize {
        let w = &self.widths;
        let bits = 2 * self.tick_bits + self.count_bits + 2 * w.r + w.diff.iter().sum::<u32>();
        bits.div_ceil(8) as usize
    }

    /// The Verilog parameters of `ms_chain` for this layout.
    pub fn verilog_params(&self) -> String {
        let w = &self.widths;
        format!(
            "#(.WR({}), .W1({}), .W2({}), .W3({}), .W4({}), .WM({}), .WT({}), .WN({}))",
            w.r, w.diff[0], w.diff[1], w.diff[2], w.diff[3], w.r, self.tick_bits, self.count_bits
        )
    }

    /// Every record of `profile`'s move at `clock` Hz: one per piece holding steps, then
    /// step N's (lo = hi = its tick, one step). A piece too wide for the layout (or a
    /// shaped piece) is [`FitError::Move`].
    pub fn records(&self, profile: &Profile, clock: u64) -> Result<Vec<Vec<u8>>, FitError> {
        let bad = |e: &dyn std::fmt::Display| FitError::Move(e.to_string());
        let edges = ChainEdges::new(profile.clone(), clock, self.widths).map_err(|e| bad(&e))?;
        let mut out = Vec::new();
        for c in chain_pieces(profile, clock) {
            let c = c.map_err(|e| bad(&e))?;
            let w = &self.widths;
            // M = Δ¹ − K lies in (−2K, 0): one bit more than K, in R's width
            if c.widths.k + 1 > w.r {
                return Err(FitError::Move(format!(
                    "piece {}: K needs {} bits, M = Δ¹ − K more than R's {}",
                    c.piece, c.widths.k, w.r
                )));
            }
            let mut fields: Vec<(ChainValue, u32)> = vec![
                (value_of(c.lo), self.tick_bits),
                (value_of(c.hi), self.tick_bits),
                (value_of(c.last - c.first + 1), self.count_bits),
                (c.r, w.r),
            ];
            fields.extend(c.diff.iter().zip(w.diff).map(|(d, b)| (*d, b)));
            fields.push((minus(&c.diff[0], &c.k), w.r));
            out.push(self.pack(&fields));
        }
        let end = value_of(edges.end_tick());
        let zero = [0u64; multistep_core::int::CHAIN_LIMBS];
        let w = &self.widths;
        let mut last = vec![
            (end, self.tick_bits),
            (end, self.tick_bits),
            (value_of(1), self.count_bits),
            (zero, w.r),
        ];
        last.extend(w.diff.iter().map(|&b| (zero, b)));
        last.push((zero, w.r));
        out.push(self.pack(&last));
        Ok(out)
    }

    /// Fields (two's complement values, low bits taken) packed low field first.
    fn pack(&self, fields: &[(ChainValue, u32)]) -> Vec<u8> {
        let mut bits = Vec::with_capacity(self.record_bytes() * 8);
        for (v, n) in fields {
            bits.extend((0..*n).map(|b| (v[(b / 64) as usize] >> (b % 64)) & 1 == 1));
        }
        bits.chunks(8)
            .map(|c| c.iter().rev().fold(0u8, |a, &b| a << 1 | b as u8))
            .collect()
    }
}

/// A move the board computes with an axis's chain unit: `plan`'s edges (what the board must
/// make) and the records the host writes into the axis's stream buffer before the start.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChainedMove {
    /// Edge ticks from the move's start, as `plan` gives them.
    pub edges: Vec<u64>,
    /// The records, one after the other.
    pub bytes: Vec<u8>,
    pub records: usize,
    /// Each record's steps and first tick.
    pub spans: Vec<ChainSpan>,
}

impl ChainedMove {
    /// `mv`'s records at `clock_hz` for `layout`; every period must fit `period_bits` (the
    /// board's tick bits). A move with a piece the chain cannot compute (a non-polynomial
    /// family, or wider than the layout) is [`FitError::Move`]: stream it instead.
    pub fn plan(
        mv: &Move<'_>,
        clock_hz: u64,
        period_bits: u32,
        layout: &ChainLayout,
    ) -> Result<ChainedMove, FitError> {
        let profile = Profile::plan_on_clock(mv, clock_hz as f64)
            .map_err(|e| FitError::Move(format!("plan: {e}")))?;
        Self::from_profile(&profile, clock_hz, period_bits, layout)
    }

    /// As [`ChainedMove::plan`], for a planned profile (`Profile::plan_on_clock`'s).
    pub fn from_profile(
        profile: &Profile,
        clock_hz: u64,
        period_bits: u32,
        layout: &ChainLayout,
    ) -> Result<ChainedMove, FitError> {
        let records = layout.records(profile, clock_hz)?;
        let mut spans = Vec::with_capacity(records.len());
        for c in chain_pieces(profile, clock_hz) {
            let c = c.map_err(|e| FitError::Move(e.to_string()))?;
            spans.push(ChainSpan {
                first: c.first,
                last: c.last,
                lo: c.lo,
            });
        }
        let edges: Vec<u64> = multistep_core::EdgeGenerator::new(profile.clone(), clock_hz as f64)
            .map_err(|e| FitError::Move(format!("plan: {e}")))?
            .collect();
        let mut last = 0;
        for (i, &t) in edges.iter().enumerate() {
            let p = t.wrapping_sub(last);
            if p == 0 || p >> period_bits.min(63) != 0 {
                return Err(FitError::Move(format!(
                    "step {i}: period of {p} ticks does not fit the board's {period_bits} \
                     tick bits"
                )));
            }
            last = t;
        }
        let n = edges.len() as u64;
        spans.push(ChainSpan {
            first: n,
            last: n,
            lo: edges.last().copied().unwrap_or(0),
        });
        Ok(ChainedMove {
            edges,
            records: records.len(),
            bytes: records.concat(),
            spans,
        })
    }

    /// The chain's timeline on a board whose axis FIFO holds `fifo_depth` periods
    /// (`multistep_core::tdm::chain`): whether it stays ahead of the pulse unit.
    pub fn timeline(&self, fifo_depth: u32) -> ChainTimeline {
        let load = self.bytes.len().div_ceil(self.records.max(1)) as u64 + RECORD_CLOCKS;
        chain_timeline(&self.edges, &self.spans, fifo_depth as usize, load).unwrap_or(
            ChainTimeline {
                go: 0,
                least_slack: i64::MIN,
                first_late: Some(0),
            },
        )
    }

    /// The chain stays ahead of the pulse unit by at least [`CHAIN_MARGIN`] clocks on
    /// every step, so the board computes this move with no underrun.
    pub fn keeps_up(&self, fifo_depth: u32) -> bool {
        self.timeline(fifo_depth).least_slack >= CHAIN_MARGIN
    }

    pub fn steps(&self) -> u64 {
        self.edges.len() as u64
    }

    /// Link bytes per step of the records alone.
    pub fn bytes_per_step(&self) -> f64 {
        self.bytes.len() as f64 / self.edges.len().max(1) as f64
    }

    /// The write that arms `axis` for this move (before its bulk writes and the start).
    pub fn arm_write(&self, axis: u32) -> RegWrite {
        RegWrite {
            reg: Reg::Axis(axis, AxisReg::ChainSteps),
            data: self.steps() as u32,
        }
    }

    /// The records cut into bulk writes of at most `frame` bytes, all sent before the
    /// start (the stream buffer must hold them: `bytes.len()` at most its size).
    pub fn frames(&self, frame: usize) -> Vec<Range<usize>> {
        let frame = frame.clamp(1, BULK_MAX);
        (0..self.bytes.len())
            .step_by(frame)
            .map(|s| s..(s + frame).min(self.bytes.len()))
            .collect()
    }

    /// The bulk write of `range` of the records to `axis`.
    pub fn bulk(&self, axis: u32, range: Range<usize>, seq: u8) -> BulkWrite {
        BulkWrite {
            seq,
            addr: Reg::Axis(axis, AxisReg::StreamData).addr(),
            data: self.bytes[range].to_vec(),
        }
    }
}

/// Clocks a record's load takes beyond its bytes (`ms_chain_axis`: the last byte's read,
/// the start).
pub const RECORD_CLOCKS: u64 = 3;
/// Least clocks a chained move's periods must be ahead of the pulse unit for the host to
/// choose the chain over streaming (the model leaves out the start's few clocks).
pub const CHAIN_MARGIN: i64 = 64;

/// `a − b` in two's complement.
fn minus(a: &ChainValue, b: &ChainValue) -> ChainValue {
    let mut out = *a;
    let mut borrow = false;
    for (x, y) in out.iter_mut().zip(b) {
        let (d1, b1) = x.overflowing_sub(*y);
        let (d2, b2) = d1.overflowing_sub(borrow as u64);
        *x = d2;
        borrow = b1 | b2;
    }
    out
}

fn value_of(x: u64) -> ChainValue {
    let mut v = [0u64; multistep_core::int::CHAIN_LIMBS];
    v[0] = x;
    v
}
