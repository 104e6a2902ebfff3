// ms_fifo: one axis's FIFO of periods (first-word fall-through), depth 2^LD.
module ms_fifo #(
    parameter W  = 24,
    parameter LD = 4
) (
    input  wire         clk,
    input  wire         clear,
    input  wire         push,
    input  wire [W-1:0] din,
    input  wire         pop,
    output wire [W-1:0] dout,
    output wire         empty,
    output wire         full,
    output wire         afull    // one entry short of full
);
    reg [W-1:0] mem [0:(1<<LD)-1];
    reg [LD:0]  wp;
    reg [LD:0]  rp;
    initial begin
        wp = {(LD+1){1'b0}};
        rp = {(LD+1){1'b0}};
    end
    assign dout  = mem[rp[LD-1:0]];
    assign empty = (wp == rp);
    assign full  = (wp == {~rp[LD], rp[LD-1:0]});
    wire [LD:0] wp1 = wp + 1'b1;
    assign afull = (wp1 == {~rp[LD], rp[LD-1:0]});
    always @(posedge clk) begin
        if (push) mem[wp[LD-1:0]] <= din;
    end
    always @(posedge clk) begin
        if (clear) begin
            wp <= {(LD+1){1'b0}};
            rp <= {(LD+1){1'b0}};
        end else begin
            if (push) wp <= wp + 1'b1;
            if (pop)  rp <= rp + 1'b1;
        end
    end
endmodule
