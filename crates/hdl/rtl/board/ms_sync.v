// ms_sync: two-flop synchronizer for W asynchronous inputs (each bit on its own; a bus
// that must change as one word needs a handshake instead). INIT is the power-up value.
module ms_sync #(
    parameter W    = 1,
    parameter INIT = 0
) (
    input  wire         clk,
    input  wire [W-1:0] d,
    output wire [W-1:0] q
);
    reg [W-1:0] s1, s2;
    initial begin
        s1 = INIT[W-1:0];
        s2 = INIT[W-1:0];
    end
    always @(posedge clk) begin
        s1 <= d;
        s2 <= s1;
    end
    assign q = s2;
endmodule
