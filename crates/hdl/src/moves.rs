//! What the core's registers hold: per axis, the pieces of a `multistep_core::int` move
//! that have steps, each as its per-step kernel, start tick and step count. The reference
//! edges are the core's own (`StepKernel::local_edge`); nothing here re-derives a formula.

use crate::{CoreParams, HdlError, Widths};
use multistep_core::int::{IntProfile, KernelMode, StepKernel};

/// One piece slot of an axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PieceRegs {
    pub kernel: StepKernel,
    /// Start tick (from the move's start) and duration.
    pub t0: u64,
    pub dur: u64,
    /// Steps in the piece (>= 1).
    pub steps: u64,
}

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
    /// so its two ends bound it).
    fn check(&self, w: &Widths, index: usize) -> Result<(), HdlError> {
        let err = |reason: String| HdlError::Piece { index, reason };
        let fits = |x: u128, bits: u32| bits >= 128 || x >> bits == 0;
        if self.steps == 0 || !fits(self.steps.into(), w.wn) {
            return Err(err(format!("{} steps not in 1..2^{}", self.steps, w.wn)));
        }
        if !fits(self.dur.into(), w.wd) {
            return Err(err(format!(
                "{} ticks do not fit {} tick bits",
                self.dur, w.wd
            )));
        }
        if !fits(u128::from(self.t0) + u128::from(self.dur), w.wt) {
            return Err(err(format!("ends after tick 2^{}", w.wt)));
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
        Ok(())
    }
}

impl AxisMove {
    /// The pieces with steps of a planned integer move. Fails if a piece needs the software
    /// wide path (no 128-bit kernel), or does not fit the core `p`.
    pub fn from_profile(
        profile: &IntProfile,
        dir: bool,
        p: &CoreParams,
    ) -> Result<AxisMove, HdlError> {
        let mut pieces = Vec::new();
        for (index, pc) in profile.pieces().iter().enumerate() {
            if pc.steps == 0 {
                continue;
            }
            let kernel = *pc.kernel().ok_or(HdlError::Piece {
                index,
                reason: "its radicand needs more than 128 bits (core::int's wide path)".into(),
            })?;
            pieces.push(PieceRegs {
                kernel,
                t0: pc.t0,
                dur: pc.dur,
                steps: pc.steps,
            });
        }
        let m = AxisMove { dir, pieces };
        m.check(p)?;
        Ok(m)
    }

    /// Checks the move against the core: slot count, every register's width, every period
    /// (at least 2 ticks, at most the tick bits).
    pub fn check(&self, p: &CoreParams) -> Result<(), HdlError> {
        let w = p.widths()?;
        if self.pieces.is_empty() || self.pieces.len() > p.pieces as usize {
            return Err(HdlError::Move(format!(
                "{} pieces with steps; the core holds 1..={}",
                self.pieces.len(),
                p.pieces
            )));
        }
        for (index, pc) in self.pieces.iter().enumerate() {
            pc.check(&w, index)?;
        }
        let edges = self.edges();
        let mut prev = 0;
        for (i, &e) in edges.iter().enumerate() {
            if e < prev || (e - prev) >> w.wd != 0 {
                return Err(HdlError::Move(format!(
                    "period {} of step {} does not fit {} tick bits",
                    e.wrapping_sub(prev),
                    i + 1,
                    w.wd
                )));
            }
            // the 50 % pulse needs a tick high and a tick low (the first edge may be at 1)
            if i > 0 && e - prev < 2 {
                return Err(HdlError::Move(format!(
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

    /// Every edge tick (from the move's start), by the core's kernels.
    pub fn edges(&self) -> Vec<u64> {
        self.pieces
            .iter()
            .flat_map(|p| (0..p.steps).map(move |j| p.t0 + p.kernel.local_edge(j)))
            .collect()
    }
}
