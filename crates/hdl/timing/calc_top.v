// Timing wrapper for crates/hdl/timing/ice40.sh: a 32-bit shift register feeds every input
// of the calculator (replicated) and q is folded to one pin, so the placer sees 4 pins.
module calc_top #(parameter WY = 128, parameter WK = 68, parameter WQ = 24, parameter RB = 2)
    (input wire clk, input wire sin, input wire start, output reg sout, output wire done);
    reg [31:0] sr;
    wire [WQ-1:0] q;
    always @(posedge clk) begin
        sr <= {sr[30:0], sin};
        sout <= ^q;
    end
    wire [127:0] rep = {4{sr}};
    ms_calc #(.WY(WY), .WK(WK), .WN(20), .WQ(WQ), .RB(RB), .MD(16)) u(.clk(clk), .start(start),
              .mode(sr[1:0]), .y0(rep[WY-1:0]), .dy({rep[WY-2:0], sr[31]}),
              .k(rep[WK:0]), .dv(rep[WK+1:2]), .j(sr[19:0]), .done(done), .q(q));
endmodule
