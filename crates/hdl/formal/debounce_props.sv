// ms_debounce on ms_filter_clock's time base: after a reset (which takes the input's level
// without an edge) the accepted level changes only once the input has differed from it for
// `ticks` consecutive clocks (at least one), and at the latest after load * P of them, the
// prescaler and the filter count computed here from their definitions (P the least power
// of two with ticks < P * 2^(WB-1); load = ticks / P + 2 when P > 1); with P = 1 both
// bounds are `ticks`. `accept` is a change to 1 in its own clock, `rise` the clock after,
// `begins` the first clock differing.
// MUTATE expects the change one clock later than allowed: the check must then fail.
module debounce_props #(
    parameter WD = 4,
    parameter WB = 3
) (
    input wire          clk,
    input wire          rst,
    input wire          d,
    input wire [WD-1:0] ticks
);
    localparam WC = WD + WB + 1;
    wire          strobe, q, begins, accept, rise;
    wire [WB-1:0] load;
    ms_filter_clock #(.WD(WD), .WB(WB)) clock (.clk(clk), .ticks(ticks), .load(load),
        .strobe(strobe));
    ms_debounce #(.W(WB)) dut (.clk(clk), .rst(rst), .d(d), .strobe(strobe), .load(load),
        .q(q), .begins(begins), .accept(accept), .rise(rise));

`ifdef MUTATE
    localparam [WC-1:0] SLIP = 1;
`else
    localparam [WC-1:0] SLIP = 0;
`endif
    reg           init = 1'b1;
    reg  [WD-1:0] ticks_d;
    reg           q_d = 1'b0, d_d = 1'b0, rst_d = 1'b0, rst_dd = 1'b0, accept_d = 1'b0;
    reg  [WC-1:0] cnt = 0;   // clocks up to the last one that d had differed from q
    // consecutive clocks before this one with d != (this clock's) q
    wire [WC-1:0] run  = (!init && !rst_d && q == q_d) ? cnt : {WC{1'b0}};
    wire [WC-1:0] need = (ticks == 0) ? 1 : {{(WB+1){1'b0}}, ticks};
    wire [WC-1:0] t    = {{(WB+1){1'b0}}, ticks};
    reg  [WC-1:0] p, latest;
    integer j;
    always @(*) begin
        p = 1;
        for (j = 0; j < WD; j = j + 1)
            if (t >= (p << (WB - 1))) p = p << 1;
        latest = (p == 1) ? need : (t / p + 2) * p;
    end

    always @(*) begin
        // the board resets first, and for 2 clocks at least (ms_reset: 3 or more; the time
        // base's count follows the filter time a clock later); the filter time is a
        // register the host sets at rest
        if (init || (rst_d && !rst_dd)) assume(rst);
        if (!init) assume(ticks == ticks_d);
        // a change of q: to the input, which had differed long enough
        if (!init && !rst_d && q != q_d) assert(q == d_d && cnt >= need + SLIP);
        // and never later than `latest` clocks
        if (!rst && d != q) assert(run + 1 <= latest);
        if (!init && rst_d) assert(q == d_d);
        if (!init) assert(accept_d == (!rst_d && !q_d && q));
        if (!init) assert(rise == accept_d);
        assert(begins == (!rst && d != q && run == 0));
        cover(!init && !rst_d && q != q_d && ticks > 7);
        cover(!init && !rst_d && q != q_d && cnt == latest && p > 1);
        cover(!init && rise);
    end

    always @(posedge clk) begin
        init     <= 1'b0;
        ticks_d  <= ticks;
        q_d      <= q;
        d_d      <= d;
        rst_d    <= rst;
        rst_dd   <= rst_d;
        accept_d <= accept;
        if (rst || d == q) cnt <= 0;
        else if (run != {WC{1'b1}}) cnt <= run + 1'b1;
    end
endmodule
