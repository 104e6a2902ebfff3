// ms_onehot: the number of the set bit of a vector with at most one bit set (a write to
// one of K axes): the OR of the numbers of the set bits, no priority chain; 0 when none is.
module ms_onehot #(
    parameter K  = 2,
    parameter LK = 1
) (
    input  wire [K-1:0]  v,
    output reg  [LK-1:0] index
);
    integer i;
    always @(*) begin
        index = {LK{1'b0}};
        for (i = 0; i < K; i = i + 1)
            if (v[i]) index = index | i[LK-1:0];
    end
endmodule
