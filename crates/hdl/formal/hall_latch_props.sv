// ms_axis_io's Hall latch (with the position and latch it drives, ms_positions by its
// definition, one axis): when a Hall level is accepted (the Hall edge output, a clock
// later), `HallPosition` holds the position in the clock the input rose to that level if
// the flag was clear then, and else the position in the clock it was accepted; the flag is
// set. The input, the host's clears, position writes, STEP and DIR are free; every clock
// strobes (the time base is `debounce_props`'s).
// MUTATE expects the position of the clock after the rise: the check must then fail.
module hall_latch_props #(
    parameter WB = 3
) (
    input wire          clk,
    input wire          rst,
    input wire          core_step,
    input wire          dir,
    input wire          hall,
    input wire          hall_clr,
    input wire          pos_wr,
    input wire [31:0]   pos_in,
    input wire [WB-1:0] load
);
    wire [31:0] pos, hall_pos;
    wire        hall_flag, hall_edge, count, latch;
    /* the pins are not checked here */
    ms_axis_io #(.WD(3), .WB(WB), .LIMIT(0)) dut (
        .clk(clk), .rst(rst), .core_step(core_step), .dir(dir),
        .halt(1'b0), .kill(1'b0), .kill_pin(1'b0), .fixed(1'b0), .now(3'd0), .end_at(3'd0), .strobe(1'b1),
        .load(load), .hall(hall), .limit(1'b0),
        .hall_clr(hall_clr), .en(1'b0), .lvl_step(1'b1), .lvl_dir(1'b1), .lvl_en(1'b1),
        .step_pin(), .dir_pin(), .en_pin(), .count(count), .latch(latch),
        .hall_flag(hall_flag), .hall_lvl(), .hall_edge(hall_edge), .limit_lvl(),
        .limit_edge());
    ms_positions #(.K(1), .LK(1), .MEM(0)) u_pos (.clk(clk), .rst(rst), .cnt(count), .up(dir),
        .latch(latch), .wr(pos_wr), .din(pos_in), .rd(1'b0), .ax(1'b0), .rd_pos(pos), .rd_hall(hall_pos));

    reg         init = 1'b1;
    reg         hall_d = 1'b0, rst_d = 1'b0, rise_clear = 1'b0;
    reg [31:0]  pos_d, rise_pos;   // the position a clock ago, and where the input rose
    reg [WB-1:0] load_d;
`ifdef MUTATE
    wire [31:0] stamp = pos_d;
`else
    wire [31:0] stamp = rise_pos;
`endif
    always @(*) begin
        // the board resets first; the filter time is a register the host sets at rest
        if (init) assume(rst);
        if (!init) assume(load == load_d);
        if (!init && hall_edge) begin
            assert(hall_flag);
            assert(hall_pos == (rise_clear ? stamp : pos_d));
        end
        cover(!init && hall_edge && rise_clear && rise_pos != pos_d);
        cover(!init && hall_edge && !rise_clear && rise_pos != pos_d);
    end
    always @(posedge clk) begin
        init   <= 1'b0;
        rst_d  <= rst;
        hall_d <= hall;
        load_d <= load;
        pos_d  <= pos;
        // the first clock of a high run, as the filter sees it (not in a reset)
        if (hall && (!hall_d || rst_d) && !rst) begin
            rise_pos   <= pos;
            rise_clear <= !hall_flag;
        end
    end
endmodule
