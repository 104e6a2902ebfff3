#!/bin/sh
# Place and route the period calculator alone on an iCE40 HX8K and print its Fmax.
# Needs yosys and nextpnr-ice40 (Debian: apt-get install yosys nextpnr-ice40). Not part of
# the test suite: it takes minutes and only measures timing.
#   crates/hdl/timing/ice40.sh [RB] [WY] [WK] [WQ]      defaults: the core's 2 128 68 24
set -eu
here=$(cd "$(dirname "$0")" && pwd)
rtl="$here/../rtl"
rb=${1:-2} wy=${2:-128} wk=${3:-68} wq=${4:-24}
out=$(mktemp -d)
yosys -q -p "read_verilog $rtl/ms_calc.v $rtl/ms_div.v $rtl/ms_isqrt.v $rtl/ms_nmul.v $rtl/ms_steps.v $here/calc_top.v;
             chparam -set RB $rb -set WY $wy -set WK $wk -set WQ $wq calc_top;
             synth_ice40 -top calc_top -json $out/calc.json"
nextpnr-ice40 --hx8k --package ct256 --freq 50 --json "$out/calc.json" > "$out/pnr.log" 2>&1 || true
grep "ICESTORM_LC:" "$out/pnr.log" | tail -1
grep "Max frequency" "$out/pnr.log" | tail -1
echo "log: $out/pnr.log"
