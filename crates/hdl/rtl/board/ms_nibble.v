// ms_nibble: one nibble of the stream code (multistep_core::stream, docs/HDL.md
// "Streamed moves"), combinational: whether it ends a period, and that period. Nibbles,
// low first: 0 pad; 1-13 the previous period + (n - 7); 14 + 2 nibbles: + a signed 8-bit
// change; 15 + 6 nibbles: the period itself. `esc` is the code being read (0: a new one,
// 1: a change, 2: a period), `got` its nibbles after the first so far, `acc` those
// nibbles, shifted in at the top; esc_n, got_n, acc_n are the three after a nibble that
// does not end a period.
module ms_nibble (
    input  wire [3:0]  n,
    input  wire [1:0]  esc,
    input  wire [2:0]  got,
    input  wire [19:0] acc,
    input  wire [24:0] prev,
    output reg         done,
    output reg  [24:0] p,
    output wire [1:0]  esc_n,
    output wire [2:0]  got_n,
    output wire [19:0] acc_n
);
    assign esc_n = (esc != 2'd0) ? esc : (n == 4'd14) ? 2'd1 : (n == 4'd15) ? 2'd2 : 2'd0;
    assign got_n = (esc == 2'd0) ? 3'd0 : got + 1'b1;
    assign acc_n = (esc == 2'd0) ? 20'd0 : {n, acc[19:4]};
    wire [7:0]  d8    = {n, acc[19:16]};
    // one adder for both relative codes: n - 7 (-7..6) or the signed 8-bit change
    wire [7:0]  dp    = (esc == 2'd1) ? d8 : {4'd0, n} - 8'd7;
    wire [24:0] p_rel = prev + {{17{dp[7]}}, dp};
    wire [24:0] p_abs = {1'b0, n, acc[19:0]};
    always @(*) begin
        done = 1'b0;
        p = p_rel;
        if (esc == 2'd0) begin
            done = (n != 4'd0) && (n != 4'd14) && (n != 4'd15);
        end else if (esc == 2'd1) begin
            done = (got == 3'd1);
        end else begin
            done = (got == 3'd5);
            p = p_abs;
        end
    end
endmodule
