// ms_debounce: the accepted level `q` changes exactly when the input has differed from it
// for `ticks` consecutive clocks (at least one), never sooner and never later; `accept`
// is that change to 1 in its own clock and `rise` the clock after; a reset takes the
// input's level without an edge.
// MUTATE expects the change one clock later: the check must then fail.
module debounce_props #(
    parameter W = 3
) (
    input wire         clk,
    input wire         rst,
    input wire         d,
    input wire [W-1:0] ticks
);
    wire q, accept, rise;
    ms_debounce #(.W(W)) dut (.clk(clk), .rst(rst), .d(d), .ticks(ticks), .q(q),
        .accept(accept), .rise(rise));

`ifdef MUTATE
    localparam [W:0] SLIP = 1;
`else
    localparam [W:0] SLIP = 0;
`endif
    reg          init = 1'b1;
    reg [W-1:0]  ticks_d;
    reg [W:0]    differ = 0;     // consecutive clocks before this one with d != q
    reg          q_d = 1'b0, d_d = 1'b0, rst_d = 1'b0, accept_d = 1'b0, due_d = 1'b0;
    wire [W:0]   need = (ticks == 0) ? 1 : {1'b0, ticks};
    // the change this clock's inputs make at the edge
    wire         due = !rst && d != q && differ + 1 >= need + SLIP;

    always @(*) begin
        // the board resets first; the filter time is a register the host sets at rest
        if (init) assume(rst);
        if (!init) assume(ticks == ticks_d);
        assert(accept == (due && d));
        if (!init) assert(q == (rst_d || due_d ? d_d : q_d));
        if (!init) assert(rise == accept_d);
        cover(!init && !rst_d && q != q_d && ticks > 2);
        cover(!init && rise);
        cover(!init && !rst && d != q && differ + 2 == need);
    end

    always @(posedge clk) begin
        init     <= 1'b0;
        ticks_d  <= ticks;
        q_d      <= q;
        d_d      <= d;
        rst_d    <= rst;
        accept_d <= accept;
        due_d    <= due;
        if (rst || d == q || due) differ <= 0;
        else if (differ != {(W+1){1'b1}}) differ <= differ + 1'b1;
    end
endmodule
