// ms_replay, the shared replay decoder (K = 2, WD = 4, 256-byte buffers), its pushes:
// never into a full FIFO, at most one a clock, never a period of 0, and never more periods
// for an axis than the steps it was armed for. The environment is the board's: the FIFOs
// are modelled (depth 2, popped whenever the solver says while not empty), an axis is armed
// and started only while it has no periods to go (the core refuses a busy axis), a bulk
// frame is committed only when it fit, and the buffers' bytes are whatever the solver
// writes: any code, a bad one too. The calculator pushes (`hold`) whenever the solver says,
// never two clocks in a row. No retarget here (it changes the count on purpose).
// MUTATE expects one period less than the armed steps: the check must then fail.
module replay_props (
    input wire       clk,
    input wire [1:0] arm,
    input wire [2:0] arm_steps,
    input wire       bsel,
    input wire       bax,
    input wire       bopen,
    input wire [1:0] blen,
    input wire       bwr,
    input wire [1:0] bidx,
    input wire [7:0] bbyte,
    input wire [1:0] bcommit,
    input wire [1:0] init,
    input wire [1:0] halt,
    input wire [1:0] pop,
    input wire       rd,
    input wire       rax,
    input wire       hold
);
    localparam [2:0] DEPTH = 3'd2;
`ifdef MUTATE
    localparam [3:0] SLIP = 4'd1;
`else
    localparam [3:0] SLIP = 4'd0;
`endif
    reg        rst = 1'b1;
    reg        hold_d = 1'b0;
    reg  [2:0] count [0:1];        // periods in each axis's FIFO
    reg  [3:0] pushed [0:1];       // periods pushed since the axis's last init
    reg  [2:0] armed_for [0:1];    // the steps of its last arm
    reg  [2:0] started [0:1];      // ... as its last init took them
    initial begin
        count[0] = 3'd0;
        count[1] = 3'd0;
        pushed[0] = 4'd0;
        pushed[1] = 4'd0;
        armed_for[0] = 3'd0;
        armed_for[1] = 3'd0;
        started[0] = 3'd0;
        started[1] = 3'd0;
    end
    wire [1:0] full = {count[1] == DEPTH, count[0] == DEPTH};
    wire [1:0] armed, push, more, fault;
    wire       bok;
    wire [8:0] free;
    wire [3:0] period;
    ms_replay #(.K(2), .LK(1), .WD(4), .LB(8)) dut (
        .clk(clk), .rst(rst), .arm(arm), .arm_steps({29'd0, arm_steps}),
        .retarget_in(2'b00), .bsel(bsel), .bax(bax), .bopen(bopen), .blen({6'd0, blen}),
        .bwr(bwr), .bidx({6'd0, bidx}), .bbyte(bbyte), .bcommit(bcommit), .init(init),
        .halt(halt), .full(full), .hold(hold), .rd(rd), .rax(rax), .armed(armed), .bok(bok), .free(free), .push(push),
        .period(period), .more(more), .fault(fault));

    integer a;
    always @(*) begin
        // ms_regs arms one axis a clock (a StreamSteps write) and commits one frame
        assume(arm != 2'b11);
        assume(bcommit != 2'b11);
        assume(!(hold && hold_d));
        // ms_link: a request never comes in the clock a frame opens or writes a byte, nor
        // a commit (the clock after its frame's request) with either or with a request
        assume(!(rd && (bopen || bwr)));
        assume(!(bcommit != 2'b00 && (bopen || bwr || rd)));
        for (a = 0; a < 2; a = a + 1) begin
            // the core starts, and the host arms, only an axis with nothing to go
            if (init[a] || arm[a]) assume(!more[a]);
            // ms_regs commits a bulk frame only when it fit (the open frame's axis)
            if (bcommit[a]) assume(bok && bsel && bax == a);
            assert(!push[a] || !full[a]);
            if (push[a]) assert(period != 4'd0);
            assert(count[a] <= DEPTH);
            assert(pushed[a] + SLIP <= {1'b0, started[a]} || pushed[a] == 4'd0);
        end
        assert(push != 2'b11);
        cover(push[0] && more[1]);
        cover(pushed[1] == 4'd2 && count[1] == DEPTH);
        cover(fault[0]);
        cover(hold_d && push[0]);
    end

    always @(posedge clk) begin
        rst <= 1'b0;
        hold_d <= hold;
        for (a = 0; a < 2; a = a + 1) begin
            count[a] <= count[a] + (push[a] ? 3'd1 : 3'd0)
                        - ((pop[a] && count[a] != 3'd0) ? 3'd1 : 3'd0);
            if (arm[a]) armed_for[a] <= arm_steps;
            if (init[a]) begin
                pushed[a]  <= 4'd0;
                started[a] <= armed_for[a];
                count[a]   <= 3'd0;
            end else if (push[a]) begin
                pushed[a] <= pushed[a] + 1'b1;
            end
        end
    end
endmodule
