// ms_div: sequential restoring divider, RB quotient bits per cycle (radix 2^RB), for a
// quotient known to fit WQ bits (num < den * 2^WQ). The start cycle loads num and den;
// then NQ = WQ / RB cycles; `fin` is high in the cycle after the last, when q = num / den.
module ms_div #(
    parameter WN = 128,  // numerator bits (> WQ)
    parameter WD = 68,   // denominator bits (also remainder bits)
    parameter WQ = 24,   // quotient bits, a multiple of RB
    parameter RB = 2     // quotient bits per cycle
) (
    input  wire          clk,
    input  wire          start,
    input  wire [WN-1:0] num,
    input  wire [WD-1:0] den,
    output wire          fin,
    output reg  [WQ-1:0] q
);
    localparam NQ = WQ / RB;
    reg [WD-1:0] rem;
    reg [WD-1:0] rden;
    wire         busy;   // iterating
    ms_steps #(.N(NQ)) u_steps (.clk(clk), .start(start), .busy(busy), .fin(fin));
    // RB restoring steps in one cycle; the low numerator bits shift through q
    reg [WD-1:0] nrem;
    reg [WQ-1:0] nq;
    /* verilator lint_off UNUSED */  // rs - den < den fits WD bits
    reg [WD:0]   rs, rd;
    /* verilator lint_on UNUSED */
    integer s;
    always @(*) begin
        nrem = rem;
        nq = q;
        rs = {(WD+1){1'b0}};
        rd = {(WD+1){1'b0}};
        for (s = 0; s < RB; s = s + 1) begin
            rs = {nrem, nq[WQ-1]};
            rd = rs - {1'b0, rden};
            if (rs >= {1'b0, rden}) begin
                nrem = rd[WD-1:0];
                nq = {nq[WQ-2:0], 1'b1};
            end else begin
                nrem = rs[WD-1:0];
                nq = {nq[WQ-2:0], 1'b0};
            end
        end
    end
    // the high numerator bits start in the remainder (< den since the quotient fits)
    /* verilator lint_off UNUSED */
    wire [WD+WN-WQ-1:0] hi_ext = {{WD{1'b0}}, num[WN-1:WQ]};
    /* verilator lint_on UNUSED */
    always @(posedge clk) begin
        if (start) begin
            rem  <= hi_ext[WD-1:0];
            q    <= num[WQ-1:0];
            rden <= den;
        end else if (busy) begin
            rem <= nrem;
            q   <= nq;
        end
    end
endmodule
