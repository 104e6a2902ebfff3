// ms_isqrt: sequential integer square root, two bits of x per cycle (restoring).
// After W/2 cycles: q = floor(sqrt(x)), r = x - q*q (r == 0 iff x is a perfect square).
module ms_isqrt #(
    parameter W = 114  // even
) (
    input  wire           clk,
    input  wire           start,
    input  wire [W-1:0]   x,
    output reg            busy,
    output reg  [W/2-1:0] q,
    output reg  [W/2+1:0] r
);
    localparam WR = W / 2;
    reg [W-1:0] rx;
    reg [7:0]   cnt;
    wire [WR+3:0] rs = {r, rx[W-1:W-2]};          // r*4 + next two bits
    wire [WR+3:0] tr = {2'b00, q, 2'b01};         // 4q + 1
    wire          ge = (rs >= tr);
    /* verilator lint_off UNUSED */  // the remainder after subtraction fits WR+2 bits
    wire [WR+3:0] rd = rs - tr;
    /* verilator lint_on UNUSED */
    initial busy = 1'b0;
    always @(posedge clk) begin
        if (start) begin
            rx   <= x;
            q    <= {WR{1'b0}};
            r    <= {(WR+2){1'b0}};
            cnt  <= WR[7:0];
            busy <= 1'b1;
        end else if (busy) begin
            rx   <= {rx[W-3:0], 2'b00};
            q    <= {q[WR-2:0], ge};
            r    <= ge ? rd[WR+1:0] : rs[WR+1:0];
            cnt  <= cnt - 8'd1;
            busy <= (cnt != 8'd1);
        end
    end
endmodule
