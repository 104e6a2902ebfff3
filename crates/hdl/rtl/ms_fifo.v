// ms_fifo: one axis's FIFO of periods (first-word fall-through), depth 2^LD. `full` and
// `afull` (at most one free place) are registers, computed from the pointers' next
// values: the same flags every clock as comparing the pointers, but with no logic between
// them and the scheduler or the chain unit that read them.
module ms_fifo #(
    parameter W  = 24,
    parameter LD = 4
) (
    input  wire         clk,
    input  wire         clear,
    input  wire         push,
    input  wire [W-1:0] din,
    input  wire         pop,
    output wire [W-1:0] dout,
    output wire         empty,
    output reg          full,
    output reg          afull
);
    localparam [LD:0] DM1 = (1 << LD) - 1;   // depth - 1
    reg [W-1:0] mem [0:(1<<LD)-1];
    reg [LD:0]  wp;
    reg [LD:0]  rp;
    initial begin
        wp = {(LD+1){1'b0}};
        rp = {(LD+1){1'b0}};
        full = 1'b0;
        afull = (DM1 == {(LD+1){1'b0}});
    end
    assign dout  = mem[rp[LD-1:0]];
    assign empty = (wp == rp);
    wire [LD:0] wp_n   = clear ? {(LD+1){1'b0}} : wp + {{LD{1'b0}}, push};
    wire [LD:0] rp_n   = clear ? {(LD+1){1'b0}} : rp + {{LD{1'b0}}, pop};
    wire [LD:0] used_n = wp_n - rp_n;
    always @(posedge clk) begin
        if (push) mem[wp[LD-1:0]] <= din;
    end
    always @(posedge clk) begin
        wp    <= wp_n;
        rp    <= rp_n;
        full  <= (wp_n == {~rp_n[LD], rp_n[LD-1:0]});
        afull <= (wp_n == {~rp_n[LD], rp_n[LD-1:0]}) || (used_n == DM1);
    end
endmodule
