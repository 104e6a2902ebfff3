// ms_debounce: a level is accepted once the (synchronized) input has held it for `ticks`
// consecutive clocks (0 and 1 both mean the next clock); shorter glitches are never
// accepted. `ticks` is taken while the input equals the accepted level (a change of it
// applies from the next agreeing clock).
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
    // clocks the input must still differ from q, the current one included: a down counter
    // and a test of its high bits instead of an adder and a comparison against `ticks`
    reg [W-1:0] left;
    initial begin
        q = 1'b0;
        rise = 1'b0;
        left = {W{1'b1}};   // before any reset: the longest wait, never a glitch
    end
    wire flip = (d != q) && (left[W-1:1] == {(W-1){1'b0}});
    assign accept = !rst && flip && d;
    always @(posedge clk) begin
        rise <= 1'b0;
        if (rst) begin
            q    <= d;   // take the level at reset without an edge
            left <= ticks;
        end else if (d == q || flip) begin
            if (flip) begin
                q    <= d;
                rise <= d;
            end
            left <= ticks;
        end else begin
            left <= left - 1'b1;
        end
    end
endmodule
