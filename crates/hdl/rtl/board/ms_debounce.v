// ms_debounce: a level is accepted once the (synchronized) input has held it for `ticks`
// consecutive clocks (0 and 1 both mean the next clock); shorter glitches are never
// accepted.
module ms_debounce #(
    parameter W = 24
) (
    input  wire         clk,
    input  wire         rst,
    input  wire         d,
    input  wire [W-1:0] ticks,
    output reg          q,
    output wire         accept,   // this clock accepts a change from 0 to 1
    output reg          rise      // the clock after
);
    reg [W-1:0] cnt;   // clocks the input has differed from q, minus one
    initial begin
        q = 1'b0;
        rise = 1'b0;
        cnt = {W{1'b0}};
    end
    wire flip = (d != q) && (cnt + 1'b1 >= ticks);
    assign accept = !rst && flip && d;
    always @(posedge clk) begin
        rise <= 1'b0;
        if (rst) begin
            q   <= d;   // take the level at reset without an edge
            cnt <= {W{1'b0}};
        end else if (d == q) begin
            cnt <= {W{1'b0}};
        end else if (flip) begin
            q    <= d;
            rise <= d;
            cnt  <= {W{1'b0}};
        end else begin
            cnt <= cnt + 1'b1;
        end
    end
endmodule
