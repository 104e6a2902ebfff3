// ms_debounce: a level is accepted once the (synchronized) input has held it for `load`
// strobes of the shared time base (ms_filter_clock: exactly the filter time when every
// clock strobes); shorter glitches are never accepted. `load` is taken while the input
// equals the accepted level (a change of it applies from the next agreeing clock).
module ms_debounce #(
    parameter W = 10
) (
    input  wire         clk,
    input  wire         rst,
    input  wire         d,
    input  wire         strobe,
    input  wire [W-1:0] load,
    output reg          q,
    output wire         begins,   // this clock's input is the first to differ from q
    output wire         accept,   // this clock accepts a change from 0 to 1
    output reg          rise      // the clock after
);
    // strobes the input must still differ from q, the current one included: a down counter
    // and a test of its high bits instead of an adder and a comparison against `load`
    reg [W-1:0] left;
    reg         differed;   // the last clock's input differed from q and was not accepted
    initial begin
        q = 1'b0;
        rise = 1'b0;
        left = {W{1'b1}};   // before any reset: the longest wait, never a glitch
        differed = 1'b0;
    end
    wire differ = (d != q);
    wire flip   = differ && strobe && (left[W-1:1] == {(W-1){1'b0}});
    assign accept = !rst && flip && d;
    assign begins = !rst && differ && !differed;
    always @(posedge clk) begin
        rise     <= 1'b0;
        differed <= !rst && differ && !flip;
        if (rst) begin
            q    <= d;   // take the level at reset without an edge
            left <= load;
        end else if (!differ || flip) begin
            if (flip) begin
                q    <= d;
                rise <= d;
            end
            left <= load;
        end else if (strobe) begin
            left <= left - 1'b1;
        end
    end
endmodule
