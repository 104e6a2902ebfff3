// ms_div: sequential restoring divider for a quotient known to fit WQ bits
// (num < den * 2^WQ), one quotient bit per cycle: q = num / den after WQ cycles.
module ms_div #(
    parameter WN = 58,  // numerator bits
    parameter WD = 57,  // denominator bits (also remainder bits)
    parameter WQ = 25   // quotient bits; WQ < WN
) (
    input  wire          clk,
    input  wire          start,
    input  wire [WN-1:0] num,
    input  wire [WD-1:0] den,
    output reg           busy,
    output reg  [WQ-1:0] q
);
    reg [WD-1:0] rem;
    reg [WD-1:0] rden;
    reg [7:0]    cnt;
    wire [WD:0]  rs = {rem, q[WQ-1]};
    wire         ge = (rs >= {1'b0, rden});
    /* verilator lint_off UNUSED */  // rd < den fits WD bits
    wire [WD:0]  rd = rs - {1'b0, rden};
    /* verilator lint_on UNUSED */
    initial busy = 1'b0;
    // The high numerator bits start in the remainder; the low WQ bits shift through q.
    /* verilator lint_off UNUSED */  // only the low WD bits are the remainder
    wire [WD+WN-WQ-1:0] hi_ext = {{WD{1'b0}}, num[WN-1:WQ]};
    /* verilator lint_on UNUSED */
    always @(posedge clk) begin
        if (start) begin
            rem  <= hi_ext[WD-1:0];
            q    <= num[WQ-1:0];
            rden <= den;
            cnt  <= WQ[7:0];
            busy <= 1'b1;
        end else if (busy) begin
            rem  <= ge ? rd[WD-1:0] : rs[WD-1:0];
            q    <= {q[WQ-2:0], ge};
            cnt  <= cnt - 8'd1;
            busy <= (cnt != 8'd1);
        end
    end
endmodule
