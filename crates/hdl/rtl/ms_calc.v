// ms_calc: the shared period calculator, multistep_core::int's per-step kernel. A piece of
// a move is Den (p(tau) - p0) = A tau + B tau^2 (tau in local ticks); the host precomputes
// its StepKernel (mode, y0, dy, k, dv) and the calculator returns the local edge of the
// piece's j-th step, the nearest tick to the exact root (an exact half tick going to the
// earlier one), with Y = A^2 + 4 B M = (Den v)^2:
//     Accel  (B > 0): q = floor((ceil(sqrt Y) + k) / dv)   k = B - A - 1, dv = 2B
//     Decel  (B < 0): q = floor((k - floor(sqrt Y)) / dv)  k = A + b - 1, dv = 2b, b = -B
//     Cruise (B = 0): q = floor(Y / dv)                     Y = 2M + A - 1, dv = 2A
// Sequence, the same for every mode (the root is computed and unused on Cruise, so the
// cycle count never depends on the mode):
//     ND cycles   p = j * dy                 (ms_nmul, one narrow digit of j per cycle)
//     1 cycle     Y = y0 + p  (y0 - p on Decel), load the square root
//     NS cycles   root, rem = isqrt(Y)       (ms_isqrt, RB root bits per cycle)
//     1 cycle     numerator by mode, load the divider
//     NQ cycles   q = num / dv               (ms_div, RB quotient bits per cycle)
// `done` is high for one cycle with q valid, ND + NS + NQ + 2 cycles after `start` (the
// start cycle is the first of the ND). The inputs must hold still until then.
module ms_calc #(
    parameter WY = 128,  // radicand Y (a multiple of 2 RB)
    parameter WK = 68,   // divisor dv (k is WK + 1 bits, two's complement)
    parameter WN = 20,   // step index j
    parameter WQ = 24,   // local edge (a multiple of RB)
    parameter RB = 2,    // result bits per cycle of the root and the divider
    parameter MD = 16    // multiplier digit bits
) (
    input  wire          clk,
    input  wire          start,
    input  wire [1:0]    mode,   // 0 Accel, 1 Decel, 2 Cruise
    input  wire [WY-1:0] y0,
    input  wire [WY-1:0] dy,
    input  wire [WK:0]   k,
    input  wire [WK-1:0] dv,
    input  wire [WN-1:0] j,
    output wire          done,
    output wire [WQ-1:0] q
);
    localparam WNU = ((WY > WK + 2) ? WY : WK + 2) + 1;  // numerator, >= every term
    wire decel  = (mode == 2'd1);
    wire cruise = (mode == 2'd2);

    wire          mul_fin;
    wire [WY-1:0] p;
    ms_nmul #(.WA(WY), .WJ(WN), .MD(MD)) u_mul (.clk(clk), .start(start), .a(dy), .j(j),
                                                .fin(mul_fin), .p(p));
    // Y stays valid while p, y0 and mode hold: the divider reads it again on Cruise
    wire [WY-1:0] y = decel ? y0 - p : y0 + p;

    wire            sq_fin;
    wire [WY/2-1:0] root;
    wire [WY/2+1:0] rem;
    ms_isqrt #(.W(WY), .RB(RB)) u_sqrt (.clk(clk), .start(mul_fin), .x(y), .fin(sq_fin),
                                        .q(root), .r(rem));

    reg [WNU-1:0] yx, rx, kx;
    always @(*) begin
        yx = {WNU{1'b0}};
        yx[WY-1:0] = y;
        rx = {WNU{1'b0}};
        rx[WY/2-1:0] = root;
        kx = {WNU{k[WK]}};
        kx[WK:0] = k;
    end
    wire [WNU-1:0] ceil_r = rx + {{(WNU-1){1'b0}}, (rem != {(WY/2+2){1'b0}})};
    wire [WNU-1:0] num    = cruise ? yx : (decel ? kx - rx : ceil_r + kx);
    ms_div #(.WN(WNU), .WD(WK), .WQ(WQ), .RB(RB)) u_div (.clk(clk), .start(sq_fin),
                                                       .num(num), .den(dv), .fin(done),
                                                       .q(q));
endmodule
