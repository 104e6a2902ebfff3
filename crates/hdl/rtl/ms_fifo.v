// ms_fifo: one axis's FIFO of periods (first-word fall-through), depth 2^LD; `afull`: at
// most one free place. With REG = 1 `full` and `afull` are registers holding the same
// flags every clock as comparing the pointers, so no logic lies between them and the
// scheduler or the chain unit that read them: their next values are compared on the
// present pointers and only chosen by push and pop (late signals: pop comes from the
// group's start). REG = 0 compares the pointers (fewer cells, for the small devices).
module ms_fifo #(
    parameter W   = 24,
    parameter LD  = 4,
    parameter REG = 0
) (
    input  wire         clk,
    input  wire         clear,
    input  wire         push,
    input  wire [W-1:0] din,
    input  wire         pop,
    output wire [W-1:0] dout,
    output wire         empty,
    output wire         full,
    output wire         afull
);
    localparam [LD:0] DM1 = (1 << LD) - 1;   // depth - 1
    reg [W-1:0] mem [0:(1<<LD)-1];
    reg [LD:0]  wp;
    reg [LD:0]  rp;
    initial begin
        wp = {(LD+1){1'b0}};
        rp = {(LD+1){1'b0}};
    end
    assign dout  = mem[rp[LD-1:0]];
    assign empty = (wp == rp);
    always @(posedge clk) begin
        if (push) mem[wp[LD-1:0]] <= din;
    end
    generate
        if (REG != 0) begin : g_reg
            // fill levels, now: depth, depth - 1, at least depth - 2
            wire [LD:0] used = wp - rp;
            wire        at_d   = (used == DM1 + 1'b1);
            wire        at_dm1 = (used == DM1);
            wire        ge_dm2 = at_d || at_dm1 ||
                                 (DM1 != {(LD+1){1'b0}} && used == DM1 - 1'b1);
            reg         full_q, afull_q;
            initial begin
                full_q = 1'b0;
                afull_q = (DM1 == {(LD+1){1'b0}});
            end
            assign full  = full_q;
            assign afull = afull_q;
            always @(posedge clk) begin
                if (clear) begin
                    full_q  <= 1'b0;
                    afull_q <= (DM1 == {(LD+1){1'b0}});
                end else begin
                    case ({push, pop})
                        2'b10: begin full_q <= at_dm1; afull_q <= ge_dm2; end
                        2'b01: begin full_q <= 1'b0;   afull_q <= at_d;   end
                        default: begin full_q <= at_d; afull_q <= at_d || at_dm1; end
                    endcase
                end
            end
        end else begin : g_cmp
            wire [LD:0] used = wp - rp;
            assign full  = (wp == {~rp[LD], rp[LD-1:0]});
            assign afull = full || (used == DM1);
        end
    endgenerate
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
