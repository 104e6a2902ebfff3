//! Resource use from yosys: synthesize the TDM core and the K independent cores for one
//! FPGA family and count LUTs, flip-flops, DSP blocks and memories from `stat -json`.

use crate::tools::{file_names_of, run};
use crate::{Arch, CoreParams, Design, HdlError};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Seed 000 table 1 (two axes, vendor tools): TDM / independent.
pub const PAPER_LUT_RATIO: f64 = 4153.0 / 6262.0;
/// Seed 000 table 1: flip-flops.
pub const PAPER_FF_RATIO: f64 = 2139.0 / 2999.0;
/// Seed 000 table 1: DSP blocks.
pub const PAPER_DSP_RATIO: f64 = 5.0 / 6.0;

/// FPGA family for yosys.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Target {
    /// Xilinx 7-series (`synth_xilinx`): LUT1-6 and INV, FD*, DSP48E1, LUTRAM/SRL, RAMB18/36.
    Xilinx,
    /// Lattice iCE40 UltraPlus (`synth_ice40 -dsp`): SB_LUT4, SB_DFF*, SB_MAC16, SB_RAM40_4K.
    Ice40,
    /// Lattice ECP5 (`synth_ecp5`): LUT4 (+2 per CCU2C carry), TRELLIS_FF, MULT18X18D,
    /// TRELLIS_DPR16X4, DP16KD.
    Ecp5,
}

impl Target {
    fn synth(self, top: &str) -> String {
        match self {
            Target::Xilinx => format!("synth_xilinx -flatten -top {top}"),
            Target::Ice40 => format!("synth_ice40 -dsp -top {top}"),
            Target::Ecp5 => format!("synth_ecp5 -top {top}"),
        }
    }

    /// The synthesis command that keeps the module hierarchy (for per-module counts).
    pub(crate) fn synth_hierarchy(self, top: &str) -> String {
        match self {
            Target::Xilinx => format!("synth_xilinx -top {top}"),
            Target::Ice40 => format!("synth_ice40 -dsp -noflatten -top {top}"),
            // without wide LUTs: given one module at a time, ABC maps much of it into wide
            // LUTs (two LUT4s and a PFUMX), and the modules summed to a third more than the
            // placed board (docs/HDL.md, "Per module")
            Target::Ecp5 => format!("synth_ecp5 -nowidelut -noflatten -top {top}"),
        }
    }

    /// The design as a board of this family builds it ([`Design::for_family`]).
    fn design(self, params: &CoreParams, arch: Arch) -> Result<Design, HdlError> {
        match self {
            Target::Ecp5 => Design::for_family(params, arch, crate::boards::Family::Ecp5),
            _ => Design::new(params, arch),
        }
    }

    /// Adds one cell type's count to `r`.
    fn classify(self, cell: &str, n: u64, r: &mut Resources) {
        let is = |p: &[&str]| p.iter().any(|x| cell.starts_with(x));
        match self {
            Target::Xilinx => {
                // INV cells occupy LUT1s on the device
                if is(&["LUT", "INV"]) {
                    r.lut += n
                } else if is(&["FD"]) {
                    r.ff += n
                } else if is(&["DSP48"]) {
                    r.dsp += n
                } else if is(&["RAMB"]) {
                    r.bram += n
                } else if is(&["RAM", "SRL"]) {
                    r.lutram += n
                }
            }
            Target::Ice40 => {
                if cell == "SB_LUT4" {
                    r.lut += n
                } else if is(&["SB_DFF"]) {
                    r.ff += n
                } else if cell == "SB_MAC16" {
                    r.dsp += n
                } else if is(&["SB_RAM"]) {
                    r.bram += n
                }
            }
            Target::Ecp5 => {
                if cell == "LUT4" {
                    r.lut += n
                } else if cell == "CCU2C" {
                    r.lut += 2 * n
                } else if cell == "TRELLIS_FF" {
                    r.ff += n
                } else if is(&["MULT18", "ALU54"]) {
                    r.dsp += n
                } else if cell == "TRELLIS_DPR16X4" {
                    r.lutram += n
                } else if cell == "DP16KD" {
                    r.bram += n
                }
            }
        }
    }
}

/// Counted cells of one synthesized design.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Resources {
    pub lut: u64,
    pub ff: u64,
    pub dsp: u64,
    /// Distributed RAM / shift-register LUT cells (FIFOs, per-axis state).
    pub lutram: u64,
    /// Block RAMs.
    pub bram: u64,
}

impl Resources {
    /// K copies.
    pub fn times(self, k: u64) -> Resources {
        Resources {
            lut: self.lut * k,
            ff: self.ff * k,
            dsp: self.dsp * k,
            lutram: self.lutram * k,
            bram: self.bram * k,
        }
    }

    /// The sum of two counts.
    pub fn plus(self, o: Resources) -> Resources {
        Resources {
            lut: self.lut + o.lut,
            ff: self.ff + o.ff,
            dsp: self.dsp + o.dsp,
            lutram: self.lutram + o.lutram,
            bram: self.bram + o.bram,
        }
    }

    /// Each count divided by `n` (rounded to nearest; `n` = 0 gives zeros).
    pub fn per(self, n: u64) -> Resources {
        let d = |x: u64| (x + n / 2).checked_div(n).unwrap_or(0);
        Resources {
            lut: d(self.lut),
            ff: d(self.ff),
            dsp: d(self.dsp),
            lutram: d(self.lutram),
            bram: d(self.bram),
        }
    }
}

/// One row of the sweep: the TDM core and K independent cores for K axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Row {
    pub axes: u32,
    pub tdm: Resources,
    pub independent: Resources,
}

/// a / b, or NaN when b is 0.
pub fn ratio(a: u64, b: u64) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        a as f64 / b as f64
    }
}

impl Row {
    pub fn lut_ratio(&self) -> f64 {
        ratio(self.tdm.lut, self.independent.lut)
    }
    pub fn ff_ratio(&self) -> f64 {
        ratio(self.tdm.ff, self.independent.ff)
    }
    pub fn dsp_ratio(&self) -> f64 {
        ratio(self.tdm.dsp, self.independent.dsp)
    }
}

/// Sums the cells of `stat -json` output for `target`.
pub fn parse_stat(json: &str, target: Target) -> Result<Resources, HdlError> {
    let bad = |m: &str| HdlError::ToolFailed {
        tool: "yosys",
        detail: format!("stat -json: {m}"),
    };
    let v: serde_json::Value = serde_json::from_str(json).map_err(|e| bad(&e.to_string()))?;
    let cells = v
        .get("design")
        .and_then(|d| d.get("num_cells_by_type"))
        .and_then(|c| c.as_object())
        .ok_or_else(|| bad("no design.num_cells_by_type"))?;
    Ok(parse_cells(cells, target))
}

/// Sums a `num_cells_by_type` object for `target`.
pub(crate) fn parse_cells(
    cells: &serde_json::Map<String, serde_json::Value>,
    target: Target,
) -> Resources {
    let counts: BTreeMap<&str, u64> = cells
        .iter()
        .filter_map(|(k, n)| n.as_u64().map(|n| (k.as_str(), n)))
        .collect();
    let mut r = Resources::default();
    for (cell, n) in counts {
        target.classify(cell, n, &mut r);
    }
    r
}

/// Synthesizes `design` with yosys in `dir` and counts its cells.
pub fn synthesize(design: &Design, target: Target, dir: &Path) -> Result<Resources, HdlError> {
    let paths = design.write(dir)?;
    let script = format!(
        "read_verilog {}; {}; tee -q -o stat.json stat -json",
        file_names_of(&paths).join(" "),
        target.synth(design.arch.top())
    );
    run("yosys", "yosys", &["-q", "-p", &script], dir)?;
    let path = dir.join("stat.json");
    let text = std::fs::read_to_string(&path).map_err(|e| HdlError::io(&path, e))?;
    parse_stat(&text, target)
}

/// How the baseline of K independent cores is measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Baseline {
    /// Synthesize one single-axis core and multiply by K: the cores share nothing, so
    /// this leaves out only the bus decode and the group-start AND (a few LUTs).
    Scaled,
    /// Synthesize the whole `ms_indep_top` of K cores (slow: K times the work).
    Full,
}

/// The sweep over `axes`: for each K, the TDM core and K independent cores, synthesized
/// under `workdir`. Every parameter set is checked before any Verilog is written.
pub fn sweep(
    base: &CoreParams,
    axes: &[u32],
    target: Target,
    baseline: Baseline,
    workdir: &Path,
) -> Result<Vec<Row>, HdlError> {
    let with_axes = |k: u32| CoreParams {
        axes: k,
        ..base.clone()
    };
    let designs = axes
        .iter()
        .map(|&k| {
            let p = with_axes(k);
            Ok((
                k,
                target.design(&p, Arch::Tdm)?,
                target.design(&p, Arch::Independent)?,
            ))
        })
        .collect::<Result<Vec<_>, HdlError>>()?;
    let single = match baseline {
        Baseline::Scaled => Some(synthesize(
            &target.design(&with_axes(1), Arch::Independent)?,
            target,
            &workdir.join("indep-1"),
        )?),
        Baseline::Full => None,
    };
    // each yosys run is one process on one core: the runs go side by side
    designs
        .par_iter()
        .map(|(k, tdm, ind)| {
            let (tdm, independent) = rayon::join(
                || synthesize(tdm, target, &workdir.join(format!("tdm-{k}"))),
                || match single {
                    Some(one) => Ok(one.times(u64::from(*k))),
                    None => synthesize(ind, target, &workdir.join(format!("indep-{k}"))),
                },
            );
            Ok(Row {
                axes: *k,
                tdm: tdm?,
                independent: independent?,
            })
        })
        .collect()
}

/// A top for placing a bare core on a device with few pins: a shift register (`sin`,
/// strobe `wen`) drives the bus and every output is folded into one pin, so all the
/// logic stays and the design needs 4 pins whatever K is.
pub fn pin_light_top(design: &Design) -> String {
    let w = &design.widths;
    let k = design.params.axes;
    let sr = 32 + w.aw;
    format!(
        "// Generated by multistep-hdl: {top} behind a shift-register bus, outputs folded.\n\
         module ms_place_top (input wire clk, input wire sin, input wire wen, output reg fold);\n\
         \x20   reg [{s1}:0] sr;\n\
         \x20   reg wen_r;\n\
         \x20   wire go;\n\
         \x20   wire [{k1}:0] step, dir, busy, underrun;\n\
         \x20   {top} u_top (.clk(clk), .wr_en(wen_r), .wr_addr(sr[{s1}:32]), .wr_data(sr[31:0]),\n\
         \x20       .go(go), .step(step), .dir(dir), .busy(busy), .underrun(underrun));\n\
         \x20   always @(posedge clk) begin\n\
         \x20       sr <= {{sr[{s2}:0], sin}};\n\
         \x20       wen_r <= wen;\n\
         \x20       fold <= ^{{go, step, dir, busy, underrun}};\n\
         \x20   end\n\
         endmodule\n",
        top = design.arch.top(),
        s1 = sr - 1,
        s2 = sr - 2,
        k1 = k - 1,
    )
}

/// The board [`place`] uses for `family`: the first of that family in
/// [`crate::boards::BOARDS`].
fn place_board(family: crate::boards::Family) -> Option<&'static crate::boards::Board> {
    crate::boards::BOARDS.iter().find(|b| b.family == family)
}

/// The hard blocks of a device [`place`] uses: (DSP, block RAM), from the data sheets.
fn hard_blocks(device: &str) -> Option<(u64, u64)> {
    match device {
        // MULT18X18D, DP16KD
        d if d.starts_with("LFE5U-25F") => Some((28, 56)),
        d if d.starts_with("LFE5U-85F") => Some((156, 208)),
        // SB_MAC16, SB_RAM40_4K
        d if d.starts_with("iCE40UP5K") => Some((8, 30)),
        _ => None,
    }
}

/// Why a design synthesized to `r` cannot fit the device [`place`] uses for `family`,
/// known before placing it: more DSP blocks or block RAMs than the device has (so the K
/// independent cores of a large K are not synthesized again and handed to nextpnr only to
/// fail). `None` when they fit, or the device is not known.
pub fn blocks_over(family: crate::boards::Family, r: &Resources) -> Option<String> {
    let (dsp, bram) = hard_blocks(place_board(family)?.device)?;
    let (dsp_cell, bram_cell) = match family {
        crate::boards::Family::Ecp5 => ("MULT18X18D", "DP16KD"),
        crate::boards::Family::Ice40 => ("SB_MAC16", "SB_RAM40_4K"),
    };
    let over: Vec<String> = [(dsp_cell, r.dsp, dsp), (bram_cell, r.bram, bram)]
        .into_iter()
        .filter(|&(_, used, have)| used > have)
        .map(|(cell, used, have)| format!("{cell} {used} of {have}"))
        .collect();
    (!over.is_empty()).then(|| format!("{} (by synthesis)", over.join(", ")))
}

/// Places and routes `design` (behind [`pin_light_top`]) on the device of the first
/// board of `family` in [`crate::boards::BOARDS`], at the design's clock, in `dir`.
pub fn place(
    design: &Design,
    family: crate::boards::Family,
    dir: &Path,
) -> Result<crate::pnr::Placed, HdlError> {
    let board = place_board(family)
        .ok_or_else(|| HdlError::Param(format!("no board of family {family:?}")))?;
    let mut paths = design.write(dir)?;
    let top = dir.join("ms_place_top.v");
    std::fs::write(&top, pin_light_top(design)).map_err(|e| HdlError::io(&top, e))?;
    paths.push(top);
    let flow = crate::pnr::Flow {
        family,
        nextpnr_args: board.nextpnr_args,
        top: "ms_place_top",
        sources: file_names_of(&paths),
        constraints: None,
        clock_hz: design.params.clock_hz,
        pack: false,
        nextpnr: crate::pnr::Nextpnr::YoWasp,
    };
    crate::pnr::place_and_route(&flow, dir)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boards::Family;

    fn blocks(dsp: u64, bram: u64) -> Resources {
        Resources {
            dsp,
            bram,
            ..Resources::default()
        }
    }

    #[test]
    fn independent_cores_over_the_hard_blocks_are_known_before_placing() {
        // eight independent cores on the LFE5U-25F (docs/HDL.md): 64 multipliers, 72 DP16KD
        assert_eq!(
            blocks_over(Family::Ecp5, &blocks(64, 72)).as_deref(),
            Some("MULT18X18D 64 of 28, DP16KD 72 of 56 (by synthesis)")
        );
        assert_eq!(
            blocks_over(Family::Ice40, &blocks(8, 31)).as_deref(),
            Some("SB_RAM40_4K 31 of 30 (by synthesis)")
        );
        assert_eq!(blocks_over(Family::Ecp5, &blocks(28, 56)), None);
        assert_eq!(blocks_over(Family::Ice40, &blocks(8, 30)), None);
    }
}
