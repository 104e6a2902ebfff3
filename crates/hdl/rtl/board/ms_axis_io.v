// ms_axis_io: one axis's pins and counters around the core.
//  - STEP: the core's STEP one clock later (50 % duty), or with a fixed width (`fixed`)
//    high for exactly PulseWidth clocks from each of the core's rises (the core TDM model's
//    PulseShape::Fixed); forced low at once (combinationally) by `kill_pin` (the e-stop
//    input) and from the next clock by `kill` (the synchronized e-stop) and `halt`.
//  - `count`: a STEP rise of the core that is not cut by `kill` or `halt` (one cut only by
//    `kill_pin`, in the synchronizer's 2 clocks, is counted), which moves the position
//    (ms_positions) by +1 / -1 (by DIR). (The period read back is the pulse unit's.)
//  - Hall and limit inputs (synchronized and made active-high by the caller): debounced on
//    the shared time base; the Hall edge is time-stamped: `latch` copies the position into
//    the Hall latch (ms_positions) in the clock the accepted level began (the rises before
//    it), and the flag is set when it is accepted. A level that began while the last
//    edge's flag was still set is latched when accepted instead, so the flag never pairs
//    with an older edge's position.
//  - output levels: STEP, DIR, ENABLE active high when their `lvl_*` bit is 1.
module ms_axis_io #(
    parameter WD    = 24,
    parameter WB    = 10,   // the filters' counters (ms_filter_clock)
    parameter LIMIT = 1     // 0: no limit input wired (its level and edge read 0)
) (
    input  wire          clk,
    input  wire          rst,
    input  wire          core_step,
    input  wire          dir,        // the latched DIR bit (1 = position counts up)
    input  wire          halt,
    input  wire          kill,       // the e-stop, synchronized: STEP low at the next clock
    input  wire          kill_pin,   // the e-stop input itself: gates the STEP pin only
    input  wire          fixed,      // a fixed STEP high time (PulseWidth != 0); else 50 % duty
    input  wire [WD-1:0] now,        // a free-running clock count (shared)
    input  wire [WD-1:0] end_at,     // now + PulseWidth: where a pulse rising now ends (shared)
    input  wire          strobe,     // the filters' time base
    input  wire [WB-1:0] load,
    input  wire          hall,       // active-high, synchronized
    input  wire          limit,      // active-high, synchronized
    input  wire          hall_clr,
    input  wire          en,
    input  wire          lvl_step,
    input  wire          lvl_dir,
    input  wire          lvl_en,
    output wire          step_pin,
    output wire          dir_pin,
    output wire          en_pin,
    output wire          count,      // a counted rise (ms_positions)
    output wire          latch,      // the Hall latch takes the position (ms_positions)
    output reg           hall_flag,
    output wire          hall_lvl,
    output wire          hall_edge,  // one clock at the accepted Hall edge
    output wire          limit_lvl,
    output wire          limit_edge
);
    reg          core_d;   // the core's STEP one clock ago
    reg          s;        // STEP, active high, before the e-stop gate
    // A fixed-width pulse ends where `now` reaches the end taken at its rise: per axis a
    // register and an equality, where a counter would need an adder and a comparator.
    // A pulse keeps the width it rose with (PulseWidth is written only while no axis is
    // busy; a fixed pulse may outlast the move's end).
    reg [WD-1:0] t_end;
    initial begin
        core_d = 1'b0;
        s = 1'b0;
        hall_flag = 1'b0;
        t_end = {WD{1'b0}};
    end
    wire rise  = core_step && !core_d;
    always @(posedge clk) begin
        core_d <= core_step;
        if (rst || halt || kill) begin
            s <= 1'b0;
        end else if (!fixed) begin
            s <= core_step;
        end else if (rise) begin
            s <= 1'b1;
        end else if (now == t_end) begin
            // PulseWidth clocks after the rise's clock: high for exactly that many
            s <= 1'b0;
        end
    end
    // a rise that reaches the pin
    wire out_rise = rise && !(rst || halt || kill);
    assign count = out_rise;
    always @(posedge clk)
        if (out_rise) t_end <= end_at;
    wire begins, accept;
    ms_debounce #(.W(WB)) u_hall (.clk(clk), .rst(rst), .d(hall), .strobe(strobe),
        .load(load), .q(hall_lvl), .begins(begins), .accept(accept), .rise(hall_edge));
    generate
        if (LIMIT != 0) begin : lim
            /* verilator lint_off PINCONNECTEMPTY */
            ms_debounce #(.W(WB)) u_limit (.clk(clk), .rst(rst), .d(limit), .strobe(strobe),
                .load(load), .q(limit_lvl), .begins(), .accept(), .rise(limit_edge));
            /* verilator lint_on PINCONNECTEMPTY */
        end else begin : no_lim
            assign limit_lvl  = 1'b0;
            assign limit_edge = 1'b0;
            /* verilator lint_off UNUSED */
            wire unused_limit = limit;
            /* verilator lint_on UNUSED */
        end
    endgenerate
    // the Hall position: latched where an active level begins while the flag is clear
    // (`caught`), else where it is accepted
    reg  caught;
    wire enter = begins && hall;
    wire caught_now = enter ? !hall_flag : caught;
    initial caught = 1'b0;
    always @(posedge clk) begin
        if (rst || hall_clr) hall_flag <= 1'b0;
        if (rst) caught <= 1'b0;
        else if (enter) caught <= !hall_flag;
        if (accept) hall_flag <= 1'b1;
    end
    assign latch = (enter && !hall_flag) || (accept && !caught_now);
    // the only use of the unsynchronized e-stop: a gate, no flip-flop sees it
    assign step_pin = (s && !kill && !kill_pin) ? lvl_step : !lvl_step;
    assign dir_pin  = dir ? lvl_dir : !lvl_dir;
    assign en_pin   = en ? lvl_en : !lvl_en;
endmodule
