// ms_chain: one axis's forward-difference chain for polynomial pieces (scurve: cubic;
// scurve4, seed 003's jerk-continuous curve: quartic), multistep_core::int::chain.
// A piece record (bytes, little-endian, lo first: lo, hi, count, R, D1..D4, M = D1 - K) is
// shifted in a byte a clock; `go` runs it. Each clock is one tick e: at e >= hi the piece's
// remaining steps are all at e; else when R >= 0 step i's edge is e and R takes K; the chain
// advances (R += D1, or R += M = D1 - K with an edge, D1 += D2, M += D2, D2 += D3,
// D3 += D4, e += 1), so an edge costs no extra clock and R's update is one carry chain. It
// stalls while an edge waits for room in the FIFO. R = Q(e) - i*K, Q = 2^S*D^n*p at e's
// upper half tick: R >= 0 is DESIGN.md §1's test p((e + 1/2)/f) >= i.
// The period pushed is the edge less the last edge (the move's first edge against tick 0);
// a period of 0 or wider than WD bits sets fault and pushes nothing.
module ms_chain #(
    parameter WR = 304,
    parameter W1 = 280,
    parameter W2 = 264,
    parameter W3 = 248,
    parameter W4 = 240,
    parameter WM = 304,    // M = D1 - K (WM >= W1)
    parameter WT = 40,     // ticks
    parameter WN = 32,     // steps of a piece
    parameter WD = 24      // a period
) (
    input  wire          clk,
    input  wire          rst,
    input  wire          init,     // a move begins: the last edge is tick 0
    input  wire          halt,
    input  wire          ld,       // a record byte
    input  wire [7:0]    ld_byte,
    input  wire          go,       // the record is complete: run its steps
    input  wire          full,     // the axis's FIFO
    output wire          busy,     // a piece runs (no record byte may be written)
    output wire          push,
    output wire [WD-1:0] period,
    output reg           fault
);
    localparam RB = 2 * WT + WN + WR + W1 + W2 + W3 + W4 + WM;
    reg [RB-1:0] rec;
    // fields of the record (they are the running registers too)
    localparam O_HI = WT, O_N = 2 * WT, O_R = 2 * WT + WN;
    localparam O_1 = O_R + WR, O_2 = O_1 + W1, O_3 = O_2 + W2, O_4 = O_3 + W3, O_M = O_4 + W4;
    wire [WT-1:0] e  = rec[WT-1:0];
    wire [WT-1:0] hi = rec[O_HI +: WT];
    wire [WN-1:0] n  = rec[O_N +: WN];
    wire [WR-1:0] r  = rec[O_R +: WR];
    wire [W1-1:0] d1 = rec[O_1 +: W1];
    wire [W2-1:0] d2 = rec[O_2 +: W2];
    wire [W3-1:0] d3 = rec[O_3 +: W3];
    wire [W4-1:0] d4 = rec[O_4 +: W4];
    wire [WM-1:0] m  = rec[O_M +: WM];
    reg           run;
    reg  [WT-1:0] last;
    initial begin
        run = 1'b0;
        fault = 1'b0;
        at_end = 1'b0;
    end
    assign busy = run;

    reg  at_end;           // e >= hi, kept as a register (off R's carry-chain path)
    wire [WT-1:0] e_n = e + 1'b1;
    wire due    = run && (at_end || !r[WR-1]);
    wire emit   = due && !full && !fault;
    wire adv    = run && !at_end && (!due || emit);
    // sign-extended differences and the K an edge takes
    wire [WR-1:0] d1x = {{(WR-W1){d1[W1-1]}}, d1};
    wire [W1-1:0] d2x = {{(W1-W2){d2[W2-1]}}, d2};
    wire [W2-1:0] d3x = {{(W2-W3){d3[W3-1]}}, d3};
    wire [W3-1:0] d4x = {{(W3-W4){d4[W4-1]}}, d4};
    wire [WM-1:0] d2m = {{(WM-W2){d2[W2-1]}}, d2};
    wire [WR-1:0] mx  = {{(WR-WM){m[WM-1]}}, m};
    wire [WR-1:0] r_n = r + ((emit && !at_end) ? mx : d1x);
    wire [WT-1:0] gap = e - last;
    wire          bad = (e <= last) || (gap[WT-1:WD] != {(WT-WD){1'b0}});
    assign push   = emit && !bad;
    assign period = gap[WD-1:0];

    always @(posedge clk) begin
        if (rst) begin
            run   <= 1'b0;
            fault <= 1'b0;
            last  <= {WT{1'b0}};
        end else if (halt) begin
            run <= 1'b0;
        end else if (init) begin
            run   <= 1'b0;     // a piece left over from a move ended early
            last  <= {WT{1'b0}};
            fault <= 1'b0;
        end else if (!run) begin
            if (ld) rec <= {ld_byte, rec[RB-1:8]};
            if (go) begin
                run    <= (n != {WN{1'b0}});
                at_end <= (e >= hi);
            end
        end else begin
            if (emit) begin
                if (bad) fault <= 1'b1;
                last <= e;
                rec[O_N +: WN] <= n - 1'b1;
                if (n == {{(WN-1){1'b0}}, 1'b1}) run <= 1'b0;
            end
            if (adv) begin
                rec[WT-1:0]  <= e_n;
                at_end       <= (e_n >= hi);
                rec[O_R +: WR] <= r_n;
                rec[O_1 +: W1] <= d1 + d2x;
                rec[O_M +: WM] <= m + d2m;
                rec[O_2 +: W2] <= d2 + d3x;
                rec[O_3 +: W3] <= d3 + d4x;
            end
        end
    end
endmodule
