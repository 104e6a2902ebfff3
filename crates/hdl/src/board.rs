//! The board top level `ms_board` (`rtl/board/`): the core behind a UART host link, with
//! e-stop, ENABLE, DIR setup, pulse width, Hall and limit inputs. A per-board wrapper (PLL
//! and pins) instantiates it with [`BoardTop::verilog_params`].

use crate::{CoreParams, HdlError, Widths, LIBRARY};

/// The board modules, one small module per file (besides [`LIBRARY`], the core's).
pub const BOARD_LIBRARY: [(&str, &str); 17] = [
    ("ms_sync.v", include_str!("../rtl/board/ms_sync.v")),
    ("ms_onehot.v", include_str!("../rtl/board/ms_onehot.v")),
    ("ms_reset.v", include_str!("../rtl/board/ms_reset.v")),
    ("ms_uart_rx.v", include_str!("../rtl/board/ms_uart_rx.v")),
    ("ms_uart_tx.v", include_str!("../rtl/board/ms_uart_tx.v")),
    ("ms_crc16.v", include_str!("../rtl/board/ms_crc16.v")),
    ("ms_link.v", include_str!("../rtl/board/ms_link.v")),
    (
        "ms_filter_clock.v",
        include_str!("../rtl/board/ms_filter_clock.v"),
    ),
    ("ms_debounce.v", include_str!("../rtl/board/ms_debounce.v")),
    ("ms_axis_io.v", include_str!("../rtl/board/ms_axis_io.v")),
    (
        "ms_positions.v",
        include_str!("../rtl/board/ms_positions.v"),
    ),
    ("ms_nibble.v", include_str!("../rtl/board/ms_nibble.v")),
    (
        "ms_step_counts.v",
        include_str!("../rtl/board/ms_step_counts.v"),
    ),
    (
        "ms_replay_axis.v",
        include_str!("../rtl/board/ms_replay_axis.v"),
    ),
    ("ms_replay.v", include_str!("../rtl/board/ms_replay.v")),
    ("ms_regs.v", include_str!("../rtl/board/ms_regs.v")),
    ("ms_board.v", include_str!("../rtl/board/ms_board.v")),
];

/// The chain units' modules, in a build only when [`BoardTop::chains`] is set (so a board
/// without them is synthesized from exactly the files above).
pub const CHAIN_LIBRARY: [(&str, &str); 4] = [
    (
        "ms_step_count.v",
        include_str!("../rtl/board/ms_step_count.v"),
    ),
    ("ms_stream.v", include_str!("../rtl/board/ms_stream.v")),
    ("ms_chain.v", include_str!("../rtl/board/ms_chain.v")),
    (
        "ms_chain_axis.v",
        include_str!("../rtl/board/ms_chain_axis.v"),
    ),
];

/// Most a UART bit time may be off the nominal baud (the receiver samples once per bit,
/// at its middle, so 10 bits tolerate about 5 % between both ends; half of it is ours).
pub const MAX_BAUD_ERROR: f64 = 0.025;

/// The bits of each Hall and limit filter's counter (`ms_board`'s `WB`).
pub const FILTER_BITS: u32 = 10;

/// The longest a changed input level is held before its filter accepts it, in clocks from
/// its first one, for a `Debounce` of `ticks` clocks (`ms_filter_clock`): exactly `ticks`
/// (at least 1) below 2^(FILTER_BITS - 1); longer, (ticks / P + 2) P with P the least power
/// of two that brings ticks / P below that (the shortest is more than `ticks`).
pub fn filter_latest(ticks: u64) -> u64 {
    let half = 1u64 << (FILTER_BITS - 1);
    match (0..64).map(|s| 1u64 << s).find(|&p| ticks / p < half) {
        Some(1) | None => ticks.max(1),
        Some(p) => (ticks / p + 2) * p,
    }
}

/// What `ms_board` is built with.
#[derive(Clone, Debug, PartialEq)]
pub struct BoardTop {
    /// The core; its clock is the board clock (a whole number of Hz).
    pub core: CoreParams,
    /// UART baud.
    pub baud: u32,
    /// The e-stop input's active level (true: high stops).
    pub estop_active_high: bool,
    /// Each axis's stream buffer is 2^bits bytes (8..=16), or 0: no replay units (the
    /// board computes trapezoids only).
    pub stream_buffer_bits: u32,
    /// The SYNC line for cross-board group starts (`Arm`, `Fire`, `SyncTick`).
    pub sync: bool,
    /// A forward-difference chain unit per axis (`ms_chain_axis`): scurve and scurve4
    /// pieces computed on the board from [`crate::chain::CHAIN_LAYOUT`] records, fed
    /// through the stream buffer (needs `stream_buffer_bits` ≥ 8).
    pub chains: bool,
    /// The family has distributed RAM (ECP5): the calculator's dy memory is held there
    /// (`LUTRAM`), as it must be read into the multiplier within a clock.
    pub lutram: bool,
    /// Every axis has a limit input (else the limit filters are left out and the limits
    /// read inactive: a pin layout without limit wires).
    pub limits: bool,
}

impl BoardTop {
    pub fn new(core: CoreParams, baud: u32) -> BoardTop {
        BoardTop {
            core,
            baud,
            estop_active_high: true,
            stream_buffer_bits: 9,
            sync: true,
            chains: false,
            lutram: false,
            limits: true,
        }
    }

    /// Checks the core and the link parameters.
    pub fn widths(&self) -> Result<Widths, HdlError> {
        let w = self.core.widths()?;
        let hz = self.core.clock_hz;
        if hz.fract() != 0.0 || hz > f64::from(u32::MAX) {
            return Err(HdlError::Param(format!(
                "the board clock must be a whole number of Hz below 2^32, got {hz}"
            )));
        }
        if self.baud == 0 || self.div() < 4 || self.div() > 0xFFFF {
            return Err(HdlError::Param(format!(
                "baud {} needs 4..=65535 clocks per bit at {hz} Hz",
                self.baud
            )));
        }
        let lb = self.stream_buffer_bits;
        if lb != 0 && !(8..=16).contains(&lb) {
            return Err(HdlError::Param(format!(
                "stream buffer bits must be 0 or 8..=16, got {lb}"
            )));
        }
        if self.chains && lb == 0 {
            return Err(HdlError::Param(
                "chain units read their records from the stream buffer: give it 8..=16 bits".into(),
            ));
        }
        let err = self.baud_error();
        if err > MAX_BAUD_ERROR {
            return Err(HdlError::Param(format!(
                "baud {} is {:.1} % off at {hz} Hz ({} clocks per bit; at most {} %)",
                self.baud,
                err * 100.0,
                self.div(),
                MAX_BAUD_ERROR * 100.0
            )));
        }
        Ok(w)
    }

    /// Clocks per UART bit: CLK_HZ / BAUD rounded (`ms_board.v`).
    pub fn div(&self) -> u32 {
        let hz = self.core.clock_hz as u64;
        let b = u64::from(self.baud.max(1));
        ((hz + b / 2) / b) as u32
    }

    /// The relative error of the board's bit time against the nominal one.
    pub fn baud_error(&self) -> f64 {
        let exact = self.core.clock_hz / f64::from(self.baud.max(1));
        (f64::from(self.div()) - exact).abs() / exact
    }

    /// `ms_board`'s parameters and their values.
    pub fn param_list(&self) -> Result<Vec<(&'static str, u32)>, HdlError> {
        let w = self.widths()?;
        let board = [
            ("CLK_HZ", self.core.clock_hz as u32),
            ("BAUD", self.baud),
            ("ESTOP_ACTIVE", u32::from(self.estop_active_high)),
            ("VERSION", u32::from(crate::link::crate_version())),
            ("LB", self.stream_buffer_bits),
            ("SYNC", u32::from(self.sync)),
        ];
        Ok(w.core_param_list(self.core.axes, w.lk)
            .into_iter()
            .chain(board)
            // CHAINS, LUTRAM and LIMITS only when not the default: a board without them
            // builds from the same text
            .chain(self.chains.then_some(("CHAINS", 1)))
            .chain(self.lutram.then_some(("LUTRAM", 1)))
            .chain((!self.limits).then_some(("LIMITS", 0)))
            .collect())
    }

    /// `#(.K(..), …)` for an `ms_board` instance.
    pub fn verilog_params(&self) -> Result<String, HdlError> {
        Ok(format!(
            "#({})",
            self.param_list()?
                .iter()
                .map(|(k, v)| format!(".{k}({v})"))
                .collect::<Vec<_>>()
                .join(", ")
        ))
    }

    /// Every Verilog file of the board (the core's library and the board's), checked first.
    pub fn files(&self) -> Result<Vec<(String, String)>, HdlError> {
        self.widths()?;
        let recur = self.core.recurrence.is_some();
        Ok(LIBRARY
            .iter()
            .chain(std::iter::once(&crate::RECURRENCE_UNIT).filter(|_| recur))
            .chain(BOARD_LIBRARY.iter())
            .chain(CHAIN_LIBRARY.iter().filter(|_| self.chains))
            .map(|(n, t)| (n.to_string(), t.to_string()))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filter_times_exact_below_512_clocks_and_under_one_percent_late_above() {
        assert!(include_str!("../rtl/board/ms_board.v")
            .contains(&format!("parameter WB       = {FILTER_BITS},")));
        assert_eq!(filter_latest(0), 1);
        assert_eq!(filter_latest(511), 511);
        // P = 2: 512 / 2 + 2 strobes
        assert_eq!(filter_latest(512), 516);
        assert_eq!(filter_latest(1800), 1808);
        for t in [512u64, 1000, 25_000, 100_000, (1 << 24) - 1] {
            let late = filter_latest(t) - t;
            assert!(late > 0 && late * 100 < t, "{t}: {late}");
        }
    }

    #[test]
    fn three_megabaud_at_the_default_clock() {
        let b = BoardTop::new(CoreParams::default(), 3_000_000);
        assert_eq!(b.div(), 17);
        assert!(b.baud_error() < 0.021);
        assert!(b.widths().is_ok());
        let slow = BoardTop::new(
            CoreParams {
                clock_hz: 10e6,
                max_rate: 100e3,
                ..Default::default()
            },
            3_000_000,
        );
        assert!(
            matches!(slow.widths(), Err(HdlError::Param(_))),
            "3 clocks per bit"
        );
        let off = BoardTop::new(CoreParams::default(), 3_030_303);
        assert!(
            off.baud_error() > MAX_BAUD_ERROR,
            "16.5 clocks per bit, 17 used: 3 %"
        );
    }
}
