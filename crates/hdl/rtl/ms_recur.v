// ms_recur: the exact per-step recurrence's jump and walk (multistep_core::int::recurrence,
// docs/HDL.md "The per-step recurrence"). On a piece P(τ) = A·τ + B·τ² the edge of the step
// with target M is the tick e with U(e − 1) < 4M <= U(e), U(e) = 4·P(e + 1/2) =
// t·(2A + B·t), t = 2e + 1, wherever P increases. From a predicted local edge e0 in
// [lo, hi] (the caller's clamp) the unit computes U(e0) with two multiplies, then walks a
// tick a clock with additions only, on G(e) = U(e) − U(e − 1) = 4A + 8B·e = 4h,
// h = A + 2B·e = A + B·t − B:
//   U(e) < 4M        : e + 1, h += 2B, U += 4h (the new h)
//   U(e) − 4h >= 4M  : e − 1, U −= 4h, h −= 2B
// until neither holds (`done`, `at`), or `fail` when a move would leave [lo, hi] (P may
// not increase at a piece's first and last tick) or would be the (LIMIT + 1)-th: the step
// then takes the closed form. A step takes LAT + `moves` clocks from `go` to done or fail.
// MD = 0 (LAT = 5): B·t, then 2A + B·t, then its two partial products by t's halves,
// then U (each multiply and addition in its own clock: 50 MHz on an ECP5), then the walk.
// MD > 0 (LAT = 2·ND + 4, ND = ceil((WE + 1) / MD) digits of t): one multiplier of a WS-bit
// signed number by an MD-bit digit serves both products, a digit a clock from t's top,
// each product added into the sum the clock after it (Horner: sum·2^MD + product), so a
// device with few DSP blocks (the UP5K's 8 SB_MAC16) holds the unit.
module ms_recur #(
    parameter WE    = 24,   // local tick bits
    parameter WA    = 66,   // 2A (unsigned)
    parameter WB    = 68,   // B (two's complement)
    parameter WU    = 128,  // 4M (unsigned)
    parameter LIMIT = 16,   // most ticks a walk moves (< 32)
    parameter MD    = 0     // 0: full-width multiplies; 1..WE + 1: digit-serial, MD-bit digits
) (
    input  wire                 clk,
    input  wire                 rst,
    input  wire                 go,      // starts a step (while not busy)
    input  wire [WE-1:0]        e0,      // the predicted edge, lo <= e0 <= hi
    input  wire [WE-1:0]        lo,
    input  wire [WE-1:0]        hi,
    input  wire [WA-1:0]        two_a,
    input  wire signed [WB-1:0] b,
    input  wire [WU-1:0]        m4,
    output reg                  busy,
    output reg                  done,    // one clock: `at` is the step's edge
    output reg                  fail,    // one clock: the closed form decides
    output reg  [WE-1:0]        at,      // the edge (local ticks)
    output reg  [4:0]           moves
);
    localparam WT = WE + 1;                           // t = 2e + 1
    localparam WP = WB + WT + 1;                      // B·t, signed
    localparam WS = ((WA + 1 > WP) ? WA + 1 : WP) + 2; // 2A + B·t and h, signed
    localparam WV = ((WS + WT > WU + 1) ? WS + WT : WU + 1) + 2; // U and 4M, signed
    localparam [4:0] LIM = LIMIT[4:0];
    localparam TL = WT / 2;                           // t's low half
    localparam ND = (MD == 0) ? 1 : (WT + MD - 1) / MD; // t's digits (MD > 0)
    localparam MDW = (MD == 0) ? 1 : MD;
    localparam WTD = (MD == 0) ? WT : ND * MD;          // t padded to whole digits
    localparam [4:0] NDC = ND[4:0];
    /* verilator lint_off UNUSED */
    localparam LAT = (MD == 0) ? 5 : 2 * ND + 4;        // clocks from go to U, plus one
    /* verilator lint_on UNUSED */
    localparam [2:0] IDLE = 3'd0, MUL1 = 3'd1, SUM1 = 3'd2, MUL2 = 3'd3, SUM2 = 3'd4,
                     WALK = 3'd5, DIGB = 3'd6, DIGS = 3'd7;
    reg  [2:0]           st;
    reg  [WE-1:0]        e, lo_q, hi_q;
    reg  signed [WB-1:0] b_q;
    reg  [WA-1:0]        a_q;
    reg  signed [WV-1:0] m_q, u;
    reg  signed [WS-1:0] h, s;
    reg  signed [WP-1:0] bt;
    reg  signed [WV-1:0] p_lo, p_hi;   // s·t's partial products
    // digit-serial (MD > 0): t's digits from the top, the product of the last digit and
    // whether there is one, the sum so far, the digits taken
    reg  [WTD-1:0]       tsh;
    reg  signed [WS+MDW:0] prod;
    reg                  pv;
    reg  signed [WV-1:0] acc;
    reg  [4:0]           dc;
    initial begin
        st = IDLE;
        busy = 1'b0;
        done = 1'b0;
        fail = 1'b0;
    end
    wire signed [WT:0]   t   = $signed({1'b0, e, 1'b1});
    wire signed [WS-1:0] b_s  = {{(WS - WB){b_q[WB-1]}}, b_q};
    wire signed [WS-1:0] bt_s = {{(WS - WP){bt[WP-1]}}, bt};
    wire signed [WS-1:0] a2_s = $signed({{(WS - WA){1'b0}}, a_q});
    wire signed [WS-1:0] s0   = a2_s + bt_s;                  // 2A + B·t
    wire signed [WS-1:0] h0   = (a2_s >>> 1) + bt_s - b_s;    // A + B·t − B
    wire signed [WS-1:0] h_up = h + (b_s <<< 1);              // h at e + 1
    wire signed [WV-1:0] g_dn = {{(WV - WS){h[WS-1]}}, h} <<< 2;       // G(e)
    wire signed [WV-1:0] g_up = {{(WV - WS){h_up[WS-1]}}, h_up} <<< 2; // G(e + 1)
    wire signed [WV-1:0] u_dn = u - g_dn;                     // U(e − 1)
    wire                 up   = u < m_q;
    wire                 dn   = u_dn >= m_q;
    // the shared multiplier: B on the first product, 2A + B·t on the second, held in a
    // register loaded as each is known (at go and in SUM1), so no multiplexer lies
    // between a flip-flop and the DSP blocks (their input and the product's sum are the
    // unit's longest path)
    reg  signed [WS-1:0]   mx;
    wire signed [MDW:0]    dig  = $signed({1'b0, tsh[WTD-1:WTD-MDW]});
    wire signed [WV-1:0]   prod_v = {{(WV - WS - MDW - 1){prod[WS+MDW]}}, prod};
    wire signed [WV-1:0]   acc_n  = pv ? (acc <<< MDW) + prod_v : acc;
    wire [WTD-1:0]         t_pad  = {{(WTD - WT){1'b0}}, e, 1'b1};
    always @(posedge clk) begin
        done <= 1'b0;
        fail <= 1'b0;
        if (rst) begin
            st   <= IDLE;
            busy <= 1'b0;
        end else begin
            case (st)
                IDLE: if (go) begin
                    e     <= e0;
                    lo_q  <= lo;
                    hi_q  <= hi;
                    a_q   <= two_a;
                    b_q   <= b;
                    m_q   <= $signed({{(WV - WU){1'b0}}, m4});
                    moves <= 5'd0;
                    busy  <= 1'b1;
                    tsh   <= {{(WTD - WT){1'b0}}, e0, 1'b1};
                    acc   <= {WV{1'b0}};
                    pv    <= 1'b0;
                    dc    <= 5'd0;
                    mx    <= {{(WS - WB){b[WB-1]}}, b};
                    st    <= (MD == 0) ? MUL1 : DIGB;
                end
                // a digit a clock: its product now, added into acc the clock after
                DIGB, DIGS: begin
                    if (MD != 0) prod <= mx * dig;
                    tsh  <= tsh << MDW;
                    pv   <= (dc != NDC);
                    acc  <= acc_n;
                    dc   <= dc + 1'b1;
                    if (dc == NDC) begin
                        if (st == DIGB) begin
                            bt <= acc_n[WP-1:0];
                            st <= SUM1;
                        end else begin
                            u  <= acc_n;
                            st <= WALK;
                        end
                    end
                end
                // (each multiplier only in the MD it serves: synthesis does not see that the
                // other states are never reached)
                MUL1: begin
                    if (MD == 0) bt <= b_q * t;
                    st <= SUM1;
                end
                SUM1: begin
                    s   <= s0;
                    mx  <= s0;
                    h   <= h0;
                    tsh <= t_pad;
                    acc <= {WV{1'b0}};
                    pv  <= 1'b0;
                    dc  <= 5'd0;
                    st  <= (MD == 0) ? MUL2 : DIGS;
                end
                MUL2: begin
                    if (MD == 0) begin
                        p_lo <= s * $signed({1'b0, t[TL-1:0]});
                        p_hi <= s * $signed({1'b0, t[WT-1:TL]});
                    end
                    st   <= SUM2;
                end
                SUM2: begin
                    u  <= p_lo + (p_hi <<< TL);
                    st <= WALK;
                end
                default: begin
                    if (up || dn) begin
                        if ((up ? (e == hi_q) : (e == lo_q)) || moves == LIM) begin
                            fail <= 1'b1;
                            busy <= 1'b0;
                            st   <= IDLE;
                        end else if (up) begin
                            e     <= e + 1'b1;
                            u     <= u + g_up;
                            h     <= h_up;
                            moves <= moves + 1'b1;
                        end else begin
                            e     <= e - 1'b1;
                            u     <= u_dn;
                            h     <= h - (b_s <<< 1);
                            moves <= moves + 1'b1;
                        end
                    end else begin
                        at   <= e;
                        done <= 1'b1;
                        busy <= 1'b0;
                        st   <= IDLE;
                    end
                end
            endcase
        end
    end
endmodule
