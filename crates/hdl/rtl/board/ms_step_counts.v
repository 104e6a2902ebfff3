// ms_step_counts: the step counts of the K axes of the shared replay unit (ms_replay),
// each exactly ms_step_count's, with the counts in two small memories and one adder for
// all: per axis only the flags stay in flip-flops (periods to go, `left_nz`; none done
// yet, `zero`; armed for none, `none`).
//  - steps[g]: written by `load` or `retarget` of axis g, which the register map sends one
//    axis a clock (a StreamSteps write), so one write port serves every axis.
//  - done[s]: written by the decoder's `step`, of the axis it serves (s) only; `init`
//    sets `zero` instead (done reads 0 until the axis's next step), as pmem's `fresh`.
//  - the step's update of left_nz reads both at s; a retarget's, a clock later as in
//    ms_step_count, reads done at the retargeted axis (a second read port) against the
//    count it wrote (held a clock). Two steps of one axis are at least two clocks apart
//    (a turn is a pick and a decode), and a step with a retarget's update in the same
//    clock wins, as in ms_step_count.
module ms_step_counts #(
    parameter K  = 2,
    parameter LK = 1
) (
    input  wire          clk,
    input  wire          rst,       // nothing counted changes
    input  wire [K-1:0]  load,      // armed: the count is `count` (before `halt`)
    input  wire [K-1:0]  halt,      // stopped: nothing counted changes
    input  wire [K-1:0]  init,      // the start: none done yet
    input  wire [K-1:0]  retarget,  // the running stream's count is `count` from now
    input  wire [LK-1:0] s,         // the axis the decoder serves
    input  wire          step,      // a period of axis s is taken (to be pushed)
    input  wire [31:0]   count,
    output reg  [K-1:0]  left_nz
);
    reg [31:0]   steps [0:(1<<LK)-1];
    reg [31:0]   done  [0:(1<<LK)-1];
    reg [K-1:0]  zero, none;
    reg          rt_d;       // a retarget took effect last clock, of axis rt_ax, to rt_cnt
    reg [LK-1:0] rt_ax;
    reg [31:0]   rt_cnt;
    initial begin
        left_nz = {K{1'b0}};
        zero = {K{1'b1}};
        none = {K{1'b1}};
        rt_d = 1'b0;
    end
    wire [K-1:0] live = ~(load | halt | init) & {K{!rst}};
    wire [K-1:0] wr_v = (load | (retarget & live)) & {K{!rst}};
    // the written axis (at most one bit of wr_v is set)
    wire [LK-1:0] wa;
    ms_onehot #(.K(K), .LK(LK)) u_wa (.v(wr_v), .index(wa));
    integer i;

    // a step of s: done + 1 against steps, one subtract for < and ==, as ms_step_count
    wire        s_live  = live[s];
    wire [31:0] done_s  = zero[s] ? 32'd0 : done[s];
    wire [32:0] done_1w = {1'b0, done_s} + 1'b1;
    wire [33:0] gap     = {2'b0, steps[s]} - {1'b0, done_1w};
    wire        lt_1    = !gap[33] && (gap[32:0] != 33'd0);
    // a retarget's update: done < the count written
    wire [31:0] done_r  = zero[rt_ax] ? 32'd0 : done[rt_ax];
    wire        le_r    = done_r < rt_cnt;
    wire        stepped = step && s_live;

    always @(posedge clk) begin
        if (|wr_v) steps[wa] <= count;
        if (stepped) done[s] <= done_1w[31:0];
    end
    always @(posedge clk) begin
        rt_d   <= |(retarget & live);
        rt_ax  <= wa;
        rt_cnt <= count;
        for (i = 0; i < K; i = i + 1) begin
            if (wr_v[i]) none[i] <= (count == 32'd0);
            if (!rst && !load[i] && !halt[i] && init[i]) begin
                zero[i]    <= 1'b1;
                left_nz[i] <= !none[i];
            end
            if (live[i]) begin
                if (rt_d && rt_ax == i[LK-1:0]) left_nz[i] <= le_r;
                if (stepped && s == i[LK-1:0]) begin
                    zero[i]    <= 1'b0;
                    left_nz[i] <= lt_1;
                end
            end
        end
    end
endmodule
