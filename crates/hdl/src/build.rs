//! `multistep hdl build`: a board's bitstream. Emits the core library, the board top level
//! (`ms_board`) and a per-board wrapper (the PLL from the oscillator to the core clock, the
//! reset, the board's pin names), then synthesizes, places, routes and packs it with the
//! YoWASP flow ([`crate::pnr`]) and reports what it uses and how fast it runs.

use crate::boards::{Board, Family, Pll};
use crate::pnr::{place_and_route, Flow, Nextpnr, Placed};
use crate::{CoreParams, HdlError};
use multistep_core::int::recurrence::RecurrenceClocks;
use multistep_core::int::{IntClock, IntPhaseMove, IntProfile};
use multistep_core::tdm::{k_max, rate_move, Axis, Board as TdmBoard, TdmConfig};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The report of one build (`--format json` prints exactly this).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BuildReport {
    pub board: String,
    pub device: String,
    pub axes: u32,
    pub clock_hz: f64,
    pub fmax_mhz: f64,
    pub timing_met: bool,
    /// Logic sites used: ECP5 TRELLIS_COMB, iCE40 ICESTORM_LC.
    pub lut: u64,
    pub ff: u64,
    pub dsp: u64,
    pub bram: u64,
    /// Device totals of the same four, for the percentages.
    pub lut_available: u64,
    pub dsp_available: u64,
    pub bram_available: u64,
    pub bitstream: PathBuf,
    /// How many axes one calculator serves at 100 k steps/s each at this clock (the core
    /// TDM model's `k_max` with the RTL's latencies and FIFO depth).
    pub axes_at_100k_steps_per_s: usize,
}

/// Axes the core TDM model runs at `rate` steps/s each with no underrun, for the RTL of
/// `params` (its latencies, FIFO depth, clock): seed 000 eq. (12) checked by simulation.
pub fn axes_at_rate(params: &CoreParams, rate: f64) -> Result<usize, HdlError> {
    let w = params.widths()?;
    let cfg = TdmConfig {
        clock_hz: params.clock_hz,
        fifo_depth: params.fifo_depth as usize,
        latencies: w.latencies(),
        ..Default::default()
    };
    let tdm = |e: multistep_core::tdm::TdmError| HdlError::Move(e.to_string());
    if let Some(clocks) = w.recurrence_clocks() {
        return axes_by_recurrence(params, cfg, clocks, rate);
    }
    // seed 000's shape: 2 ms accel, 6 ms cruise at `rate`, 2 ms decel
    let m = rate_move(rate, 0.002, 0.006, 0.002).map_err(tdm)?;
    let mut storage = (0..multistep_core::tdm::MAX_AXES.min(32))
        .map(|_| Axis::new(m.clone(), params.clock_hz))
        .collect::<Result<Vec<_>, _>>()
        .map_err(tdm)?;
    Ok(k_max(&cfg, &[m], &mut storage).map_err(tdm)?.k_max)
}

/// [`axes_at_rate`] for a core with the per-step recurrence: the most axes (up to 32) on
/// the same move, planned in integers, each period at the recurrence's clocks, with no
/// underrun.
fn axes_by_recurrence(
    params: &CoreParams,
    cfg: TdmConfig,
    clocks: RecurrenceClocks,
    rate: f64,
) -> Result<usize, HdlError> {
    let hz = params.clock_hz as u64;
    let ticks = |s: f64| (s * params.clock_hz).round() as u64;
    let m = IntPhaseMove {
        steps: (rate * 0.008).round().max(1.0) as u64,
        accel_ticks: ticks(0.002),
        cruise_ticks: ticks(0.006),
        decel_ticks: ticks(0.002),
        start_speed: 0,
        end_speed: 0,
    };
    let bad = |e: String| HdlError::Move(e);
    let profile =
        IntProfile::<3>::phase_in(&m, IntClock::hz(hz)).map_err(|e| bad(e.to_string()))?;
    let fed = |k: usize| -> Result<bool, HdlError> {
        let mut axes = (0..k)
            .map(|_| Axis::recurrent(profile.clone(), hz, clocks))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| bad(e.to_string()))?;
        let board = TdmBoard::new(cfg, &mut axes).map_err(|e| bad(e.to_string()))?;
        Ok(board.run(|_| {}).underruns == 0)
    };
    // more axes on one calculator never feed better: a binary search for the last fed
    let (mut most, mut over) = (0, 33);
    while over - most > 1 {
        let k = (most + over) / 2;
        if fed(k)? {
            most = k;
        } else {
            over = k;
        }
    }
    Ok(most)
}

/// `{zeros, sig}` padding a K-bit bus to the board's `max` wires (unused outputs low).
fn pad(sig: &str, axes: u32, max: u32) -> String {
    if axes == max {
        sig.to_string()
    } else {
        format!("{{{}'b0, {sig}}}", max - axes)
    }
}

/// The PLL instance: `clk` (the core clock) and `locked` from the board oscillator `osc`.
fn pll(b: &Board, osc: &str) -> String {
    let mhz = |hz: f64| format!("{}", hz / 1e6);
    match b.pll {
        Pll::Ehxplll {
            clki_div,
            clkfb_div,
            clkop_div,
            clkop_cphase,
        } => format!(
            "    // EHXPLLL: {in_} MHz x {clkfb_div} / {clki_div} = {out} MHz, VCO {vco} MHz \
             (ecppll -i {in_} -o {out})\n\
             \x20   (* FREQUENCY_PIN_CLKI=\"{in_}\" *) (* FREQUENCY_PIN_CLKOP=\"{out}\" *)\n\
             \x20   (* ICP_CURRENT=\"12\" *) (* LPF_RESISTOR=\"8\" *) (* MFG_ENABLE_FILTEROPAMP=\"1\" *) \
             (* MFG_GMCREF_SEL=\"2\" *)\n\
             \x20   EHXPLLL #(.PLLRST_ENA(\"DISABLED\"), .INTFB_WAKE(\"DISABLED\"), \
             .STDBY_ENABLE(\"DISABLED\"), .DPHASE_SOURCE(\"DISABLED\"),\n\
             \x20       .OUTDIVIDER_MUXA(\"DIVA\"), .OUTDIVIDER_MUXB(\"DIVB\"), \
             .OUTDIVIDER_MUXC(\"DIVC\"), .OUTDIVIDER_MUXD(\"DIVD\"),\n\
             \x20       .CLKI_DIV({clki_div}), .CLKOP_ENABLE(\"ENABLED\"), .CLKOP_DIV({clkop_div}), \
             .CLKOP_CPHASE({clkop_cphase}), .CLKOP_FPHASE(0),\n\
             \x20       .FEEDBK_PATH(\"CLKOP\"), .CLKFB_DIV({clkfb_div})\n\
             \x20   ) u_pll (.RST(1'b0), .STDBY(1'b0), .CLKI({osc}), .CLKOP(clk), .CLKFB(clk), \
             .CLKINTFB(),\n\
             \x20       .PHASESEL0(1'b0), .PHASESEL1(1'b0), .PHASEDIR(1'b1), .PHASESTEP(1'b1), \
             .PHASELOADREG(1'b1),\n\
             \x20       .PLLWAKESYNC(1'b0), .ENCLKOP(1'b0), .LOCK(locked));\n",
            in_ = mhz(b.osc_hz),
            out = mhz(b.clock_hz()),
            vco = mhz(b.pll.vco_hz(b.osc_hz)),
        ),
        Pll::Pll40Pad {
            divr,
            divf,
            divq,
            filter_range,
        } => format!(
            "    // SB_PLL40_PAD: {in_} MHz x {} / ({} x 2^{divq}) = {out} MHz, VCO {vco} MHz \
             (icepll -i {in_} -o {out})\n\
             \x20   SB_PLL40_PAD #(.FEEDBACK_PATH(\"SIMPLE\"), .DIVR(4'd{divr}), .DIVF(7'd{divf}), \
             .DIVQ(3'd{divq}), .FILTER_RANGE(3'd{filter_range}))\n\
             \x20       u_pll (.PACKAGEPIN({osc}), .PLLOUTGLOBAL(clk), .LOCK(locked), \
             .RESETB(1'b1), .BYPASS(1'b0));\n",
            divf + 1,
            divr + 1,
            in_ = mhz(b.osc_hz),
            out = mhz(b.clock_hz()),
            vco = mhz(b.pll.vco_hz(b.osc_hz)),
        ),
    }
}

/// The board wrapper: the board's pins (as named in its constraint file), the PLL, the
/// reset (button or PLL not locked), and `ms_board` on the first `axes` axis wires.
pub fn wrapper(b: &Board, params: &CoreParams) -> Result<String, HdlError> {
    let top = b.board_top(params);
    let board_params = top.verilog_params()?;
    let pins = b.pinout;
    let (k, max) = (params.axes, pins.axes);
    let m1 = max - 1;
    let (osc, reset, leds) = match b.family {
        Family::Ecp5 => (
            "clk_25mhz",
            "    input  wire         btn_reset,      // pressed = high\n",
            "    output wire [3:0]   led,\n",
        ),
        Family::Ice40 => (
            "clk_12mhz",
            "    input  wire         btn_n,          // pressed = low\n",
            "    output wire         led_red_n,\n    output wire         led_green_n,\n",
        ),
    };
    let limit_port = if pins.limits {
        format!("    input  wire [{m1}:0]   limit,\n")
    } else {
        String::new()
    };
    let mut s = format!(
        "// Generated by multistep-hdl {}: the {} board wrapper ({}), K = {k} of {max} axis wires.\n\
         module {} (\n\
         \x20   input  wire         {osc},\n\
         \x20   input  wire         uart_rx,\n\
         \x20   output wire         uart_tx,\n\
         {reset}{leds}\
         \x20   input  wire         estop,\n\
         \x20   input  wire [{m1}:0]   hall,\n\
         {limit_port}\
         \x20   output wire [{m1}:0]   step,\n\
         \x20   output wire [{m1}:0]   dir,\n\
         \x20   output wire [{m1}:0]   enable,\n\
         \x20   // open drain, pulled up: the cross-board start (docs/HDL.md, \"Cross-board start\")\n\
         \x20   inout  wire         sync\n\
         );\n\
         \x20   wire clk, locked;\n",
        env!("CARGO_PKG_VERSION"),
        b.name,
        b.device,
        b.top,
    );
    s.push_str(&pll(b, osc));
    let rst_n = match b.family {
        Family::Ecp5 => "locked & ~btn_reset",
        Family::Ice40 => "locked & btn_n",
    };
    let k1 = k - 1;
    let _ = write!(
        s,
        "    wire [{k1}:0] step_k, dir_k, enable_k;\n\
         \x20   wire [3:0] led_k;\n\
         \x20   wire sync_oe;\n\
         \x20   /* verilator lint_off UNUSED */\n\
         \x20   wire [{m1}:0] hall_w = hall, limit_w = {limit_w};\n\
         \x20   /* verilator lint_on UNUSED */\n\
         \x20   ms_board {board_params} u_board (\n\
         \x20       .clk(clk), .rst_n_async({rst_n}), .uart_rx(uart_rx), .uart_tx(uart_tx),\n\
         \x20       .estop_in(estop), .hall_in(hall_w[{k1}:0]), .limit_in(limit_w[{k1}:0]),\n\
         \x20       .step_out(step_k), .dir_out(dir_k), .enable_out(enable_k), .led(led_k),\n\
         \x20       .sync_in(sync), .sync_oe(sync_oe));\n\
         \x20   assign sync   = sync_oe ? 1'b0 : 1'bz;\n\
         \x20   assign step   = {};\n\
         \x20   assign dir    = {};\n\
         \x20   assign enable = {};\n",
        pad("step_k", k, max),
        pad("dir_k", k, max),
        pad("enable_k", k, max),
        // a layout without limit inputs: they read inactive
        limit_w = if pins.limits {
            "limit".to_string()
        } else {
            format!("{max}'d0")
        },
    );
    match b.family {
        Family::Ecp5 => s.push_str("    assign led = led_k;\n"),
        Family::Ice40 => s.push_str(
            "    // two LEDs, active low: led[0] red, led[1] green\n\
             \x20   assign led_red_n   = ~led_k[0];\n\
             \x20   assign led_green_n = ~led_k[1];\n",
        ),
    }
    s.push_str("endmodule\n");
    Ok(s)
}

/// The Verilog of a board build: the core library, the board top and the wrapper.
pub fn sources(b: &Board, params: &CoreParams) -> Result<Vec<(String, String)>, HdlError> {
    let mut files = b.board_top(params).files()?;
    files.push((format!("{}.v", b.top), wrapper(b, params)?));
    Ok(files)
}

/// Emits, synthesizes, places, routes and packs `axes` axes for board `b` in `out`; the
/// report is also written to `out/report.json`. A design that does not fit or misses the
/// core clock is an error (after the report is written, for the timing case).
pub fn build(b: &Board, axes: u32, out: &Path) -> Result<BuildReport, HdlError> {
    build_with(b, axes, out, Nextpnr::YoWasp)
}

/// [`build`] with the given nextpnr.
pub fn build_with(
    b: &Board,
    axes: u32,
    out: &Path,
    nextpnr: Nextpnr,
) -> Result<BuildReport, HdlError> {
    nextpnr.check()?;
    let params = b.params(axes)?;
    let files = sources(b, &params)?;
    let rtl = out.join("rtl");
    std::fs::create_dir_all(&rtl).map_err(|e| HdlError::io(&rtl, e))?;
    for (name, text) in &files {
        let path = rtl.join(name);
        std::fs::write(&path, text).map_err(|e| HdlError::io(&path, e))?;
    }
    let (cname, ctext) = b.pinout.file;
    let cpath = out.join(cname);
    std::fs::write(&cpath, ctext).map_err(|e| HdlError::io(&cpath, e))?;
    let flow = Flow {
        family: b.family,
        nextpnr_args: b.nextpnr_args,
        top: b.top,
        sources: files.iter().map(|(n, _)| format!("rtl/{n}")).collect(),
        constraints: Some(cname.to_string()),
        clock_hz: params.clock_hz,
        pack: true,
        nextpnr,
    };
    let placed = place_and_route(&flow, out)?;
    let report = report_of(b, &params, &placed)?;
    let path = out.join("report.json");
    let text = serde_json::to_string_pretty(&report).map_err(|e| HdlError::Sim(e.to_string()))?;
    std::fs::write(&path, text + "\n").map_err(|e| HdlError::io(&path, e))?;
    if !report.timing_met {
        return Err(HdlError::TimingMissed {
            fmax_mhz: placed.fmax_mhz,
            clock_mhz: placed.constraint_mhz,
        });
    }
    Ok(report)
}

fn report_of(b: &Board, params: &CoreParams, p: &Placed) -> Result<BuildReport, HdlError> {
    Ok(BuildReport {
        board: b.name.to_string(),
        device: b.device.to_string(),
        axes: params.axes,
        clock_hz: params.clock_hz,
        fmax_mhz: (p.fmax_mhz * 100.0).round() / 100.0,
        timing_met: p.timing_met(),
        lut: p.lut.used,
        ff: p.ff,
        dsp: p.dsp.used,
        bram: p.bram.used,
        lut_available: p.lut.available,
        dsp_available: p.dsp.available,
        bram_available: p.bram.available,
        bitstream: p.bitstream.clone().unwrap_or_default(),
        axes_at_100k_steps_per_s: axes_at_rate(params, 100_000.0)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boards::BOARDS;

    #[test]
    fn wrappers_name_every_constrained_pin() {
        for b in &BOARDS {
            let pins = b.pinout;
            let p = b.params(b.max_axes.min(2)).unwrap();
            let v = wrapper(b, &p).unwrap();
            assert!(v.contains(&format!("module {} (", b.top)), "{v}");
            assert!(
                v.contains(&format!(".K({})", p.axes))
                    && v.contains(".CLK_HZ(")
                    && v.contains(".BAUD("),
                "{v}"
            );
            assert_eq!(v.contains(" limit,"), pins.limits, "{v}");
            // every port of the constraint file is a port of the wrapper, and every axis
            // wire of the wrapper is in the constraint file
            let text = pins.file.1;
            for a in 0..pins.axes {
                for wire in ["step", "dir", "enable", "hall"]
                    .into_iter()
                    .chain(pins.limits.then_some("limit"))
                {
                    assert!(
                        text.contains(&format!("{wire}[{a}]\""))
                            || text.contains(&format!("{wire}[{a}] ")),
                        "{}: {wire}[{a}] has no pin in {}",
                        b.name,
                        pins.file.0
                    );
                }
            }
            for line in text.lines() {
                let port = if let Some(r) = line.strip_prefix("set_io ") {
                    r.split_whitespace()
                        .rfind(|t| !t.starts_with('-') && t.parse::<u32>().is_err() && *t != "yes")
                } else if let Some(r) = line.strip_prefix("LOCATE COMP \"") {
                    r.split('"').next()
                } else {
                    None
                };
                if let Some(port) = port {
                    let base = port.split('[').next().unwrap();
                    assert!(
                        v.contains(&format!(" {base},")) || v.contains(&format!(" {base}\n")),
                        "{}: {port} not in the wrapper",
                        b.name
                    );
                }
            }
        }
    }

    #[test]
    fn one_calculator_serves_the_documented_axes_at_100k() {
        let ulx3s = Board::by_name("ulx3s-25f").unwrap();
        let mut p = ulx3s.params(8).unwrap();
        // the closed form alone: 10; with the recurrence every axis the core holds
        p.recurrence = None;
        assert_eq!(axes_at_rate(&p, 100e3).unwrap(), 10);
        p.recurrence = Some(13);
        assert_eq!(axes_at_rate(&p, 100e3).unwrap(), 32);
        // the 85F's 128-period FIFOs are within the model's range
        let ulx3s85 = Board::by_name("ulx3s-85f").unwrap();
        let p = ulx3s85.params(8).unwrap();
        assert_eq!(p.fifo_depth, 128);
        // at its 30 MHz the one calculator serves 7 trapezoid axes at 100 k steps/s (the
        // documented figure); scurve and scurve4 run on a chain unit per axis, all 8
        assert_eq!(p.clock_hz, 30e6);
        assert_eq!(axes_at_rate(&p, 100e3).unwrap(), 7);
    }
}

#[cfg(test)]
mod move_fit {
    use crate::boards::BOARDS;
    use crate::AxisMove;
    use multistep_core::int::{IntClock, IntPhaseMove, IntProfile};

    /// Trapezoids (whole-millisecond phases, up to the board's longest piece) fit every
    /// board's widths: the narrower iCE40 radicand and kernels still take them.
    #[test]
    fn trapezoids_fit_every_board() {
        for b in &BOARDS {
            let p = b.params(b.max_axes).unwrap();
            let hz = p.clock_hz as u64;
            let ms = |t: f64| (t * hz as f64 / 1000.0) as u64;
            for (steps, a, c, d) in [
                (800, 2.0, 6.0, 2.0),
                (4000, 10.0, 35.0, 10.0),
                (100, 5.0, 10.0, 5.0),
                (2000, 20.0, 30.0, 20.0),
                (50, 10.0, 0.0, 10.0),
                (1, 1.0, 0.0, 1.0),
            ] {
                let m = IntPhaseMove {
                    steps,
                    accel_ticks: ms(a),
                    cruise_ticks: ms(c),
                    decel_ticks: ms(d),
                    start_speed: 0,
                    end_speed: 0,
                };
                let prof = IntProfile::phase(&m, IntClock::hz(hz)).unwrap();
                AxisMove::from_profile(&prof, false, &p)
                    .unwrap_or_else(|e| panic!("{}: {m:?}: {e}", b.name));
            }
        }
    }
}
