// ms_calc: the shared period calculator. For segment (n steps, d ticks, start speed s =
// v0 * 2^F * d with v0 in steps/tick) and step index i (1..n) it returns the segment-local
// edge q (nearest tick to tau_i, below), tau_i the exact root of
//     A*tau^2 + B*tau = C*i,  A = n*2^F - s,  B = s*d,  C = 2^F * d^2
// i.e. t_i = 2i / (v0 + sqrt(v0^2 + 2 a i)) of DESIGN.md section 2 in ticks. The edge is
// the nearest tick, an exact half tick going to the earlier one (the exactness test
// p(e - 1/2) < i <= p(e + 1/2), as crates/core/src/int does): q = ceil(tau_i - 1/2), exact:
//     A > 0: q = floor((ceil(sqrt(X)) - B + A - 1) / 2A)
//     A < 0: q = floor((B + |A| - isqrt(X) - 1) / 2|A|)
//     A = 0: q = floor((2 d i + n - 1) / 2n)                X = B^2 + 4 A C i
// Operation sequence (the Rust reference model `multistep_hdl::model` does the same):
// mul s*d, mul d*d, mul B*B, mul |A|*i, mul |A|i*d^2, mul d*i, isqrt X, div.
module ms_calc #(
    parameter WN  = 20,   // steps per segment
    parameter WD  = 24,   // ticks per segment
    parameter WF  = 8,    // fraction bits of the start speed
    parameter WM  = 57,   // multiplier operand bits (> every operand)
    parameter WX  = 114,  // radicand bits (even, > every term)
    parameter WNU = 60,   // divider numerator bits
    parameter WDE = 34,   // divider denominator bits
    parameter WQ  = 25    // quotient (local edge) bits
) (
    input  wire             clk,
    input  wire             start,
    input  wire [WN-1:0]    n,
    input  wire [WD-1:0]    d,
    input  wire [WD+WF-1:0] s,
    input  wire [WN-1:0]    i,
    output reg              busy,
    output wire [WQ-1:0]    q
);
    localparam WS = WD + WF;
    localparam WA = WS + 1;          // |A| < 2^WA since n*2^F and s are < 2^WS (n <= d)
    localparam WB = WS + WD;
    localparam S_IDLE = 4'd0, S_BD = 4'd1, S_DD = 4'd2, S_BB = 4'd3, S_AI = 4'd4,
               S_AC = 4'd5, S_DI = 4'd6, S_SQ = 4'd7, S_DV = 4'd8;
    reg [3:0] st;
    reg       launched;   // the unit of this state has been started

    // A = n*2^F - s as sign and magnitude
    wire [WA:0] n_sh  = {{(WA+1-WN-WF){1'b0}}, n, {WF{1'b0}}};
    wire [WA:0] s_x   = {{(WA+1-WS){1'b0}}, s};
    wire        aneg  = s_x > n_sh;
    wire        azero = s_x == n_sh;
    wire [WA:0] amag  = aneg ? s_x - n_sh : n_sh - s_x;

    reg [WB-1:0]         b_r;     // B = s d
    reg [2*WD-1:0]       dd_r;    // d^2
    reg [2*WB-1:0]       bb_r;    // B^2
    reg [WA+WN-1:0]      ai_r;    // |A| i
    reg [WA+WN+2*WD-1:0] aidd_r;  // |A| i d^2
    reg [WD+WN-1:0]      di_r;    // d i

    // multiplier operands by state
    reg  [WM-1:0] ma, mb;
    always @(*) begin
        case (st)
            S_BD: begin ma = {{(WM-WS){1'b0}}, s};        mb = {{(WM-WD){1'b0}}, d}; end
            S_DD: begin ma = {{(WM-WD){1'b0}}, d};        mb = {{(WM-WD){1'b0}}, d}; end
            S_BB: begin ma = {{(WM-WB){1'b0}}, b_r};      mb = {{(WM-WB){1'b0}}, b_r}; end
            S_AI: begin ma = {{(WM-WA){1'b0}}, amag[WA-1:0]}; mb = {{(WM-WN){1'b0}}, i}; end
            S_AC: begin ma = {{(WM-WA-WN){1'b0}}, ai_r};  mb = {{(WM-2*WD){1'b0}}, dd_r}; end
            default: begin ma = {{(WM-WD){1'b0}}, d};     mb = {{(WM-WN){1'b0}}, i}; end
        endcase
    end
    wire            mul_busy;
    /* verilator lint_off UNUSED */  // WM has a spare bit, so the top product bits are zero
    wire [2*WM-1:0] mp;
    /* verilator lint_on UNUSED */
    wire            is_mul = (st >= S_BD) && (st <= S_DI);
    ms_mul #(.W(WM)) u_mul (.clk(clk), .start(is_mul && !launched), .a(ma), .b(mb),
                            .busy(mul_busy), .p(mp));

    // radicand X = B^2 +- 4 |A| i C, C = 2^F d^2
    wire [WX-1:0] bb_x  = {{(WX-2*WB){1'b0}}, bb_r};
    wire [WX-1:0] acx   = {{(WX-WA-WN-2*WD-WF-2){1'b0}}, aidd_r, {(WF+2){1'b0}}};
    wire [WX-1:0] x     = aneg ? bb_x - acx : bb_x + acx;
    wire              sq_busy;
    wire [WX/2-1:0]   root;
    wire [WX/2+1:0]   rrem;
    ms_isqrt #(.W(WX)) u_sqrt (.clk(clk), .start(st == S_SQ && !launched), .x(x),
                               .busy(sq_busy), .q(root), .r(rrem));

    // numerator and denominator of the rounded local edge
    wire [WNU-1:0] root_x = {{(WNU-WX/2){1'b0}}, root};
    wire [WNU-1:0] b_x    = {{(WNU-WB){1'b0}}, b_r};
    wire [WNU-1:0] a_x    = {{(WNU-WA-1){1'b0}}, amag};
    wire [WNU-1:0] ceil_x = root_x + {{(WNU-1){1'b0}}, (rrem != {(WX/2+2){1'b0}})};
    wire [WNU-1:0] lin_x  = {{(WNU-WD-WN-1){1'b0}}, di_r, 1'b0} + {{(WNU-WN){1'b0}}, n};
    wire [WNU-1:0] one    = {{(WNU-1){1'b0}}, 1'b1};
    wire [WNU-1:0] num    = azero ? lin_x - one
                                  : (aneg ? b_x + a_x - root_x - one : ceil_x - b_x + a_x - one);
    wire [WDE-1:0] den    = azero ? {{(WDE-WN-1){1'b0}}, n, 1'b0}
                                  : {{(WDE-WA-2){1'b0}}, amag, 1'b0};
    wire dv_busy;
    ms_div #(.WN(WNU), .WD(WDE), .WQ(WQ)) u_div (.clk(clk), .start(st == S_DV && !launched),
                                                 .num(num), .den(den), .busy(dv_busy), .q(q));

    wire unit_busy = mul_busy | sq_busy | dv_busy;
    initial begin
        st = S_IDLE;
        launched = 1'b0;
        busy = 1'b0;
    end
    always @(posedge clk) begin
        if (st == S_IDLE) begin
            launched <= 1'b0;
            if (start) begin
                st   <= S_BD;
                busy <= 1'b1;
            end
        end else if (!launched) begin
            launched <= 1'b1;
        end else if (!unit_busy) begin
            launched <= 1'b0;
            case (st)
                S_BD: b_r    <= mp[WB-1:0];
                S_DD: dd_r   <= mp[2*WD-1:0];
                S_BB: bb_r   <= mp[2*WB-1:0];
                S_AI: ai_r   <= mp[WA+WN-1:0];
                S_AC: aidd_r <= mp[WA+WN+2*WD-1:0];
                S_DI: di_r   <= mp[WD+WN-1:0];
                default: ;
            endcase
            if (st == S_DV) begin
                st   <= S_IDLE;
                busy <= 1'b0;
            end else begin
                st <= st + 4'd1;
            end
        end
    end
endmodule
