// ms_axis_io's STEP pin: the e-stop input forces it inactive in the same clock, the
// synchronized e-stop (`kill`) and `halt` from the next clock on; a fixed width (`width`
// != 0) holds it active for exactly `width` clocks from each of the core's rises; at
// 50 % duty it is the core's STEP one clock later.
// MUTATE expects a fixed-width pulse one clock longer: the check must then fail.
module axis_io_props #(
    parameter WD = 3
) (
    input wire          clk,
    input wire          rst,
    input wire          core_step,
    input wire          dir,
    input wire          halt,
    input wire          kill,
    input wire          kill_pin,
    input wire [WD-1:0] width,
    input wire          lvl_step
);
    wire step_pin;
    reg [WD-1:0] now = 0;   // ms_board's clock count (wrapping every 2^WD clocks)
    /* the other outputs are not checked here */
    ms_axis_io #(.WD(WD)) dut (
        .clk(clk), .rst(rst), .core_step(core_step), .dir(dir),
        .halt(halt), .kill(kill), .kill_pin(kill_pin), .fixed(width != 0), .now(now), .end_at(now + width),
        .strobe(1'b1), .load(10'd0), .hall(1'b0), .limit(1'b0),
        .hall_clr(1'b0), .en(1'b0), .lvl_step(lvl_step), .lvl_dir(1'b1), .lvl_en(1'b1),
        .step_pin(step_pin), .dir_pin(), .en_pin(), .count(), .latch(), .hall_flag(),
        .hall_lvl(), .hall_edge(), .limit_lvl(), .limit_edge());

`ifdef MUTATE
    localparam [WD:0] SLIP = 1;
`else
    localparam [WD:0] SLIP = 0;
`endif
    wire on = (step_pin == lvl_step);    // STEP active, whatever its level
    reg  stop_d = 1'b1;                  // rst, halt or kill one clock ago
    reg  core_d = 1'b0;
    reg  on_d = 1'b0;
    reg  init = 1'b1;
    reg [WD-1:0] width_d;
    reg  clean = 1'b0;                   // no stop and no e-stop since the core's last rise
    reg [WD:0] since = 0;                // clocks since the core's last rise
    wire stop = rst || halt || kill;
    wire core_rise = core_step && !core_d;

    always @(*) begin
        // the width is a register, written only while the axis is idle: a constant here
        if (!init) assume(width == width_d);
        if (kill_pin) assert(!on);
        if (stop_d) assert(!on);
        if (width == 0 && !stop_d && !kill && !kill_pin) assert(on == core_d);
        if (width != 0 && clean && !kill && !kill_pin && on_d && !on) assert(since == {1'b0, width} + SLIP);
        if (width != 0 && clean && on) assert(since < {1'b0, width});
        // every checked case is reached (yosys-smtbmc -c)
        cover(width > 2 && clean && !kill && !kill_pin && on_d && !on);
        cover(width == 0 && !stop_d && !kill && !kill_pin && on);
        cover(kill_pin && on_d);
        cover(stop_d && on_d);
    end

    always @(posedge clk) begin
        init    <= 1'b0;
        now     <= now + 1'b1;
        width_d <= width;
        stop_d <= stop;
        core_d <= core_step;
        on_d   <= on;
        if (since != {(WD+1){1'b1}}) since <= since + 1'b1;
        if (core_rise && !stop) begin
            since <= 0;
            clean <= 1'b1;
        end else if (stop || kill_pin) begin
            clean <= 1'b0;
        end
    end
endmodule
