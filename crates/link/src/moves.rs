//! What the core's registers hold: per axis, the pieces of a `multistep_core::int` move
//! that have steps, each as its per-step kernel, start tick and step count. The reference
//! edges are the core's own (`StepKernel::local_edge`); nothing here re-derives a formula.
//!
//! A piece whose local edges or step count outgrow the core's tick or step bits is split
//! at step boundaries into pieces that fit ([`PieceRegs::split_at`]): exact integer
//! re-basing of the same kernel, so the split move's edges are the planned move's, tick
//! for tick.

use crate::{CoreParams, FitError, Widths};
use multistep_core::int::{IntProfile, KernelMode, StepKernel};

/// One piece slot of an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PieceRegs {
    pub kernel: StepKernel,
    /// Start tick (from the move's start) and duration (the next piece of the same
    /// planned piece, if split, starts at `t0 + dur`). The core holds t0 only.
    pub t0: u64,
    pub dur: u64,
    /// Steps in the piece (>= 1).
    pub steps: u64,
}

/// Splitting stops past this many pieces, or the slots if more (a move far beyond them).
const MOST_PIECES: usize = 4096;

/// One axis's move: direction and its pieces with steps, in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AxisMove {
    pub dir: bool,
    pub pieces: Vec<PieceRegs>,
}

/// The RTL's mode code (`ms_calc.v`).
pub fn mode_code(m: KernelMode) -> u32 {
    match m {
        KernelMode::Accel => 0,
        KernelMode::Decel => 1,
        KernelMode::Cruise => 2,
    }
}

impl PieceRegs {
    /// Radicand of step j (None if it leaves 0..2^128).
    fn radicand(&self, j: u64) -> Option<u128> {
        let d = self.kernel.dy.checked_mul(u128::from(j))?;
        match self.kernel.mode {
            KernelMode::Decel => self.kernel.y0.checked_sub(d),
            _ => self.kernel.y0.checked_add(d),
        }
    }

    /// Checks every register against the core's widths (the radicand is monotonic in j,
    /// so its two ends bound it). `wraps`: the piece may end past move tick 2^WT (a core
    /// loaded while it runs, [`AxisMove::rolling`]).
    fn check(&self, w: &Widths, index: usize, wraps: bool) -> Result<(), FitError> {
        let err = |reason: String| FitError::Piece { index, reason };
        let fits = |x: u128, bits: u32| bits >= 128 || x >> bits == 0;
        if self.steps == 0 || !fits(self.steps.into(), w.wn) {
            return Err(err(format!("{} steps not in 1..2^{}", self.steps, w.wn)));
        }
        let kn = &self.kernel;
        for j in [0, self.steps - 1] {
            match self.radicand(j) {
                Some(y) if fits(y, w.wy) => {}
                _ => {
                    return Err(err(format!(
                        "radicand of step {j} does not fit {} bits",
                        w.wy
                    )))
                }
            }
        }
        if kn.dv == 0 || !fits(kn.dv, w.wk) {
            return Err(err(format!("divisor {} does not fit {} bits", kn.dv, w.wk)));
        }
        let k_lim = 1i128 << w.wk;
        if kn.k < -k_lim || kn.k >= k_lim {
            return Err(err(format!("k = {} does not fit {} bits", kn.k, w.wk + 1)));
        }
        // the calculator's quotient is the local edge: the last one is the largest
        let last = self.local_edge(self.steps - 1).ok_or_else(|| {
            err(format!(
                "the edge of step {} is not a tick of this piece",
                self.steps - 1
            ))
        })?;
        if !fits(last.into(), w.wd) {
            return Err(err(format!(
                "its last edge is {last} ticks after its start: more than {} tick bits",
                w.wd
            )));
        }
        if !wraps && !fits(u128::from(self.t0) + u128::from(last), w.wt) {
            return Err(err(format!("ends after tick 2^{}", w.wt)));
        }
        Ok(())
    }

    /// The local edge of step j by the core's kernel; None past the piece's end or where
    /// the kernel's arithmetic would leave its range (a kernel no planner made).
    pub fn local_edge(&self, j: u64) -> Option<u64> {
        let kn = &self.kernel;
        let y = self.radicand(j)?;
        // core::int's local_edge adds k to the root in i128, divides by dv and, on Decel,
        // takes ⌊√Y⌋ from k: k ≥ ⌊√Y⌋ is (k + 1)² > Y
        let decel_ok = || {
            let k1 = u128::try_from(kn.k).ok()? + 1;
            k1.checked_mul(k1).is_none_or(|sq| sq > y).then_some(())
        };
        if kn.dv == 0 || kn.k.unsigned_abs() >> 126 != 0 {
            return None;
        }
        if kn.mode == KernelMode::Decel {
            decel_ok()?;
        }
        let e = kn.local_edge(j);
        // a negative numerator wraps to a huge quotient: not an edge of this piece
        (e <= self.dur).then_some(e)
    }

    /// The piece from step `s` on, its time origin moved `shift` ticks later: the same
    /// kernel with Y advanced s steps and `shift·dv` taken from the numerator, since
    /// ⌊(n − shift·dv)/dv⌋ = ⌊n/dv⌋ − shift (the numerators of steps s.. are at least
    /// shift·dv when shift is at most step s's local edge, so none goes negative). Step j
    /// of the result is step s + j of `self`, its edge `t0 + shift + local` the same tick.
    /// None if s is not inside the piece, shift is past step s's edge, or a number leaves
    /// 128 bits.
    pub fn split_at(&self, s: u64, shift: u64) -> Option<PieceRegs> {
        if s >= self.steps || shift > self.local_edge(s)? {
            return None;
        }
        let kn = &self.kernel;
        let y0 = self.radicand(s)?;
        let cut = u128::from(shift).checked_mul(kn.dv)?;
        let kernel = match kn.mode {
            KernelMode::Cruise => StepKernel {
                y0: y0.checked_sub(cut)?,
                ..*kn
            },
            KernelMode::Accel | KernelMode::Decel => StepKernel {
                y0,
                k: kn.k.checked_sub(i128::try_from(cut).ok()?)?,
                ..*kn
            },
        };
        Some(PieceRegs {
            kernel,
            t0: self.t0.checked_add(shift)?,
            dur: self.dur - shift,
            steps: self.steps - s,
        })
    }

    /// This piece as pieces whose local edges fit `max_ticks` and whose step counts fit
    /// `max_steps`, each as long as it can be (binary search over the monotonic edges),
    /// appended to `out` until it holds more than `most`. A piece that fits is appended
    /// as it is. None only if a number leaves 128 bits.
    fn split_to_fit(
        &self,
        max_ticks: u64,
        max_steps: u64,
        out: &mut Vec<PieceRegs>,
        most: usize,
    ) -> Option<()> {
        let mut rest = *self;
        while out.len() <= most {
            // a first edge past the ticks (the gap before it is the period's concern):
            // the piece starts at it
            let first = rest.local_edge(0)?;
            if first > max_ticks {
                rest = rest.split_at(0, first)?;
            }
            // the most steps from rest's first on whose edges are at most max_ticks
            let (mut lo, mut hi) = (0u64, rest.steps.min(max_steps));
            while lo < hi {
                let mid = lo + (hi - lo).div_ceil(2);
                if rest.local_edge(mid - 1)? <= max_ticks {
                    lo = mid;
                } else {
                    hi = mid - 1;
                }
            }
            if lo == 0 {
                return None;
            }
            if lo == rest.steps {
                out.push(rest);
                break;
            }
            // the next piece starts at its first edge (local edge 0)
            let next = rest.split_at(lo, rest.local_edge(lo)?)?;
            out.push(PieceRegs {
                dur: next.t0 - rest.t0,
                steps: lo,
                ..rest
            });
            rest = next;
        }
        Some(())
    }
}

impl AxisMove {
    /// The pieces with steps of a planned integer move, each split into as few pieces as
    /// fit the core's tick and step bits ([`PieceRegs::split_at`]). Fails if a piece needs
    /// the software wide path (no 128-bit kernel), or the move does not fit the core `p`
    /// (its slots, or a width splitting does not change).
    pub fn from_profile(
        profile: &IntProfile,
        dir: bool,
        p: &CoreParams,
    ) -> Result<AxisMove, FitError> {
        let m = Self::split(profile, dir, p, p.pieces as usize, "the core holds")?;
        m.check(p)?;
        Ok(m)
    }

    /// The same pieces for a core loaded while it runs: up to 4096, however many slots
    /// the core has. Piece i goes into slot i mod slots once piece i − slots is done
    /// (its STEP rises made: the calculator runs ahead of the pulse unit), and the axis
    /// control word then names its slot as the last, so the core never reads a slot
    /// being written and stops where the loaded pieces end. The core's move ticks wrap:
    /// an edge is a piece's t0 plus its local edge and a period the difference of two,
    /// both modulo 2^WT, so a piece's t0 may pass 2^WT (the staging word's low WT bits).
    pub fn rolling(profile: &IntProfile, dir: bool, p: &CoreParams) -> Result<AxisMove, FitError> {
        let m = Self::split(profile, dir, p, MOST_PIECES, "a rolling load holds")?;
        m.check_inner(p, true)?;
        Ok(m)
    }

    /// The pieces of `profile` split to fit, at most `limit` of them (`holds`: what the
    /// error says holds `limit`).
    fn split(
        profile: &IntProfile,
        dir: bool,
        p: &CoreParams,
        limit: usize,
        holds: &str,
    ) -> Result<AxisMove, FitError> {
        let w = p.widths()?;
        let max = |bits: u32| (1u64 << bits.min(63)) - 1;
        let mut pieces = Vec::new();
        let mut planned = 0;
        let most = limit.max(MOST_PIECES);
        for (index, pc) in profile.pieces().iter().enumerate() {
            if pc.steps == 0 {
                continue;
            }
            planned += 1;
            let kernel = *pc.kernel().ok_or(FitError::Piece {
                index,
                reason: "its radicand needs more than 128 bits (core::int's wide path)".into(),
            })?;
            let whole = PieceRegs {
                kernel,
                t0: pc.t0,
                dur: pc.dur,
                steps: pc.steps,
            };
            whole
                .split_to_fit(max(w.wd), max(w.wn), &mut pieces, most)
                .ok_or_else(|| FitError::Piece {
                    index,
                    reason: "splitting it leaves 128 bits".into(),
                })?;
        }
        if pieces.len() > limit {
            let more = if pieces.len() > most {
                "more than "
            } else {
                ""
            };
            return Err(FitError::Move(format!(
                "{more}{} pieces with steps ({planned} planned, split at {} ticks and {} \
                 steps); {holds} 1..={limit}",
                pieces.len().min(most),
                max(w.wd),
                max(w.wn),
            )));
        }
        Ok(AxisMove { dir, pieces })
    }

    /// Checks the move against the core: slot count, every register's width, every period
    /// (at least 2 ticks, at most the tick bits).
    pub fn check(&self, p: &CoreParams) -> Result<(), FitError> {
        self.check_inner(p, false)
    }

    /// The checks of a move loaded while the core runs ([`rolling`](Self::rolling)): as
    /// [`check`](Self::check), but up to 4096 pieces, ending past move tick 2^WT.
    pub fn check_rolling(&self, p: &CoreParams) -> Result<(), FitError> {
        self.check_inner(p, true)
    }

    fn check_inner(&self, p: &CoreParams, rolling: bool) -> Result<(), FitError> {
        let w = p.widths()?;
        let slots = if rolling {
            MOST_PIECES
        } else {
            p.pieces as usize
        };
        if self.pieces.is_empty() || self.pieces.len() > slots {
            return Err(FitError::Move(format!(
                "{} pieces with steps; the core holds 1..={slots}",
                self.pieces.len(),
            )));
        }
        for (index, pc) in self.pieces.iter().enumerate() {
            pc.check(&w, index, rolling)?;
        }
        let edges = self.edges();
        let mut prev = 0;
        for (i, &e) in edges.iter().enumerate() {
            if e < prev || (e - prev) >> w.wd != 0 {
                return Err(FitError::Move(format!(
                    "period {} of step {} does not fit {} tick bits",
                    e.wrapping_sub(prev),
                    i + 1,
                    w.wd
                )));
            }
            // the 50 % pulse needs a tick high and a tick low (the first edge may be at 1)
            if i > 0 && e - prev < 2 {
                return Err(FitError::Move(format!(
                    "step {} is {} tick after the previous one (at least 2)",
                    i + 1,
                    e - prev
                )));
            }
            prev = e;
        }
        Ok(())
    }

    pub fn steps(&self) -> u64 {
        self.pieces.iter().map(|p| p.steps).sum()
    }

    /// The pieces a core of `slots` slots takes while the move runs
    /// ([`rolling`](Self::rolling)), as `(i, made)`: piece i may go into slot i mod slots
    /// once the axis has made `made` steps, those of pieces 0 to i − slots.
    pub fn late_pieces(&self, slots: usize) -> impl Iterator<Item = (usize, u64)> + '_ {
        let slots = slots.max(1);
        (slots..self.pieces.len()).scan(0, move |made, i| {
            *made += self.pieces[i - slots].steps;
            Some((i, *made))
        })
    }

    /// Every edge tick (from the move's start), by the core's kernels.
    pub fn edges(&self) -> Vec<u64> {
        self.pieces
            .iter()
            .flat_map(|p| (0..p.steps).map(move |j| p.t0 + p.kernel.local_edge(j)))
            .collect()
    }
}
