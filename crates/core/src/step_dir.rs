//! How STEP and DIR are timed around the planned edges, one definition for the STEP/DIR
//! driver ([`crate::hal`]), the TDM engine ([`crate::tdm`]) and, through the TDM model,
//! the Verilog core's tests.

/// The high time of STEP pulses. The driver and the TDM pulse unit give the same widths:
/// half the interval to the next edge (the last pulse: half its own interval), at least one
/// tick (after an underrun in the TDM engine: half the late period after it arrived); or a
/// fixed number of ticks. A pulse that would reach the next rise is cut there on
/// a pin (the TDM model reports it as merged).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PulseShape {
    /// High for half of the interval to the next edge (50 % duty, seed 000).
    #[default]
    HalfInterval,
    /// High for a fixed number of ticks.
    Fixed {
        /// Ticks high.
        ticks: u64,
    },
}

/// STEP pulse width and DIR setup: what a driver needs besides the edges.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StepDirTiming {
    /// How long STEP stays high.
    pub pulse: PulseShape,
    /// Least ticks between setting DIR and tick 0 of the move (the driver starts the move
    /// exactly this long after DIR; the TDM engine starts its group no earlier).
    pub dir_setup_ticks: u64,
}
