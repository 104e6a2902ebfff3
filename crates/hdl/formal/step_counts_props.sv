// ms_step_counts (K = 2, the counts in two memories) against its definition, two
// ms_step_count: the same `left_nz` at every clock, for any counts, loads, starts, halts,
// resets, retargets and steps the board can give. The environment is ms_replay's and
// ms_regs's: a load or retarget of one axis a clock (a StreamSteps write), an axis
// started only after its first load, retargets and steps only of a started axis, steps
// only of the axis served (s), and two steps of one axis never in consecutive clocks (a
// turn is a pick and a decode).
// MUTATE gives the reference a retarget's count one higher: the check must then fail.
module step_counts_props (
    input wire        clk,
    input wire        rst_in,
    input wire [1:0]  load,
    input wire [1:0]  halt,
    input wire [1:0]  init,
    input wire [1:0]  retarget,
    input wire        s,
    input wire        step,
    input wire [31:0] count
);
    reg       rst = 1'b1;           // the first clock is a reset
    reg [1:0] loaded = 2'b00, started = 2'b00;
    reg       step_d = 1'b0, s_d = 1'b0;
    reg       rt_d = 1'b0;          // a retarget last clock
    reg [1:0] nz_d = 2'b00;         // left_nz last clock
    wire       r = rst || rst_in;
    wire [1:0] left_nz, ref_nz;
`ifdef MUTATE
    wire [31:0] rcount = (retarget != 2'b00) ? count + 32'd1 : count;
`else
    wire [31:0] rcount = count;
`endif
    ms_step_counts #(.K(2), .LK(1)) dut (.clk(clk), .rst(r), .load(load), .halt(halt),
        .init(init), .retarget(retarget), .s(s), .step(step), .count(count),
        .left_nz(left_nz));
    ms_step_count ref0 (.clk(clk), .rst(r), .load(load[0]), .halt(halt[0]), .init(init[0]),
        .retarget(retarget[0]), .step(step && !s), .count(rcount), .left_nz(ref_nz[0]));
    ms_step_count ref1 (.clk(clk), .rst(r), .load(load[1]), .halt(halt[1]), .init(init[1]),
        .retarget(retarget[1]), .step(step && s), .count(rcount), .left_nz(ref_nz[1]));

    wire [3:0] writes = {load, retarget};
    always @(*) begin
        assume((writes & (writes - 4'd1)) == 4'd0);
        assume((init & ~loaded) == 2'b00);
        assume((retarget & ~started) == 2'b00);
        if (step) assume(started[s]);
        if (step && step_d) assume(s != s_d);
        assert(left_nz == ref_nz);
        // a step ends an axis's count; a retarget changes the flag a clock later
        cover(step_d && nz_d[s_d] && !left_nz[s_d]);
        cover(rt_d && !step_d && left_nz != nz_d);
    end
    always @(posedge clk) begin
        rst     <= 1'b0;
        loaded  <= loaded | (load & {2{!r}});
        started <= started | (init & loaded & ~load & ~halt & {2{!r}});
        step_d  <= step;
        s_d     <= s;
        rt_d    <= retarget != 2'b00;
        nz_d    <= left_nz;
    end
endmodule
