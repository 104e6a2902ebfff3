// ms_nmul: sequential multiplier with one narrow operand: p = a * j, one MD-bit digit of j
// per cycle, most significant digit first (Horner: p = p * 2^MD + a * digit). The product
// is known to fit WA bits (the kernel checks bound j * dy), so p is kept modulo 2^WA.
// Latency: ND = ceil(WJ / MD) cycles from the start cycle (which does the first digit);
// `fin` is high in the cycle after the last digit, when p is valid. Each cycle uses one
// WA x MD product (DSP blocks).
module ms_nmul #(
    parameter WA = 128,  // wide operand and product bits
    parameter WJ = 20,   // narrow operand bits
    parameter MD = 16    // digit bits
) (
    input  wire          clk,
    input  wire          start,
    input  wire [WA-1:0] a,
    input  wire [WJ-1:0] j,
    output wire          fin,
    output reg  [WA-1:0] p
);
    localparam ND  = (WJ + MD - 1) / MD;
    localparam WJP = ND * MD;
    reg [WJP-1:0] jr;       // digits not yet used, at the top
    wire          busy;     // a digit after the first
    ms_steps #(.N(ND - 1)) u_steps (.clk(clk), .start(start), .busy(busy), .fin(fin));
    reg [WJP-1:0] jx;       // j zero-extended to whole digits
    always @(*) begin
        jx = {WJP{1'b0}};
        jx[WJ-1:0] = j;
    end
    wire [WJP-1:0] src   = start ? jx : jr;
    wire [MD-1:0]  digit = src[WJP-1:WJP-MD];
    /* verilator lint_off UNUSED */  // the product is taken modulo 2^WA
    wire [WA+MD-1:0] part = {{MD{1'b0}}, a} * {{WA{1'b0}}, digit};
    wire [WA+MD-1:0] acc  = {p, {MD{1'b0}}};
    /* verilator lint_on UNUSED */
    wire [WA-1:0]  sum   = (start ? {WA{1'b0}} : acc[WA-1:0]) + part[WA-1:0];
    always @(posedge clk) begin
        if (start || busy) begin
            p  <= sum;
            jr <= src << MD;
        end
    end
endmodule
