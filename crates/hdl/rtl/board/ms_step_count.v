// ms_step_count: a replay unit's step count (ms_stream's, and each axis's of ms_replay): the
// steps it was armed for, the periods pushed since the start, and whether more are to
// come (`left_nz`: done < steps, registered, off the register-check paths).
// A retarget (a StreamSteps write while the stream runs) writes the count now and updates
// left_nz from it the clock after, as if the write had come a clock later (the host
// cannot tell): no multiplexer between the written and the running count in front of the
// subtract (68 LUT4-eq less on ECP5). One subtract, steps - (done + 1), serves both
// updates of left_nz: its sign and whether it is zero give done + 1 < steps after a step
// and done + 1 <= steps (done < steps) after a retarget alone (as two comparisons of a
// multiplexed operand this synthesized 173 LUT4-eq larger on ECP5); 33 bits, so done + 1
// does not wrap.
module ms_step_count (
    input  wire        clk,
    input  wire        rst,       // nothing counted changes
    input  wire        load,      // armed: the count is `count` (before `halt`)
    input  wire        halt,      // stopped: nothing counted changes
    input  wire        init,      // the start: none done yet
    input  wire        retarget,  // the running stream's count is `count` from now
    input  wire        step,      // a period is pushed (or taken, to be pushed)
    input  wire [31:0] count,
    output reg         left_nz
);
    reg [31:0] steps, done;
    reg        retarget_d;   // a retarget took effect last clock: left_nz follows it now
    initial begin
        left_nz = 1'b0;
        retarget_d = 1'b0;
    end
    wire        live    = !rst && !load && !halt && !init;
    wire [32:0] done_1w = {1'b0, done} + 1'b1;
    wire [33:0] gap     = {2'b0, steps} - {1'b0, done_1w};
    wire        le_1    = !gap[33];
    wire        lt_1    = le_1 && (gap[32:0] != 33'd0);

    always @(posedge clk)
        retarget_d <= retarget && live;
    always @(posedge clk) begin
        if (!rst && load) steps <= count;
        if (!rst && !load && !halt && init) begin
            done    <= 32'd0;
            left_nz <= (steps != 32'd0);
        end
        if (live) begin
            if (retarget) steps <= count;
            if (retarget_d) left_nz <= le_1;
            if (step) begin
                done    <= done_1w[31:0];
                left_nz <= lt_1;
            end
        end
    end
endmodule
