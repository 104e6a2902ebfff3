// ms_steps: the iteration counter of a sequential unit. After the start cycle, `busy` is
// high for N cycles (the unit's iterations); `fin` is high in the cycle after the last
// (right after the start cycle when N = 0), when the unit's result is valid.
module ms_steps #(
    parameter N = 32   // iterations after the start cycle, 0..255
) (
    input  wire clk,
    input  wire start,
    output reg  busy,
    output reg  fin
);
    reg [7:0] cnt;   // iterations left, this one included
    initial begin
        busy = 1'b0;
        fin = 1'b0;
    end
    always @(posedge clk) begin
        if (start) begin
            cnt  <= N[7:0];
            busy <= (N > 0);
            fin  <= (N == 0);
        end else begin
            cnt  <= cnt - {7'd0, busy};
            busy <= busy && (cnt != 8'd1);
            fin  <= busy && (cnt == 8'd1);
        end
    end
endmodule
