//! Chained axes: the board computes an axis's polynomial pieces with a forward-difference
//! chain (`int::chain`; `ms_chain` on the board) that walks one tick a clock, never
//! faster, loading each piece's record first. So the chain is ahead of its pulse unit only
//! by what it gained before the group's start (the start waits for a full FIFO) and at
//! piece ends (the rest of a piece's ticks are skipped), less the record loads and the
//! clocks it waits on a full FIFO. This models that timeline clock by clock:
//!
//! - **Walk**: from a record's first tick `lo` the chain reaches step i's edge `t_i` after
//!   `t_i − lo` clocks, one more for the edge; a piece's record takes `load` clocks first.
//! - **FIFO**: step i's period goes into a FIFO of `depth` only after period `i − depth`
//!   left it, which the pulse unit takes at step `i − depth − 1`'s edge.
//! - **Start**: the group goes when the FIFO is full (or holds the whole move).
//! - **Underrun**: the pulse unit takes period i at step `i − 1`'s edge; a later push is
//!   an underrun there (its edges are late, none early).
//!
//! A slow tail after a fast stretch is what starves it: a FIFO full of short periods is
//! little lead, and periods longer than the lead come late. The host streams such moves.
//! No allocation: the edges and pieces are caller slices.

/// A record's steps `first..=last` (1-based) and the tick `lo` it starts walking from
/// (`int::ChainPiece`'s fields; step N's own record has `lo` at its tick).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainSpan {
    pub first: u64,
    pub last: u64,
    pub lo: u64,
}

/// The chain's timeline against its pulse unit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ChainTimeline {
    /// Clocks from the chain's start (the axis's init) to the group's start.
    pub go: u64,
    /// The least clocks a period was in the FIFO before the pulse unit took it
    /// (negative: late).
    pub least_slack: i64,
    /// The first step (0-based) whose period comes late, if any.
    pub first_late: Option<usize>,
}

/// The timeline of a chain making `edges` (ticks from the move's start, step i at
/// `edges[i − 1]`) from the records `spans` (in order, covering every step) into a FIFO of
/// `depth` periods, each record loaded in `load` clocks. `None` if a span names a step
/// beyond `edges` or an edge lies before its record's `lo`.
pub fn chain_timeline(
    edges: &[u64],
    spans: &[ChainSpan],
    depth: usize,
    load: u64,
) -> Option<ChainTimeline> {
    let n = edges.len();
    let depth = depth.max(1);
    let edge = |i: usize| if i == 0 { 0 } else { edges[i - 1] };
    let mut out = ChainTimeline {
        least_slack: i64::MAX,
        ..Default::default()
    };
    let mut go: Option<u64> = None;
    let mut c = 0u64; // clock
    let mut e; // the chain's tick
    for s in spans {
        let (first, last) = (s.first as usize, s.last as usize);
        if first == 0 || last > n || first > last {
            return None;
        }
        c += load;
        e = s.lo;
        for i in first..=last {
            let t = edges[i - 1];
            if t < e {
                return None;
            }
            c += t - e;
            if let Some(g) = go {
                // room: period i − depth left the FIFO at step i − depth − 1's edge
                if i > depth {
                    c = c.max(g + edge(i - depth - 1) + 1);
                }
                let slack = (g + edge(i - 1)) as i64 - c as i64;
                if slack < out.least_slack {
                    out.least_slack = slack;
                }
                if slack < 0 && out.first_late.is_none() {
                    out.first_late = Some(i - 1);
                }
            }
            if go.is_none() && (i == depth || i == n) {
                go = Some(c + 1);
            }
            c += 1;
            e = t + 1;
        }
    }
    out.go = go.unwrap_or(c);
    if out.least_slack == i64::MAX {
        out.least_slack = 0;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slow_tail_after_a_fast_stretch_starves_the_chain() {
        // 40 steps 100 ticks apart, then 10 steps 3000 apart: a full FIFO of 16 short
        // periods is about 1600 clocks of lead, less than one long period
        let mut edges: Vec<u64> = (1..=40).map(|i| 1000 + 100 * i).collect();
        let last = *edges.last().unwrap();
        edges.extend((1..=10).map(|i| last + 3000 * i));
        let spans = [
            ChainSpan {
                first: 1,
                last: 40,
                lo: 0,
            },
            ChainSpan {
                first: 41,
                last: 50,
                lo: last + 1,
            },
        ];
        let t = chain_timeline(&edges, &spans, 16, 221).unwrap();
        assert_eq!(t.first_late, Some(40), "{t:?}");
        assert!(t.least_slack < 0);
        // the same tail after a slow start: the FIFO's lead covers it
        let slow: Vec<u64> = (1..=50).map(|i| 3000 * i).collect();
        let spans = [ChainSpan {
            first: 1,
            last: 50,
            lo: 0,
        }];
        let t = chain_timeline(&slow, &spans, 16, 221).unwrap();
        assert_eq!(t.first_late, None, "{t:?}");
        assert!(t.least_slack > 40_000, "{t:?}");
        // bad spans
        assert!(chain_timeline(
            &slow,
            &[ChainSpan {
                first: 1,
                last: 51,
                lo: 0
            }],
            16,
            1
        )
        .is_none());
    }
}
