// ms_positions: every axis's position counter and Hall latch, read back one axis at a time.
// Per axis, as ms_axis_io kept them (the reference, MEM = 0, for families without
// distributed RAM): a reset clears the position, a write (`wr`, one axis a clock) sets
// it, else a counted STEP rise (`cnt`) moves it by +1 (`up`) or -1; `latch` copies the
// position before this clock's change into the Hall latch.
// MEM = 1 keeps the words in two small memories (distributed RAM: asynchronous
// reads) and per axis only a delta of the rises since its last visit. One axis is visited
// a clock, through one read port of each memory: a write's axis, else the axis a request
// reads back (`rd`: its values are the visit's), else the scanner's, which then waits.
// The visit adds the delta to the word, and writes a Hall latch taken since the last
// visit (held as its delta and whether the position then read as zero) from the same
// word. A reset only marks every word as reading zero. Requests come no faster than one
// in two clocks with the write a clock after its request, so the scanner waits at most
// two clocks in three, an axis is visited within 3K clocks, and its delta stays within
// +-(3K + 1).
module ms_positions #(
    parameter K   = 2,
    parameter LK  = 1,
    parameter MEM = 1,
    parameter W   = 32   // the words' bits (the register map's: 32)
) (
    input  wire          clk,
    input  wire          rst,
    input  wire [K-1:0]  cnt,      // a counted STEP rise
    input  wire [K-1:0]  up,       // its direction: 1 counts up
    input  wire [K-1:0]  latch,    // the Hall latch takes the position
    input  wire [K-1:0]  wr,       // the position is `din` (one axis at a time)
    input  wire [W-1:0]  din,
    input  wire          rd,       // a request: read back axis `ax`
    input  wire [LK-1:0] ax,
    output wire [W-1:0]  rd_pos,
    output wire [W-1:0]  rd_hall
);
    integer i;
    generate
        if (MEM == 0) begin : regs
            reg [W-1:0] pos  [0:K-1];
            reg [W-1:0] hall [0:K-1];
            initial for (i = 0; i < K; i = i + 1) pos[i] = {W{1'b0}};
            always @(posedge clk)
                for (i = 0; i < K; i = i + 1) begin
                    if (latch[i]) hall[i] <= pos[i];
                    if (rst) pos[i] <= {W{1'b0}};
                    else if (wr[i]) pos[i] <= din;
                    else if (cnt[i]) pos[i] <= pos[i] + {{(W-1){!up[i]}}, 1'b1};
                end
            assign rd_pos  = pos[ax];
            assign rd_hall = hall[ax];
            /* verilator lint_off UNUSED */
            wire unused_rd = rd;
            /* verilator lint_on UNUSED */
        end else begin : mem
            // a delta's bits: +-(3K + 1) fits
            localparam WL = $clog2(3 * K + 2) + 1;
            reg [W-1:0]  pw [0:(1<<LK)-1];   // the position words
            reg [W-1:0]  hw [0:(1<<LK)-1];   // the Hall words
            reg [WL-1:0] d  [0:K-1];         // rises since the last visit (two's complement)
            reg [WL-1:0] hd [0:K-1];         // the delta when a pending Hall latch was taken
            reg [K-1:0]  zero, hz, pend;     // the word reads 0; it did at the latch; a latch waits
            reg [LK-1:0] s;                  // the scanner
            localparam integer LAST = K - 1;
            initial begin
                zero = {K{1'b1}};
                pend = {K{1'b0}};
                s = {LK{1'b0}};
                for (i = 0; i < K; i = i + 1) d[i] = {WL{1'b0}};
            end
            // the written axis (one at a time)
            wire [LK-1:0] wa;
            ms_onehot #(.K(K), .LK(LK)) u_wa (.v(wr), .index(wa));
            wire          any_wr = |wr;
            wire [LK-1:0] a      = any_wr ? wa : rd ? ax : s;   // the axis visited
            wire [W-1:0]  base   = zero[a] ? {W{1'b0}} : pw[a];
            wire [W-1:0]  cur    = base + {{(W-WL){d[a][WL-1]}}, d[a]};
            wire [W-1:0]  held   = (hz[a] ? {W{1'b0}} : pw[a]) + {{(W-WL){hd[a][WL-1]}}, hd[a]};
            always @(posedge clk) begin
                pw[a] <= any_wr ? din : cur;
                if (latch[a] || pend[a]) hw[a] <= latch[a] ? cur : held;
            end
            always @(posedge clk) begin
                if (!any_wr && !rd) s <= (s == LAST[LK-1:0]) ? {LK{1'b0}} : s + 1'b1;
                for (i = 0; i < K; i = i + 1) begin
                    if (i[LK-1:0] == a) begin
                        d[i]    <= (rst || any_wr || !cnt[i]) ? {WL{1'b0}}
                                 : up[i] ? {{(WL-1){1'b0}}, 1'b1} : {WL{1'b1}};
                        zero[i] <= rst;
                        pend[i] <= 1'b0;
                    end else begin
                        d[i]    <= rst ? {WL{1'b0}}
                                 : d[i] + (cnt[i] ? (up[i] ? {{(WL-1){1'b0}}, 1'b1} : {WL{1'b1}})
                                                  : {WL{1'b0}});
                        zero[i] <= zero[i] || rst;
                        if (latch[i]) begin
                            hd[i]   <= d[i];
                            hz[i]   <= zero[i];
                            pend[i] <= 1'b1;
                        end
                    end
                end
            end
            assign rd_pos  = cur;
            assign rd_hall = pend[a] ? held : hw[a];
`ifdef FORMAL
            // The definition (MEM = 0's) beside it: every word and delta agree with it at
            // every clock, and so does every readback (formal/positions_props.sv). MUTATE
            // counts axis 0 the wrong way in the definition: the check must then fail.
            reg [W-1:0] f_pos  [0:K-1];
            reg [W-1:0] f_hall [0:K-1];
            reg [K-1:0] f_latched;   // undefined before an axis's first latch
`ifdef MUTATE
            wire [K-1:0] f_up = up ^ {{(K-1){1'b0}}, 1'b1};
`else
            wire [K-1:0] f_up = up;
`endif
            initial begin
                f_latched = {K{1'b0}};
                for (i = 0; i < K; i = i + 1) f_pos[i] = {W{1'b0}};
            end
            always @(posedge clk)
                for (i = 0; i < K; i = i + 1) begin
                    if (latch[i]) f_hall[i] <= f_pos[i];
                    if (latch[i]) f_latched[i] <= 1'b1;
                    if (rst) f_pos[i] <= {W{1'b0}};
                    else if (wr[i]) f_pos[i] <= din;
                    else if (cnt[i]) f_pos[i] <= f_pos[i] + {{(W-1){!f_up[i]}}, 1'b1};
                end
            always @(*) begin
                for (i = 0; i < K; i = i + 1) begin
                    assert(f_pos[i] == (zero[i] ? {W{1'b0}} : pw[i]) + {{(W-WL){d[i][WL-1]}}, d[i]});
                    if (f_latched[i])
                        assert(f_hall[i] == (pend[i] ? (hz[i] ? {W{1'b0}} : pw[i])
                                                       + {{(W-WL){hd[i][WL-1]}}, hd[i]} : hw[i]));
                end
                if (rd && !any_wr && {1'b0, ax} < K) begin
                    assert(rd_pos == f_pos[ax]);
                    if (f_latched[ax]) assert(rd_hall == f_hall[ax]);
                end
            end
`endif
        end
    endgenerate
endmodule
