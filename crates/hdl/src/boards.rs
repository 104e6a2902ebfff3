//! The boards `multistep hdl build` targets: device, oscillator, PLL, core clock, the core
//! widths that fit, and the pin layouts (constraint files in `crates/hdl/boards/`). One
//! table, [`BOARDS`].

use crate::{CoreParams, HdlError};
use serde::Serialize;

/// FPGA family: which synthesis command, place-and-router and packer a board uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Family {
    /// Lattice ECP5: `synth_ecp5`, nextpnr-ecp5, ecppack.
    Ecp5,
    /// Lattice iCE40: `synth_ice40 -dsp`, nextpnr-ice40, icepack.
    Ice40,
}

/// PLL dividers from the board oscillator to the core clock.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Pll {
    /// ECP5 EHXPLLL, feedback from CLKOP: f_out = f_in · CLKFB_DIV / CLKI_DIV, VCO =
    /// f_out · CLKOP_DIV (400–800 MHz). Dividers from `ecppll -i IN -o OUT`.
    Ehxplll {
        clki_div: u32,
        clkfb_div: u32,
        clkop_div: u32,
        clkop_cphase: u32,
    },
    /// iCE40 SB_PLL40_PAD, simple feedback: f_out = f_in · (DIVF + 1) / ((DIVR + 1) ·
    /// 2^DIVQ), PFD = f_in / (DIVR + 1) (10–133 MHz), VCO 533–1066 MHz. From `icepll`.
    Pll40Pad {
        divr: u32,
        divf: u32,
        divq: u32,
        filter_range: u32,
    },
}

impl Pll {
    /// The output frequency for an input of `f_in` Hz.
    pub fn output_hz(&self, f_in: f64) -> f64 {
        match *self {
            Pll::Ehxplll {
                clki_div,
                clkfb_div,
                ..
            } => f_in * f64::from(clkfb_div) / f64::from(clki_div),
            Pll::Pll40Pad {
                divr, divf, divq, ..
            } => f_in * f64::from(divf + 1) / (f64::from(divr + 1) * f64::from(1u32 << divq)),
        }
    }

    /// The VCO frequency for an input of `f_in` Hz.
    pub fn vco_hz(&self, f_in: f64) -> f64 {
        match *self {
            Pll::Ehxplll { clkop_div, .. } => self.output_hz(f_in) * f64::from(clkop_div),
            Pll::Pll40Pad { divq, .. } => self.output_hz(f_in) * f64::from(1u32 << divq),
        }
    }
}

/// Core widths for a board: what fits its device at its clock (see docs/HDL.md).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BoardCore {
    pub fifo_depth: u32,
    pub pieces: u32,
    pub step_bits: u32,
    pub tick_bits: u32,
    pub radicand_bits: u32,
    pub kernel_bits: u32,
    pub radix_bits: u32,
    /// Highest step rate the core is checked for (steps/s).
    pub max_rate: f64,
    /// Longest piece (s).
    pub max_piece_s: f64,
    /// The per-step recurrence's digit bits (`CoreParams::recurrence`); None: the closed
    /// form alone.
    pub recurrence: Option<u32>,
}

/// A board's pin layout: its constraint file and the axis wires it has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Pinout {
    /// Axes with STEP, DIR, ENABLE and Hall wires.
    pub axes: u32,
    /// Every axis also has a limit input (without, the limit inputs read inactive).
    pub limits: bool,
    /// The constraint file: its name and text (`crates/hdl/boards/`).
    #[serde(skip)]
    pub file: (&'static str, &'static str),
}

/// The ULX3S with up to 8 axes: a limit input per axis, E-STOP and SYNC on the headers.
const ULX3S_8: Pinout = Pinout {
    axes: 8,
    limits: true,
    file: ("ulx3s.lpf", include_str!("../boards/ulx3s.lpf")),
};

/// The ULX3S with 14 axes: all 56 header pins are axis wires; E-STOP and SYNC on the OLED
/// header, no limit inputs.
const ULX3S_14: Pinout = Pinout {
    axes: 14,
    limits: false,
    file: ("ulx3s-14.lpf", include_str!("../boards/ulx3s-14.lpf")),
};

/// The ULX3S core widths (the 85F's FIFOs are deeper).
const ULX3S_25F_CORE: BoardCore = BoardCore {
    fifo_depth: 16,
    pieces: 4,
    step_bits: 20,
    tick_bits: 24,
    radicand_bits: 128,
    kernel_bits: 68,
    radix_bits: 2,
    max_rate: 200_000.0,
    max_piece_s: 0.3,
    recurrence: None,
};

/// nextpnr's device options for the ULX3S's LFE5U-25F.
const ULX3S_25F_NEXTPNR: &[&str] = &["--25k", "--package", "CABGA381", "--speed", "6"];

/// One supported board.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Board {
    /// The name `--board` takes.
    pub name: &'static str,
    pub description: &'static str,
    pub family: Family,
    /// The FPGA's part number.
    pub device: &'static str,
    /// nextpnr's device, package and placer options.
    #[serde(skip)]
    pub nextpnr_args: &'static [&'static str],
    /// The board oscillator (Hz).
    pub osc_hz: f64,
    pub pll: Pll,
    /// Axes the pin layout has wires for (the most `--axes` takes).
    pub max_axes: u32,
    /// Axes of `hdl build` when `--axes` is not given: the most that fit and meet timing.
    pub default_axes: u32,
    /// Host link rate (baud, 8N1) through the board's USB-UART.
    pub baud: u32,
    pub core: BoardCore,
    /// The pin layout (its `axes` is `max_axes`).
    pub pinout: Pinout,
    /// The generated wrapper's top module.
    pub top: &'static str,
    /// Each axis's stream buffer: 2^bits bytes (0: no replay units, no streamed moves).
    #[serde(skip)]
    pub stream_buffer_bits: u32,
    /// The SYNC line's logic (`Arm`, `Fire`, `SyncTick`; docs/HDL.md, "Cross-board start").
    pub sync: bool,
    /// A forward-difference chain unit per axis: scurve and scurve4 computed on the board
    /// (docs/HDL.md, "Computed polynomial pieces").
    pub chains: bool,
}

/// Every supported board.
pub const BOARDS: [Board; 4] = [
    Board {
        name: "ulx3s-25f",
        description: "Radiona ULX3S with an LFE5U-25F, 25 MHz oscillator, FT231X USB-UART",
        family: Family::Ecp5,
        device: "LFE5U-25F-6BG381C",
        nextpnr_args: ULX3S_25F_NEXTPNR,
        osc_hz: 25e6,
        // ecppll -i 25 -o 50: VCO 600 MHz
        pll: Pll::Ehxplll {
            clki_div: 1,
            clkfb_div: 2,
            clkop_div: 12,
            clkop_cphase: 5,
        },
        max_axes: 8,
        default_axes: 8,
        baud: 3_000_000,
        // the closed form feeds its 8 axes at 100 k steps/s; `--recurrence 13` builds it
        // with the per-step recurrence (32 axes' worth, 53.44 MHz routed, 52 % of the
        // LUTs against 62.88 MHz and 40 %: docs/HDL.md, Boards)
        core: ULX3S_25F_CORE,
        pinout: ULX3S_8,
        top: "ms_ulx3s_top",
        stream_buffer_bits: 9,
        sync: true,
        chains: false,
    },
    Board {
        name: "ulx3s-25f-14",
        description: "Radiona ULX3S with an LFE5U-25F: every header pin an axis wire, 14 axes \
                      at 50 MHz, no limit inputs",
        family: Family::Ecp5,
        device: "LFE5U-25F-6BG381C",
        nextpnr_args: ULX3S_25F_NEXTPNR,
        osc_hz: 25e6,
        // ecppll -i 25 -o 50: VCO 600 MHz. 14 axes with the per-step recurrence (the
        // closed form alone feeds 10 at 100 k steps/s) and the shared replay decoder take
        // 67 % of the 25F's LUTs and route at 54.46 MHz (docs/HDL.md, Boards)
        pll: Pll::Ehxplll {
            clki_div: 1,
            clkfb_div: 2,
            clkop_div: 12,
            clkop_cphase: 5,
        },
        max_axes: 14,
        default_axes: 14,
        baud: 3_000_000,
        core: BoardCore {
            recurrence: Some(13),
            ..ULX3S_25F_CORE
        },
        pinout: ULX3S_14,
        top: "ms_ulx3s_top",
        stream_buffer_bits: 9,
        sync: true,
        chains: false,
    },
    Board {
        name: "ulx3s-85f",
        description: "Radiona ULX3S with an LFE5U-85F, 25 MHz oscillator, FT231X USB-UART: \
                      scurve and scurve4 computed per axis",
        family: Family::Ecp5,
        device: "LFE5U-85F-6BG381C",
        nextpnr_args: &["--85k", "--package", "CABGA381", "--speed", "6"],
        osc_hz: 25e6,
        // ecppll -i 25 -o 30: VCO 600 MHz. 30 MHz, not the 25F's 50: the routed 8-axis
        // build misses 50 (docs/HDL.md, Boards), and 30 MHz makes the 3 Mbaud link's bit
        // exactly 10 clocks (33.33 MHz is no whole number of hertz; 35 and 40 MHz miss
        // the baud by 2.6–2.8 %)
        pll: Pll::Ehxplll {
            clki_div: 5,
            clkfb_div: 6,
            clkop_div: 20,
            clkop_cphase: 9,
        },
        max_axes: 8,
        default_axes: 8,
        baud: 3_000_000,
        core: BoardCore {
            // a chain walks a tick a clock, so its lead over the pulse unit is what the
            // FIFO holds: 128 short cruise periods cover an s-curve's long last periods
            // (`multistep_core::tdm::chain`; 16 do not)
            fifo_depth: 128,
            ..ULX3S_25F_CORE
        },
        // the same board and pins as the 25F (its 8 chain units fill the 85F)
        pinout: ULX3S_8,
        top: "ms_ulx3s_top",
        // 4 kB: a whole move's chain records (219 bytes each) before it starts
        stream_buffer_bits: 12,
        sync: true,
        chains: true,
    },
    Board {
        name: "icebreaker",
        description:
            "1BitSquared iCEBreaker with an iCE40UP5K, 12 MHz oscillator, FT2232H USB-UART",
        family: Family::Ice40,
        device: "iCE40UP5K-SG48",
        nextpnr_args: &["--up5k", "--package", "sg48"],
        osc_hz: 12e6,
        // icepll -i 12 -o 18 (24 MHz misses timing: 21.08 MHz routed at K = 1)
        pll: Pll::Pll40Pad {
            divr: 0,
            divf: 47,
            divq: 5,
            filter_range: 1,
        },
        max_axes: 4,
        // four axes: 95 % of the logic cells with SYNC and no limit filters, the axes'
        // state in block RAM (docs/HDL.md); the calculator gives three 100 k steps/s
        default_axes: 4,
        baud: 1_000_000,
        core: BoardCore {
            fifo_depth: 2,
            // the piece memory is block RAM, as wide as it is for 4 slots: 16 hold a move
            // whose phases split into many 58-ms pieces at 20 tick bits
            pieces: 16,
            step_bits: 14,
            tick_bits: 20,
            radicand_bits: 48,
            kernel_bits: 26,
            radix_bits: 1,
            max_rate: 100_000.0,
            max_piece_s: 0.04,
            recurrence: None,
        },
        pinout: Pinout {
            axes: 4,
            limits: false,
            file: ("icebreaker.pcf", include_str!("../boards/icebreaker.pcf")),
        },
        top: "ms_icebreaker_top",
        // the UP5K is full with four computing axes
        stream_buffer_bits: 0,
        sync: true,
        chains: false,
    },
];

impl Board {
    /// The board top level of this board with `params`.
    pub fn board_top(&self, params: &crate::CoreParams) -> crate::BoardTop {
        crate::BoardTop {
            stream_buffer_bits: self.stream_buffer_bits,
            sync: self.sync,
            chains: self.chains,
            lutram: self.family == Family::Ecp5,
            limits: self.pinout.limits,
            ..crate::BoardTop::new(params.clone(), self.baud)
        }
    }

    /// The board named `name`, or a parameter error listing the boards.
    pub fn by_name(name: &str) -> Result<&'static Board, HdlError> {
        BOARDS.iter().find(|b| b.name == name).ok_or_else(|| {
            let names: Vec<&str> = BOARDS.iter().map(|b| b.name).collect();
            HdlError::UnknownBoard {
                name: name.to_string(),
                known: names.join(", "),
            }
        })
    }

    /// The core clock: the PLL's output (Hz).
    pub fn clock_hz(&self) -> f64 {
        self.pll.output_hz(self.osc_hz)
    }

    /// The core parameters of this board with `axes` axes, checked against its pinout.
    pub fn params(&self, axes: u32) -> Result<CoreParams, HdlError> {
        if axes == 0 || axes > self.max_axes {
            return Err(HdlError::Param(format!(
                "{} has wires for 1..={} axes, got {axes}",
                self.name, self.max_axes
            )));
        }
        let c = self.core;
        let p = CoreParams {
            axes,
            fifo_depth: c.fifo_depth,
            pieces: c.pieces,
            step_bits: c.step_bits,
            tick_bits: c.tick_bits,
            radicand_bits: c.radicand_bits,
            kernel_bits: c.kernel_bits,
            radix_bits: c.radix_bits,
            clock_hz: self.clock_hz(),
            max_rate: c.max_rate,
            max_piece_s: c.max_piece_s,
            recurrence: c.recurrence,
        };
        p.widths()?;
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_board_has_valid_params_and_a_pll_in_range() {
        for b in &BOARDS {
            for k in 1..=b.max_axes {
                b.params(k)
                    .unwrap_or_else(|e| panic!("{} K = {k}: {e}", b.name));
            }
            assert!(b.default_axes >= 1 && b.default_axes <= b.max_axes);
            assert_eq!(b.pinout.axes, b.max_axes);
            let vco = b.pll.vco_hz(b.osc_hz);
            match b.pll {
                Pll::Ehxplll { .. } => assert!((400e6..=800e6).contains(&vco), "{vco}"),
                Pll::Pll40Pad { divr, .. } => {
                    assert!((533e6..=1066e6).contains(&vco), "{vco}");
                    let pfd = b.osc_hz / f64::from(divr + 1);
                    assert!((10e6..=133e6).contains(&pfd), "{pfd}");
                }
            }
        }
    }

    #[test]
    fn plls_give_the_documented_clocks() {
        let ulx3s = Board::by_name("ulx3s-25f").unwrap();
        assert_eq!(ulx3s.clock_hz(), 50e6);
        let ulx3s85 = Board::by_name("ulx3s-85f").unwrap();
        assert_eq!(ulx3s85.clock_hz(), 30e6);
        // a bit of the 3 Mbaud link is exactly 10 clocks
        let top = ulx3s85.board_top(&ulx3s85.params(8).unwrap());
        assert_eq!((top.div(), top.baud_error()), (10, 0.0));
        let ice = Board::by_name("icebreaker").unwrap();
        assert_eq!(ice.clock_hz(), 18e6);
        // 14 axes at the 25F's 50 MHz, its link's bit as long as the 8-axis board's
        let dense = Board::by_name("ulx3s-25f-14").unwrap();
        let top = dense.board_top(&dense.params(14).unwrap());
        let eight = ulx3s.board_top(&ulx3s.params(8).unwrap());
        assert_eq!(dense.clock_hz(), 50e6);
        assert_eq!(
            (top.div(), top.baud_error()),
            (eight.div(), eight.baud_error())
        );
        assert!(!top.limits && top.lutram);
    }

    /// docs/HDL.md's 14-axis ULX3S table (after its `<!-- wiring: ulx3s-14.lpf -->` mark)
    /// names each axis wire's header pin and ball as the pin file places it.
    #[test]
    fn the_documented_fourteen_axis_wiring_is_the_pin_file() {
        let doc = include_str!("../../../docs/HDL.md");
        let (_, table) = doc
            .split_once("<!-- wiring: ulx3s-14.lpf -->")
            .expect("the wiring mark");
        let rows: Vec<&str> = table
            .lines()
            .skip_while(|l| l.trim().is_empty())
            .take_while(|l| l.starts_with('|'))
            .skip(2)
            .collect();
        assert_eq!(rows.len(), ULX3S_14.axes as usize);
        let lpf = ULX3S_14.file.1;
        for (a, row) in rows.iter().enumerate() {
            let cells: Vec<&str> = row.split('|').map(str::trim).collect();
            assert_eq!(cells[1], a.to_string(), "{row}");
            for (wire, cell) in ["step", "dir", "enable", "hall"].iter().zip(&cells[2..6]) {
                // "GP14 (U18)" is `LOCATE COMP "enable[0]" SITE "U18"; # gp[14]`
                let (pin, ball) = cell.split_once(" (").unwrap();
                let ball = ball.trim_end_matches(')');
                let n = &pin[2..];
                let line = format!(
                    "LOCATE COMP \"{wire}[{a}]\" SITE \"{ball}\"; # {}[{n}]",
                    pin[..2].to_lowercase()
                );
                assert!(lpf.contains(&line), "{row}: no `{line}` in ulx3s-14.lpf");
            }
        }
    }

    #[test]
    fn unknown_board_and_too_many_axes_are_errors() {
        assert!(
            matches!(Board::by_name("nope"), Err(HdlError::UnknownBoard { known, .. }) if known.contains("icebreaker"))
        );
        let b = Board::by_name("icebreaker").unwrap();
        assert!(b.params(b.max_axes + 1).is_err());
        assert!(b.params(0).is_err());
    }
}
