// ms_mul: sequential unsigned multiplier, one 16-bit digit of b per cycle.
// p = a * b after ceil(W/16) cycles; each cycle uses one W x 16 multiplier (DSP slices).
module ms_mul #(
    parameter W = 56
) (
    input  wire           clk,
    input  wire           start,
    input  wire [W-1:0]   a,
    input  wire [W-1:0]   b,
    output reg            busy,
    output wire [2*W-1:0] p
);
    localparam ND = (W + 15) / 16;  // digits of b
    localparam WB = ND * 16;
    reg [W-1:0]  ra;
    reg [WB-1:0] rb;
    reg [W-1:0]  hi;   // running high part
    reg [WB-1:0] lo;   // finished low digits, shifted in from the top
    reg [7:0]    cnt;
    wire [W+15:0] part = {16'b0, ra} * {{W{1'b0}}, rb[15:0]};
    wire [W+15:0] t = {16'b0, hi} + part;
    /* verilator lint_off UNUSED */  // digits beyond 2W are zero
    wire [W+WB-1:0] full = {hi, lo};
    /* verilator lint_on UNUSED */
    assign p = full[2*W-1:0];
    initial busy = 1'b0;
    always @(posedge clk) begin
        if (start) begin
            ra   <= a;
            rb   <= {{(WB-W){1'b0}}, b};
            hi   <= {W{1'b0}};
            lo   <= {WB{1'b0}};
            cnt  <= ND[7:0];
            busy <= 1'b1;
        end else if (busy) begin
            hi   <= t[W+15:16];
            lo   <= {t[15:0], lo[WB-1:16]};
            rb   <= {16'b0, rb[WB-1:16]};
            cnt  <= cnt - 8'd1;
            busy <= (cnt != 8'd1);
        end
    end
endmodule
