// ms_chain_axis: one axis's replay unit (ms_stream) with a forward-difference chain
// (ms_chain) beside it, for boards that compute scurve and scurve4 pieces (docs/HDL.md,
// "Computed polynomial pieces"). Its ports are ms_stream's plus arm_ch. A StreamSteps run
// replays the nibble code; a ChainSteps run feeds the buffer's bytes to the chain as piece
// records (RECB bytes each, a byte a clock while the chain rests), starts each record once
// it is complete, and pushes the chain's periods. Either way the steps are counted against
// the armed count, so the axis ends, underruns and halts as for any streamed move.
module ms_chain_axis #(
    parameter WD = 24,
    parameter LB = 12,
    parameter WR = 304,
    parameter W1 = 280,
    parameter W2 = 264,
    parameter W3 = 248,
    parameter W4 = 240,
    parameter WT = 40,
    parameter WN = 32
) (
    input  wire          clk,
    input  wire          rst,
    input  wire          arm,
    input  wire          arm_ch,
    input  wire [31:0]   arm_steps,
    input  wire          retarget_in,
    input  wire          bopen,
    input  wire [7:0]    blen,
    input  wire          bwr,
    input  wire [7:0]    bidx,
    input  wire [7:0]    bbyte,
    input  wire          bcommit,
    input  wire          init,
    input  wire          halt,
    input  wire          full,
    output wire          armed,
    output wire          bok,
    output wire [LB:0]   free,
    output wire          push,
    output wire [WD-1:0] period,
    output wire          more,
    output wire          fault
);
    // a record: lo, hi (WT), count (WN), R (WR), D1..D4, M (WR): multistep_hdl::chain
    localparam RECB = (2 * WT + WN + 2 * WR + W1 + W2 + W3 + W4) / 8;
    wire          avail, feed, s_push, s_fault, c_busy, c_push, c_fault;
    wire [7:0]    rbyte;
    wire [WD-1:0] s_period, c_period;
    reg  [8:0]    got;     // bytes of the record taken
    reg           ld;      // the byte taken last clock is at rbyte
    initial begin
        got = 9'd0;
        ld = 1'b0;
    end
    wire pop = feed && !c_busy && (got != RECB[8:0]) && avail;
    wire go  = feed && !c_busy && (got == RECB[8:0]) && !ld;
    always @(posedge clk) begin
        ld <= pop;
        if (rst || arm || arm_ch || init || halt || go) got <= 9'd0;
        else if (pop) got <= got + 1'b1;
    end

    ms_stream #(.WD(WD), .LB(LB), .CH(1)) u_stream (
        .clk(clk), .rst(rst), .arm(arm), .arm_steps(arm_steps), .retarget_in(retarget_in),
        .bopen(bopen), .blen(blen), .bwr(bwr), .bidx(bidx), .bbyte(bbyte),
        .bcommit(bcommit), .init(init), .halt(halt), .full(full), .arm_ch(arm_ch),
        .pop(pop), .xpush(c_push), .avail(avail), .rbyte(rbyte), .feed(feed),
        .armed(armed), .bok(bok), .free(free), .push(s_push), .period(s_period),
        .more(more), .fault(s_fault));
    ms_chain #(.WR(WR), .W1(W1), .W2(W2), .W3(W3), .W4(W4), .WM(WR), .WT(WT), .WN(WN),
               .WD(WD)) u_chain (
        .clk(clk), .rst(rst), .init(init), .halt(halt), .ld(ld), .ld_byte(rbyte), .go(go),
        .full(full), .busy(c_busy), .push(c_push), .period(c_period), .fault(c_fault));
    assign push   = s_push || c_push;
    assign period = c_push ? c_period : s_period;
    assign fault  = s_fault || c_fault;
endmodule
