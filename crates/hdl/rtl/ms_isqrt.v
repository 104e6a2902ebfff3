// ms_isqrt: sequential integer square root with remainder, RB root bits per cycle (radix
// 2^RB, restoring; RB = 1 is radix 2, RB = 2 radix 4). The start cycle loads x; then
// NS = W / (2 RB) cycles; `fin` is high in the cycle after the last, when
// q = floor(sqrt(x)) and r = x - q*q (r == 0 iff x is a perfect square) are valid.
module ms_isqrt #(
    parameter W  = 128,  // radicand bits, a multiple of 2 RB
    parameter RB = 2     // root bits per cycle
) (
    input  wire           clk,
    input  wire           start,
    input  wire [W-1:0]   x,
    output wire           fin,
    output reg  [W/2-1:0] q,
    output reg  [W/2+1:0] r
);
    localparam WR = W / 2;
    localparam NS = WR / RB;
    reg [W-1:0] rx;
    wire        busy;   // iterating
    ms_steps #(.N(NS)) u_steps (.clk(clk), .start(start), .busy(busy), .fin(fin));
    // RB restoring steps in one cycle: bring down two radicand bits, try 4q + 1
    reg [W-1:0]    nx;
    reg [WR-1:0]   nq;
    reg [WR+1:0]   nr;
    reg [WR+3:0]   rs, tr;
    /* verilator lint_off UNUSED */  // rs - tr < 2^(WR+2) when taken
    reg [WR+3:0]   rd;
    /* verilator lint_on UNUSED */
    integer s;
    always @(*) begin
        nx = rx;
        nq = q;
        nr = r;
        rs = {(WR+4){1'b0}};
        tr = {(WR+4){1'b0}};
        rd = {(WR+4){1'b0}};
        for (s = 0; s < RB; s = s + 1) begin
            rs = {nr, nx[W-1:W-2]};
            tr = {2'b00, nq, 2'b01};
            rd = rs - tr;
            nx = {nx[W-3:0], 2'b00};
            if (rs >= tr) begin
                nr = rd[WR+1:0];
                nq = {nq[WR-2:0], 1'b1};
            end else begin
                nr = rs[WR+1:0];
                nq = {nq[WR-2:0], 1'b0};
            end
        end
    end
    always @(posedge clk) begin
        if (start) begin
            rx <= x;
            q  <= {WR{1'b0}};
            r  <= {(WR+2){1'b0}};
        end else if (busy) begin
            rx <= nx;
            q  <= nq;
            r  <= nr;
        end
    end
endmodule
