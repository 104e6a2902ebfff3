// ms_fifo under its handshake (the calculator pushes only when not full; the pulse unit
// pops only when not empty or while the word is pushed, which then passes by): the count
// stays in 0..=2^LD and matches empty/full/afull, and a tracked word leaves in order,
// unchanged.
// MUTATE makes the count bound one short: the check must then fail.
module fifo_props #(
    parameter W  = 4,
    parameter LD = 2
) (
    input wire         clk,
    input wire         clear,
    input wire         push,
    input wire [W-1:0] din,
    input wire         pop,
    input wire         mark      // the solver's choice of the word to track
);
    wire [W-1:0] dout;
    wire         empty, full, afull;
    ms_fifo #(.W(W), .LD(LD)) dut (
        .clk(clk), .clear(clear), .push(push), .din(din), .pop(pop),
        .dout(dout), .empty(empty), .full(full), .afull(afull));

    localparam [LD+1:0] DEPTH = 1 << LD;
`ifdef MUTATE
    localparam [LD+1:0] BOUND = DEPTH - 1'b1;
`else
    localparam [LD+1:0] BOUND = DEPTH;
`endif
    reg [LD+1:0] count = 0;     // words held, by the handshake alone
    reg          tracking = 1'b0;
    reg [W-1:0]  tdata;
    reg [LD+1:0] ahead;         // words in front of the tracked one
    wire passby = push && pop && empty;

    always @(*) begin
        assume(!push || !full);
        assume(!pop || !empty || push);
        assert(count <= BOUND);
        assert(empty == (count == 0));
        assert(full == (count == DEPTH));
        assert(afull == (count == DEPTH - 1'b1));
        if (tracking) assert(ahead < count);
        if (tracking && ahead == 0) assert(dout == tdata);
        // every checked case is reached (yosys-smtbmc -c)
        cover(full);
        cover(tracking && ahead == 0 && pop && count == DEPTH);
        cover(passby);
    end

    always @(posedge clk) begin
        if (clear) begin
            count    <= 0;
            tracking <= 1'b0;
        end else begin
            count <= count + (push && !passby) - (pop && !passby);
            if (tracking && pop) begin
                if (ahead == 0) tracking <= 1'b0;
                else ahead <= ahead - 1'b1;
            end else if (!tracking && mark && push && !passby) begin
                tracking <= 1'b1;
                tdata    <= din;
                ahead    <= count - pop;
            end
        end
    end
endmodule
