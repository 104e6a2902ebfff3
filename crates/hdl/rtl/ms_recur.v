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
// then takes the closed form. A step takes 5 + `moves` clocks from `go` to done or fail:
// B·t, then 2A + B·t, then its two partial products by t's halves, then U (each
// multiply and addition in its own clock: 50 MHz on an ECP5), then the walk.
module ms_recur #(
    parameter WE    = 24,   // local tick bits
    parameter WA    = 66,   // 2A (unsigned)
    parameter WB    = 68,   // B (two's complement)
    parameter WU    = 128,  // 4M (unsigned)
    parameter LIMIT = 16    // most ticks a walk moves (< 32)
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
    localparam [2:0] IDLE = 3'd0, MUL1 = 3'd1, SUM1 = 3'd2, MUL2 = 3'd3, SUM2 = 3'd4,
                     WALK = 3'd5;
    reg  [2:0]           st;
    reg  [WE-1:0]        e, lo_q, hi_q;
    reg  signed [WB-1:0] b_q;
    reg  [WA-1:0]        a_q;
    reg  signed [WV-1:0] m_q, u;
    reg  signed [WS-1:0] h, s;
    reg  signed [WP-1:0] bt;
    reg  signed [WV-1:0] p_lo, p_hi;   // s·t's partial products
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
                    st    <= MUL1;
                end
                MUL1: begin
                    bt <= b_q * t;
                    st <= SUM1;
                end
                SUM1: begin
                    s  <= s0;
                    h  <= h0;
                    st <= MUL2;
                end
                MUL2: begin
                    p_lo <= s * $signed({1'b0, t[TL-1:0]});
                    p_hi <= s * $signed({1'b0, t[WT-1:TL]});
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
