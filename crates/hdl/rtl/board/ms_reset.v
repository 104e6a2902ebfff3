// ms_reset: the board's synchronous reset. High for 16 clocks after configuration (the
// power-on reset: FPGA flip-flops start from their initial values) and while rst_n_async
// is low, then two more clocks (its release is synchronized; its assertion is too, so a
// glitch shorter than a clock may be missed — tie it to 1 when unused).
module ms_reset (
    input  wire clk,
    input  wire rst_n_async,
    output wire rst
);
    wire       ext_n;
    reg  [4:0] por;
    initial por = 5'd0;
    ms_sync #(.W(1), .INIT(0)) u_sync (.clk(clk), .d(rst_n_async), .q(ext_n));
    always @(posedge clk) begin
        if (!ext_n) por <= 5'd0;
        else if (!por[4]) por <= por + 1'b1;
    end
    assign rst = !por[4];
endmodule
