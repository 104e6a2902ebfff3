// ms_recur at WE = 3, WA = 4, WB = 4, WU = 8, LIMIT = 2, for every input, twice: with
// full-width multiplies (MD = 0, LAT = 5) and digit-serial (MD = 2: t's 4 bits in two
// digits, LAT = 8). With U(e) = (2e + 1)·(2A + B·(2e + 1)) increasing on [lo − 1, hi] (the
// piece's ticks where P increases) and lo <= e0 <= hi, each unit:
//  - answers `done` with the edge: lo <= at <= hi and U(at − 1) < 4M <= U(at);
//  - says `fail` only when the edge is not in [lo, hi] or lies more than LIMIT ticks from
//    e0 (the correction bound: every edge within LIMIT ticks of the prediction is found);
//  - answers LAT + moves clocks after the go, so at most LIMIT + LAT.
// MUTATE claims the walk finds edges LIMIT + 1 ticks away: the check must then fail.
module recur_props (
    input wire                clk,
    input wire                go,
    input wire [2:0]          e0,
    input wire [2:0]          lo,
    input wire [2:0]          hi,
    input wire [3:0]          two_a,
    input wire signed [3:0]   b,
    input wire [7:0]          m4
);
    localparam LIMIT = 2;
`ifdef MUTATE
    localparam REACH = LIMIT + 1;
`else
    localparam REACH = LIMIT;
`endif
    localparam LAT0 = 5, LAT1 = 8;
    wire busy, done, fail, busy1, done1, fail1;
    wire [2:0] at, at1;
    wire [4:0] moves, moves1;
    ms_recur #(.WE(3), .WA(4), .WB(4), .WU(8), .LIMIT(LIMIT)) dut (
        .clk(clk), .rst(1'b0), .go(go), .e0(e0), .lo(lo), .hi(hi), .two_a(two_a), .b(b),
        .m4(m4), .busy(busy), .done(done), .fail(fail), .at(at), .moves(moves));
    ms_recur #(.WE(3), .WA(4), .WB(4), .WU(8), .LIMIT(LIMIT), .MD(2)) dut1 (
        .clk(clk), .rst(1'b0), .go(go), .e0(e0), .lo(lo), .hi(hi), .two_a(two_a), .b(b),
        .m4(m4), .busy(busy1), .done(done1), .fail(fail1), .at(at1), .moves(moves1));

    // the step being answered, as it was asked
    reg signed [7:0]  c_e0 = 0, c_lo = 0, c_hi = 0, c_a2 = 0, c_b = 0;
    reg signed [15:0] c_m = 0;
    reg        [5:0]  clocks = 0;
    reg               asked = 1'b0;
    reg               init = 1'b1;

    function signed [15:0] u_at(input signed [7:0] e);
        u_at = (2 * e + 1) * (c_a2 + c_b * (2 * e + 1));
    endfunction

    wire in_range = u_at(c_lo - 1) < c_m && c_m <= u_at(c_hi);
    wire far_up   = c_e0 + REACH < c_hi && u_at(c_e0 + REACH) < c_m;
    wire far_dn   = c_e0 >= c_lo + REACH && u_at(c_e0 - REACH - 1) >= c_m;

    always @(*) begin
        // one step, asked in the first clock (every input free): a prediction within the
        // ticks where U increases
        assume(go == init);
        if (go) begin
            assume(lo <= e0 && e0 <= hi && two_a[0] == 1'b0);
            assume(2 * $signed({1'b0, two_a}) + 8 * b * $signed({1'b0, lo}) > 0);
            assume(2 * $signed({1'b0, two_a}) + 8 * b * $signed({1'b0, hi}) > 0);
        end
        if (asked && done) begin
            assert(c_lo <= $signed({1'b0, at}) && $signed({1'b0, at}) <= c_hi);
            assert(u_at($signed({1'b0, at}) - 1) < c_m && c_m <= u_at($signed({1'b0, at})));
        end
        if (asked && fail) assert(!in_range || far_up || far_dn);
        if (asked && (done || fail)) assert(clocks == LAT0 + moves && moves <= LIMIT);
        if (asked && busy) assert(clocks < LAT0 + LIMIT);
        assert(!(done && fail));
        if (asked && done1) begin
            assert(c_lo <= $signed({1'b0, at1}) && $signed({1'b0, at1}) <= c_hi);
            assert(u_at($signed({1'b0, at1}) - 1) < c_m && c_m <= u_at($signed({1'b0, at1})));
        end
        if (asked && fail1) assert(!in_range || far_up || far_dn);
        if (asked && (done1 || fail1)) assert(clocks == LAT1 + moves1 && moves1 <= LIMIT);
        if (asked && busy1) assert(clocks < LAT1 + LIMIT);
        assert(!(done1 && fail1));
        cover(asked && done && moves == LIMIT);
        cover(asked && fail && in_range);
        cover(asked && fail && !in_range);
        cover(asked && done && c_b < 0 && moves > 0);
        cover(asked && done1 && moves1 == LIMIT);
        cover(asked && fail1 && in_range);
    end

    always @(posedge clk) begin
        init <= 1'b0;
        if (go && !busy) begin
            c_e0   <= $signed({1'b0, e0});
            c_lo   <= $signed({1'b0, lo});
            c_hi   <= $signed({1'b0, hi});
            c_a2   <= $signed({1'b0, two_a});
            c_b    <= b;
            c_m    <= $signed({1'b0, m4});
            clocks <= 0;
            asked  <= 1'b1;
        end else if (asked) begin
            clocks <= clocks + 1;
        end
    end
endmodule
