//! Streamed moves: any profile family on the board. The host runs `plan`'s exact edge
//! generator (`multistep_core::edges`), codes the edges losslessly
//! (`multistep_core::stream`) and sends them in bulk writes to the axis's replay unit
//! (`rtl/board/ms_replay.v`), which turns them back into periods for the axis's FIFO and
//! pulse unit. The host keeps the axis's buffer ahead; if it falls behind, the pulse unit
//! underruns and `State` says so.

use crate::{AxisReg, BulkWrite, LinkError, Reg, RegWrite, BULK_MAX};
use multistep_core::stream::StreamEncoder;
use multistep_core::tdm::stream::Chunks;
use std::ops::Range;

/// A move's edges and their code.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StreamedMove {
    /// Edge ticks from the move's start, as `plan` gives them.
    pub edges: Vec<u64>,
    /// The coded schedule.
    pub bytes: Vec<u8>,
}

/// Part of a schedule to send: its bytes, and the earliest move tick at which the buffer
/// surely has room for them (`None`: before the start, into the empty buffer).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Chunk {
    pub not_before: Option<u64>,
    pub range: Range<usize>,
}

impl StreamedMove {
    /// Codes `edges`; every period must fit `period_bits` (the board's tick bits).
    pub fn from_edges(edges: Vec<u64>, period_bits: u32) -> Result<StreamedMove, LinkError> {
        let mut enc = StreamEncoder::new();
        let mut bytes = Vec::new();
        let mut last = 0;
        for (i, &t) in edges.iter().enumerate() {
            let p = t.wrapping_sub(last);
            if t <= last && i > 0 || p >> period_bits.min(63) != 0 {
                return Err(LinkError::Move(format!(
                    "step {i}: period of {p} ticks does not fit the board's {period_bits} \
                     tick bits"
                )));
            }
            enc.edge(t, &mut |b| bytes.push(b))
                .map_err(|e| LinkError::Move(e.to_string()))?;
            last = t;
        }
        enc.finish(&mut |b| bytes.push(b));
        Ok(StreamedMove { edges, bytes })
    }

    /// `plan`'s edges of `mv` at `clock_hz`, coded.
    pub fn plan(
        mv: &multistep_core::Move<'_>,
        clock_hz: u64,
        period_bits: u32,
    ) -> Result<StreamedMove, LinkError> {
        let g = multistep_core::edges(mv, clock_hz as f64)
            .map_err(|e| LinkError::Move(format!("plan: {e}")))?;
        Self::from_edges(g.collect(), period_bits)
    }

    pub fn steps(&self) -> u64 {
        self.edges.len() as u64
    }

    /// Link bytes per step of the code alone.
    pub fn bytes_per_step(&self) -> f64 {
        self.bytes.len() as f64 / self.edges.len().max(1) as f64
    }

    /// The schedule cut into bulk writes of at most `frame` bytes for a buffer of
    /// `buffer` bytes: what fits before the start, then each chunk at the tick of the
    /// STEP rise after which the buffer surely has room for it (a rise means its period
    /// was pushed, so its bytes were taken).
    /// The chunks are `multistep_core::tdm::stream::Chunks`, the link model's.
    pub fn chunks(&self, buffer: u64, frame: usize) -> Vec<Chunk> {
        let frame = frame.clamp(1, BULK_MAX) as u64;
        Chunks::new(&self.edges, self.bytes.len() as u64, buffer, frame)
            .map(|c| Chunk {
                not_before: c.not_before,
                range: c.start as usize..c.end as usize,
            })
            .collect()
    }

    /// The write that arms `axis` for this move (before its bulk writes and the start).
    pub fn arm_write(&self, axis: u32) -> RegWrite {
        RegWrite {
            reg: Reg::Axis(axis, AxisReg::StreamSteps),
            data: self.steps() as u32,
        }
    }

    /// The bulk write of `range` of the schedule to `axis`.
    pub fn bulk(&self, axis: u32, range: Range<usize>, seq: u8) -> BulkWrite {
        BulkWrite {
            seq,
            addr: Reg::Axis(axis, AxisReg::StreamData).addr(),
            data: self.bytes[range].to_vec(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunks_cover_the_schedule_and_wait_for_room() {
        // 2000 steps at about 500 ticks: half a byte each
        let edges: Vec<u64> = (1..=2000u64).map(|i| i * 500 + i % 3).collect();
        let m = StreamedMove::from_edges(edges, 24).unwrap();
        assert!(m.bytes_per_step() < 0.51, "{}", m.bytes_per_step());
        let c = m.chunks(256, 100);
        assert_eq!(c[0].range, 0..100);
        assert_eq!(c.iter().filter(|c| c.not_before.is_none()).count(), 2);
        assert_eq!(c.last().unwrap().range.end, m.bytes.len());
        for w in c.windows(2) {
            assert_eq!(w[0].range.end, w[1].range.start);
        }
        // the third chunk (bytes 200..300) needs 44 bytes taken: 88 nibbles, step 82
        // (the first period is 7 nibbles, the others 1)
        assert_eq!(c[2].not_before, Some(m.edges[81] + 1));
        assert!(StreamedMove::from_edges(vec![1 << 20], 20).is_err());
        assert!(StreamedMove::from_edges(vec![5, 5], 24).is_err());
    }
}
