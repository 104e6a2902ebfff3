// ms_filter_clock: the time base every Hall and limit filter (ms_debounce) shares. A filter
// time of `ticks` clocks is counted by each filter as `load` strobes of one prescaler of
// P = 2^S clocks, S the least shift that leaves ticks below 2^(WB-1):
//  - below 2^(WB-1) clocks, S = 0: every clock strobes and `load` = `ticks` (0 and 1 both
//    mean the next clock), so a level is accepted after exactly `ticks` clocks;
//  - longer, load = (ticks >> S) + 2: a level is accepted after it held more than `ticks`
//    clocks ((load - 1) P + 1 of them at least) and at most load * P <= ticks + 2P, where
//    P <= ticks / 2^(WB-2): under 1 % of the filter time late at WB = 10.
// A filter's counter is then WB bits, not WD. `ticks` is written at rest: `load` and the
// prescaler follow it one clock later.
module ms_filter_clock #(
    parameter WD = 24,
    parameter WB = 10
) (
    input  wire          clk,
    input  wire [WD-1:0] ticks,
    output reg  [WB-1:0] load,     // strobes a changed level must hold
    output wire          strobe    // this clock counts
);
    localparam WS = WD - WB + 1;   // S <= WS
    // S found a power of two at a time: halve by k while ticks >> S needs k more halvings
    reg [WD-1:0] t;                // ticks >> S
    reg [WS-1:0] m;                // P - 1: S ones
    integer k, b;
    always @(*) begin
        b = 0;   // assigned on every path: no latch
        t = ticks;
        m = {WS{1'b0}};
        for (k = 16; k >= 1; k = k / 2)
            if ((t >> (WB - 2 + k)) != {WD{1'b0}}) begin
                t = t >> k;
                for (b = 0; b < k; b = b + 1) m = {m[WS-2:0], 1'b1};
            end
    end
    reg [WS-1:0] mask_q;
    reg [WS-1:0] pre;              // free running: a strobe where its S low bits are 0
    initial begin
        load = {WB{1'b1}};
        mask_q = {WS{1'b0}};
        pre = {WS{1'b0}};
    end
    always @(posedge clk) begin
        load   <= t[WB-1:0] + {{(WB-2){1'b0}}, m[0], 1'b0};
        mask_q <= m;
        pre    <= pre + 1'b1;
    end
    // every P clocks whatever the count (no state of it delays a strobe)
    assign strobe = ((pre & mask_q) == {WS{1'b0}});
endmodule
