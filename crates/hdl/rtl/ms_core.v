// ms_core: K axes sharing one period calculator by time-division multiplexing
// (seed 000 section 1.2, DESIGN.md section 3). Each axis has its pieces in a shared piece
// memory, its own FIFO of periods (a separate memory) and its own pulse unit. Round-robin
// (seed 000): the first axis at or after the one after the last served whose FIFO has room
// and that still owes periods gets the calculator.
//
// Register bus (write-only, synchronous, 32-bit data; status on the output ports):
//   wr_addr = {1'b0, axis[LK], word[5]}: staging word (the axis bits are ignored here;
//             K independent cores use them to pick a core)
//     words 0-3 y0, 4-7 dy (little-endian 32-bit words), 8-10 k (two's complement),
//     11-13 dv, 14 t0, 15 steps, 16 mode (0 Accel, 1 Decel, 2 Cruise)
//   wr_addr = {1'b1, axis[LK], 5'd0}: commit: piece slot data[LS-1:0] of `axis` = staging
//   wr_addr = {1'b1, axis[LK], 5'd1}: axis control: bit 31 = DIR, data[LS-1:0] = last slot
//   wr_addr = {1'b1, *, 5'd2}: start; data bits K-1:0 = the axes of a synchronous group.
//   With the per-step recurrence (RECUR = 1) staging words 17-31 hold its piece fields:
//     17-19 2A, 20-22 B (two's complement), 23-26 4M of the piece's first step, 27-30 4Den
//     (4M's increase a step), 31 hi = D - 1, the last tick a walk may visit (0: the piece
//     takes the closed form for every step; word 31 is cleared by each commit).
// Slots 0..last hold the axis's pieces with steps in order (pieces of 0 steps are not
// loaded). The group's pulse units start together (tick 0) once every member's FIFO is
// full or holds its whole move. Do not write an axis's pieces while busy[axis] is high.
//
// Board controls (tie to 0 when unused, as ms_tdm_top does):
//   halt[a]   the axis stops now: it leaves the calculator, its pulse unit stops (STEP
//              low) and it leaves a pending group; its FIFO is cleared at its next start.
//   divert[a]  from the next period the calculator computes of axis a on, the axis runs
//              the piece in slot div_slot[a] (a stop ramp the host loaded) as its last,
//              that piece's t0 counted from the last edge computed before the divert.
//              Ignored if the axis has no more periods to compute.
//
// Replayed axes (ms_board's ms_stream; tie to 0 when unused):
//   stream[a]  at its start the axis does not take the calculator: its periods come on
//              s_push / s_din while s_more is high (from init_ax[a] on), into the same
//              FIFO and pulse unit; ax_full[a] is that FIFO's full flag.
//   SHARED = 1: s_din's first word is every replayed axis's (one decoder), never pushed
//              in a clock with calc_push (the decoder waits): the FIFOs then share one
//              write-data multiplexer instead of one each.
//
// Timing: one period takes exactly ND + NS + NQ + 5 cycles: select (the piece memory and
// dy's are read), dy into its register, the calculator's ND + NS + NQ + 2, and the FIFO
// write; the next select follows.
// With RECUR = 1 a step after the move's first two, on a piece with hi > 0, is found by
// ms_recur (multistep_core::int::recurrence) from the prediction of the last three periods:
// select, the prediction, ms_recur's LR + 1 + moves and the FIFO write, LR + 4 + moves
// cycles (LR: ms_recur's clocks to U). A walk that fails hands the step to the closed form
// three cycles after its answer, so the step costs the two sums exactly (the core TDM
// model's RecurrenceClocks { jump: LR + 4, tick: 1, closed: ND + NS + NQ + 5 }).
module ms_core #(
    parameter K   = 2,
    parameter LK  = 1,     // axis index bits (>= 1)
    parameter LS  = 2,     // piece slot bits (2^LS pieces per axis)
    parameter LF  = 4,     // FIFO depth 2^LF
    parameter WN  = 20,    // steps per piece
    parameter WD  = 24,    // period (ticks between edges)
    parameter WQ  = 24,    // local edge
    parameter WT  = 27,    // move tick (<= 32)
    parameter WY  = 128,
    parameter WK  = 68,
    parameter RB  = 2,
    parameter MD  = 16,
    parameter AW  = 7,     // 1 + LK + 5
    parameter LUTRAM = 0,  // 1: the family has distributed RAM (ECP5): state there, dy registered
    parameter RECUR = 0,   // 1: the per-step recurrence (ms_recur) beside the closed form
    parameter SHARED = 0,  // 1: one replayed period bus for all axes (above)
    /* verilator lint_off UNUSEDPARAM */  // the recurrence's, unused without it
    parameter MR  = 0,     // ms_recur's multiplier digit bits (0: full width)
    parameter WRA = 56,    // its 2A (unsigned), B (two's complement) and 4M bits: fewer
    parameter WRB = 40,    // than the closed form's (which squares A); the host gives a
    parameter WRU = 80     // piece whose fields do not fit hi = 0
    /* verilator lint_on UNUSEDPARAM */
) (
    input  wire          clk,
    input  wire          wr_en,
    input  wire [AW-1:0] wr_addr,
    /* verilator lint_off UNUSED */
    input  wire [31:0]   wr_data,   // fields use their low bits only
    /* verilator lint_on UNUSED */
    output wire          ready,     // a started group is filled and may go
    output reg           pending,   // a started group waits for go
    input  wire          go,
    input  wire [K-1:0]  halt,
    input  wire [K-1:0]  divert,
    input  wire [K*LS-1:0] div_slot,
    output wire [K-1:0]  step,
    output wire [K-1:0]  dir,
    output wire [K-1:0]  busy,
    output wire [K-1:0]  underrun,
    input  wire [K-1:0]  stream,
    input  wire [K-1:0]  s_push,
    input  wire [K*WD-1:0] s_din,
    input  wire [K-1:0]  s_more,
    output wire [K-1:0]  init_ax,
    output wire [K-1:0]  ax_full,
    output wire          calc_push, // the calculator pushes a period this clock
    output wire [K*WD-1:0] pulse_per, // each pulse unit's period (the one being timed)
    input  wire [LK-1:0] slot_ax,   // an axis whose slot the register map asks for ...
    output wire [LS-1:0] slot_at    // ... its next period's piece slot (without a clock)
);
    // piece word: {mode, steps, t0, dv, k, dy, y0}
    localparam WP  = 2 + WN + WT + WK + (WK + 1) + 2 * WY;
    localparam WST = LS + WN + 2 * WT;   // per-axis state {slot, j, last edge, base}
    // the recurrence's widths: 2A, B, 4M
    localparam WA  = WRA;
    localparam WB  = WRB;
    localparam WU  = WRU;
    localparam WRP = WA + WB + 2 * WU + WQ;   // its piece word {hi, 4Den, 4M0, B, 2A}
    localparam WRS = 3 + 3 * WD + WU;         // its axis state {known, p1, p2, p3, 4M}
    localparam NW  = (RECUR != 0) ? 32 : 17;  // staging words

    // ---- register bus ----
    wire          is_cmd = wr_addr[AW-1];
    wire [4:0]    word   = wr_addr[4:0];
    wire [LK-1:0] wax    = wr_addr[LK+4:5];
    wire          ax_ok  = ({1'b0, wax} < K);
    /* verilator lint_off UNUSED */  // bits of staging words beyond the field widths
    reg [NW*32-1:0] stg;    // staging words 0..NW-1
    /* verilator lint_on UNUSED */
    // one write enable per word: a run-time part-select would synthesize as two shifters
    // the width of the whole staging register
    integer sw;
    // hi (word 31) reads 0 from configuration and after every commit, so a host that
    // writes the first 17 words only gets the closed form, never a stale piece's walk
    initial if (RECUR != 0) stg[32*(NW-1) +: 32] = 32'd0;
    always @(posedge clk) begin
        for (sw = 0; sw < NW; sw = sw + 1)
            if (wr_en && !is_cmd && word == sw[4:0]) stg[32*sw +: 32] <= wr_data;
        if (RECUR != 0 && commit) stg[32*(NW-1) +: 32] <= 32'd0;
    end
    wire [WP-WY-1:0] stg_word = {stg[16*32 +: 2], stg[15*32 +: WN], stg[14*32 +: WT],
                                 stg[11*32 +: WK], stg[8*32 +: WK+1], stg[0 +: WY]};
    wire commit   = wr_en && is_cmd && (word == 5'd0) && ax_ok;
    wire ctl_wr   = wr_en && is_cmd && (word == 5'd1) && ax_ok;
    wire start_wr = wr_en && is_cmd && (word == 5'd2);
    // The host writes an axis's pieces only while it is idle, or slots it is not in (a
    // divert's): a read never meets a write to its own address, so synthesis needs no
    // bypass for that case (on iCE40 a 188-bit register and its multiplexer). The piece
    // is in block RAM on every family (on ECP5 yosys would pick distributed RAM: 1203
    // more logic sites in the 8-axis ULX3S build, docs/HDL.md). dy has a block RAM of its
    // own: the multiplier takes it in the calculator's first cycle, and straight from the
    // block RAM's 5.8 ns clock-to-output that missed 50 MHz on ECP5 (47.87 MHz routed in
    // the 14-axis ULX3S build), so there (LUTRAM = 1) it passes through a register, and on
    // every family the calculator starts two clocks after select (one count of cycles for
    // all). In distributed RAM it cost the 14-axis ULX3S build 1 491 more LUTs.
    (* no_rw_check, ram_style = "block" *)
    reg [WP-WY-1:0] pmem [0:(1<<(LK+LS))-1];
    always @(posedge clk) begin
        if (commit) pmem[{wax, wr_data[LS-1:0]}] <= stg_word;
    end
    reg [LS-1:0] last_slot [0:K-1];
    reg [K-1:0]  dir_r;
    reg [K-1:0]  group;
    reg [K-1:0]  div_req;     // a divert waits for the axis's next computed period
    wire         div_now;     // the period just computed is the last before the ramp

    // ---- scheduler ----
    reg  [K-1:0]   init_pend;
    reg  [K-1:0]   calc_act;
    reg            sel;       // free to select (no period in flight)
    reg            cstart;    // the cycle after select (dy into its register)
    reg  [LK-1:0]  m;         // axis in the calculator
    wire [WST-1:0] cur;       // m's state, read at select
    reg  [WP-WY-1:0] rd;      // m's piece but dy, read at select
    wire [WY-1:0]  rdy;       // its dy
    wire [K-1:0]   fifo_full, fifo_afull, fifo_empty, fifo_push, fifo_pop, running;
    wire [K*WD-1:0] fifo_dout;

    // the index of a one-hot vector's bit (an OR of the set bits' indices)
    function [LK-1:0] index_of(input [K-1:0] v);
        integer o;
        begin
            index_of = {LK{1'b0}};
            for (o = 0; o < K; o = o + 1)
                if (v[o]) index_of = index_of | o[LK-1:0];
        end
    endfunction
    // lowest axis with a pending start (initialised first, one per cycle): the lowest set
    // bit, x & -x (a carry chain), and its index
    wire          ini_any = |init_pend;
    wire [K-1:0]  ini_bit = init_pend & (~init_pend + 1'b1);
    wire [LK-1:0] ini_ax  = index_of(ini_bit);
    // The pick is a register: the first eligible axis from rr on, wrapping, found in the
    // clock before from what calc_act, init_pend and the FIFOs' fill will be at the clock
    // edge, so a select's read addresses start at flip-flops (the pick over K axes and the
    // memories' addresses were one path: 41.49 MHz at K = 32 on the ECP5-25F). rr is taken
    // as it is: after a select, the clock that follows selects nothing. So it picks the
    // axis the search over the registers would pick whenever a select can happen. The
    // search: the lowest eligible axis at or above rr (rr_mask, the axes from rr on), else
    // the lowest eligible one; lowest set bits as x & -x. The register holds the pick
    // one-hot; its index is decoded after it, in the select's path (short: it starts at
    // the register).
    reg  [K-1:0]  rr_mask;
    reg           pick_any;
    reg  [K-1:0]  pick_bit;
    wire [K-1:0]  calc_act_d, init_pend_d, full_d;
    wire [K-1:0]  elig_d  = calc_act_d & ~full_d & ~init_pend_d;
    wire [K-1:0]  from_rr = elig_d & rr_mask;
    wire [K-1:0]  cand    = (|from_rr) ? from_rr : elig_d;
    always @(posedge clk) begin
        pick_any <= |elig_d;
        pick_bit <= cand & (~cand + 1'b1);
    end
    wire [LK-1:0] pick = index_of(pick_bit);
    wire do_init = sel && ini_any;
    wire do_sel  = sel && !ini_any && pick_any;
    wire [LS-1:0] pick_slot;   // the picked axis's slot, read without a clock (below)

    // dy's memory, read at select, and on ECP5 the register the multiplier reads it from
    generate
        if (LUTRAM != 0) begin : dy_reg
            (* no_rw_check, ram_style = "block" *)
            reg [WY-1:0] dmem [0:(1<<(LK+LS))-1];
            reg [WY-1:0] q, qr;
            always @(posedge clk) begin
                if (commit) dmem[{wax, wr_data[LS-1:0]}] <= stg[4*32 +: WY];
                if (do_sel) q <= dmem[{pick, pick_slot}];
                if (cstart) qr <= q;
            end
            assign rdy = qr;
        end else begin : dy_direct
            (* no_rw_check *)
            reg [WY-1:0] dmem [0:(1<<(LK+LS))-1];
            reg [WY-1:0] q;
            always @(posedge clk) begin
                if (commit) dmem[{wax, wr_data[LS-1:0]}] <= stg[4*32 +: WY];
                if (do_sel) q <= dmem[{pick, pick_slot}];
            end
            assign rdy = q;
        end
    endgenerate

    // the piece word in the calculator
    wire [1:0]    k_mode  = rd[WP-WY-1:WP-WY-2];
    wire [WN-1:0] k_steps = rd[WP-WY-3:WP-WY-2-WN];
    wire [WT-1:0] k_t0    = rd[WY+2*WK+WT:WY+2*WK+1];
    wire [WK-1:0] k_dv    = rd[WY+2*WK:WY+WK+1];
    wire [WK:0]   k_k     = rd[WY+WK:WY];
    wire [WY-1:0] k_dy    = rdy;
    wire [WY-1:0] k_y0    = rd[WY-1:0];
    wire [LS-1:0] c_slot  = cur[WST-1:WST-LS];
    wire [WN-1:0] c_j     = cur[WN+2*WT-1:2*WT];
    wire [WT-1:0] c_last  = cur[2*WT-1:WT];
    wire [WT-1:0] c_base  = cur[WT-1:0];   // 0, or the last edge before a divert
    // the closed form, or the recurrence's answer (RECUR = 1, below)
    wire          c_start, c_done, r_done;
    wire [WQ-1:0] c_q, r_at;
    ms_calc #(.WY(WY), .WK(WK), .WN(WN), .WQ(WQ), .RB(RB), .MD(MD)) u_calc (
        .clk(clk), .start(c_start), .mode(k_mode), .y0(k_y0), .dy(k_dy), .k(k_k), .dv(k_dv),
        .j(c_j), .done(c_done), .q(c_q));
    wire          done = c_done || r_done;
    wire [WQ-1:0] q    = r_done ? r_at : c_q;
    reg [WT-1:0] qx;
    always @(*) begin
        qx = {WT{1'b0}};
        qx[WQ-1:0] = q;
    end
    // From block RAM the piece's fields come late in the cycle (5.8 ns on ECP5), so what
    // the period's end needs of t0 and the step count is registered in the calculator's
    // first cycle; both hold until `done` (the inputs do not change while it runs).
    reg [WT-1:0]   base_t0;   // c_base + k_t0
    reg            last_j;    // the period is the piece's last
    reg            last_s;    // the piece is the move's last (only a divert changes that,
                              // at the period's end)
    always @(posedge clk) begin
        if (cstart) begin
            base_t0 <= c_base + k_t0;
            last_j  <= (c_j + 1'b1 == k_steps);
            last_s  <= (c_slot == last_slot[m]);
        end
    end
    wire [WT-1:0]  edge_t   = base_t0 + qx;
    /* verilator lint_off UNUSED */  // a period is < 2^WD (checked on the host)
    wire [WT-1:0]  period   = edge_t - c_last;
    /* verilator lint_on UNUSED */
    wire [WN-1:0]  j_next   = c_j + 1'b1;

    // ---- the per-step recurrence (RECUR = 1) ----
    generate
        if (RECUR != 0) begin : recur
            // its piece fields, beside the piece memory (block RAM, as it is), and each
            // axis's last periods and next 4M; both read at select into registers
            (* no_rw_check, ram_style = "block" *)
            reg [WRP-1:0] rpmem [0:(1<<(LK+LS))-1];
            reg [WRS-1:0] rsmem [0:K-1];
            reg [WRP-1:0] rp;
            reg [WRS-1:0] rs;
            wire [WA-1:0]        r_2a   = rp[WA-1:0];
            wire signed [WB-1:0] r_b    = rp[WA+WB-1:WA];
            wire [WU-1:0]        r_m40  = rp[WA+WB+WU-1:WA+WB];
            wire [WU-1:0]        r_4den = rp[WA+WB+2*WU-1:WA+WB+WU];
            wire [WQ-1:0]        r_hi   = rp[WRP-1:WRP-WQ];
            wire [2:0]           known  = rs[WRS-1:WRS-3];   // edges so far, up to 4
            wire [WD-1:0]        p1 = rs[WU+3*WD-1:WU+2*WD];  // the last period
            wire [WD-1:0]        p2 = rs[WU+2*WD-1:WU+WD];
            wire [WD-1:0]        p3 = rs[WU+WD-1:WU];
            wire [WU-1:0]        r_m4   = rs[WU-1:0];
            // whether the piece walks (hi > 0), in a memory of its own read into a
            // flip-flop at select: from the block RAM's output it would be the start of
            // the closed form's path (40.29 MHz on the 8-axis ULX3S)
            reg rok [0:(1<<(LK+LS))-1];
            reg rok_q;
            // the cstart cycle predicts, the next one starts the walk
            wire use_r = rok_q && (known >= 3'd2);
            // the prediction (int::recurrence's EdgeHistory::predict): with four edges the
            // last plus floor((4(p1 + p2) + 6(p1 - p3)) / 8), the mean of the last two
            // periods plus 1.5 times their mean second difference; else the last period
            localparam WG = WT + 4;
            wire signed [WG-1:0] sp1 = $signed({{(WG-WD){1'b0}}, p1});
            wire signed [WG-1:0] sp2 = $signed({{(WG-WD){1'b0}}, p2});
            wire signed [WG-1:0] sp3 = $signed({{(WG-WD){1'b0}}, p3});
            wire signed [WG-1:0] d4  = ((sp1 <<< 3) + (sp1 <<< 1) + (sp2 <<< 2)
                                        - (sp3 <<< 2) - (sp3 <<< 1)) >>> 3;
            wire signed [WG-1:0] delta  = (known >= 3'd4) ? d4 : sp1;
            // the last edge from the piece's origin (the state's ticks are the move's)
            wire signed [WG-1:0] last_l = $signed({4'b0, c_last}) - $signed({4'b0, c_base})
                                        - $signed({4'b0, k_t0});
            reg signed [WG-1:0] g_d, g_l;
            reg                 rgo, fa1, fa2, fa3;
            reg                 cgo_c;  // the closed form starts (the clock after cstart)
            reg [WU-1:0]        m4_q;   // the step's 4M
            reg [WU-1:0]        m4_n;   // the next step's, settled long before done
            wire                r_fail;
            initial begin
                rgo = 1'b0;
                cgo_c = 1'b0;
                fa1 = 1'b0;
                fa2 = 1'b0;
                fa3 = 1'b0;
            end
            always @(posedge clk) begin
                rgo   <= cstart && use_r;
                cgo_c <= cstart && !use_r;
                if (cstart) begin
                    g_d  <= delta;
                    g_l  <= last_l;
                    m4_q <= (c_j == {WN{1'b0}}) ? r_m40 : r_m4;
                end
                m4_n <= m4_q + r_4den;
                fa1  <= r_fail;
                fa2  <= fa1;
                fa3  <= fa2;
            end
            // the walk's first tick: the prediction clamped to [1, hi]
            wire signed [WG-1:0] guess = g_l + g_d;
            wire signed [WG-1:0] hi_s  = $signed({{(WG-WQ){1'b0}}, r_hi});
            wire [WQ-1:0] e0 = (guess < $signed({{(WG-1){1'b0}}, 1'b1})) ? {{(WQ-1){1'b0}}, 1'b1}
                             : (guess > hi_s) ? r_hi : guess[WQ-1:0];
            /* verilator lint_off PINCONNECTEMPTY */
            ms_recur #(.WE(WQ), .WA(WA), .WB(WB), .WU(WU), .LIMIT(16), .MD(MR)) u_recur (
                .clk(clk), .rst(1'b0), .go(rgo), .e0(e0), .lo({{(WQ-1){1'b0}}, 1'b1}),
                .hi(r_hi), .two_a(r_2a), .b(r_b), .m4(m4_q), .busy(), .done(r_done),
                .fail(r_fail), .at(r_at), .moves());
            /* verilator lint_on PINCONNECTEMPTY */
            // a failed walk's step takes the closed form three cycles after the answer, so
            // it costs the jump, the ticks and a closed-form period exactly
            assign c_start = cgo_c || fa3;
            wire [2:0]     known_n = (known == 3'd4) ? known : known + 3'd1;
            wire [WRS-1:0] rs_next = {known_n, period[WD-1:0], p1, p2, m4_n};
            always @(posedge clk) begin
                if (commit) begin
                    rpmem[{wax, wr_data[LS-1:0]}] <= {stg[31*32 +: WQ], stg[27*32 +: WU],
                        stg[23*32 +: WU], stg[20*32 +: WB], stg[17*32 +: WA]};
                    rok[{wax, wr_data[LS-1:0]}] <= (stg[31*32 +: WQ] != {WQ{1'b0}});
                end
                if (do_init) rsmem[ini_ax] <= {WRS{1'b0}};
                else if (done) rsmem[m] <= rs_next;
                if (do_sel) begin
                    rp    <= rpmem[{pick, pick_slot}];
                    rok_q <= rok[{pick, pick_slot}];
                    rs    <= rsmem[pick];
                end
            end
        end else begin : closed
            // the calculator starts the clock after cstart (dy's register)
            reg cgo;
            initial cgo = 1'b0;
            always @(posedge clk) cgo <= cstart;
            assign c_start = cgo;
            assign r_done  = 1'b0;
            assign r_at    = {WQ{1'b0}};
        end
    endgenerate
    wire           piece_end = last_j;
    wire           mov_end  = piece_end && last_s;
    assign         div_now  = done && div_req[m] && !mov_end;
    wire [WST-1:0] next_st  = div_now ? {div_slot[m*LS +: LS], {WN{1'b0}}, edge_t, edge_t}
                            : piece_end ? {c_slot + 1'b1, {WN{1'b0}}, edge_t, c_base}
                                        : {c_slot, j_next, edge_t, c_base};
    always @(posedge clk) begin
        if (ctl_wr) begin
            last_slot[wax] <= wr_data[LS-1:0];
            dir_r[wax]     <= wr_data[31];
        end else if (div_now) begin
            last_slot[m] <= div_slot[m*LS +: LS];
        end
    end
    // Each axis's state {slot, j, last edge, base}: written at its init and as the
    // calculator finishes its period, read at select into a register. The select's piece
    // address needs the slot before that read. On ECP5 the state is distributed RAM, read
    // there without a clock too (a block RAM's output would come too late for the
    // calculator's first cycle, which takes j, at 50 MHz). The iCE40 has no distributed
    // RAM: its state is block RAM, read only at select (flip-flops and their K-wide
    // multiplexer cost 70 LUT4 an axis), with the slots in a small memory of their own.
    wire           st_we = do_init || done;
    wire [LK-1:0]  st_wa = do_init ? ini_ax : m;
    wire [WST-1:0] st_wd = do_init ? {WST{1'b0}} : next_st;
    always @(posedge clk)
        if (do_sel) rd <= pmem[{pick, pick_slot}];
    generate
        if (LUTRAM != 0) begin : st_lutram
            (* no_rw_check, ram_style = "distributed" *)
            reg [WST-1:0] st_mem [0:K-1];
            reg [LS-1:0]  slot_mem [0:K-1];   // the slots again, read at slot_ax
            reg [WST-1:0] sq;
            always @(posedge clk) begin
                if (st_we) begin
                    st_mem[st_wa]   <= st_wd;
                    slot_mem[st_wa] <= st_wd[WST-1:WST-LS];
                end
                if (do_sel) sq <= st_mem[pick];
            end
            assign cur       = sq;
            assign pick_slot = st_mem[pick][WST-1:WST-LS];
            assign slot_at   = slot_mem[slot_ax];
        end else begin : st_block
            (* no_rw_check, ram_style = "block" *)
            reg [WST-1:0] st_mem [0:K-1];
            reg [LS-1:0]  slot_mem [0:K-1];
            reg [WST-1:0] sq;
            always @(posedge clk) begin
                if (st_we) begin
                    st_mem[st_wa]   <= st_wd;
                    slot_mem[st_wa] <= st_wd[WST-1:WST-LS];
                end
                if (do_sel) sq <= st_mem[pick];
            end
            assign cur       = sq;
            assign pick_slot = slot_mem[pick];
            assign slot_at   = slot_mem[slot_ax];
        end
    endgenerate
    initial begin
        m = {LK{1'b0}};
        rr_mask = {K{1'b1}};
        pick_bit = {K{1'b0}};
        pick_any = 1'b0;
        init_pend = {K{1'b0}};
        calc_act = {K{1'b0}};
        sel = 1'b1;
        cstart = 1'b0;
        pending = 1'b0;
        group = {K{1'b0}};
        div_req = {K{1'b0}};
    end
    wire [K-1:0] m_bit   = {{(K-1){1'b0}}, 1'b1} << m;
    // the next values of the scheduler's registers (the pick above is found from them)
    assign calc_act_d = (calc_act | (do_init ? ini_bit & ~stream : {K{1'b0}}))
                      & ~((done && mov_end) ? m_bit : {K{1'b0}}) & ~halt;
    assign init_pend_d = (start_wr ? init_pend | wr_data[K-1:0] : init_pend)
                       & ~(do_init ? ini_bit : {K{1'b0}}) & ~halt;
    // full after this clock, or one clock late: full now, or one short of full and pushed.
    // A pop is not looked at (the scheduler sees its room a clock later), so the pulse
    // unit's edge test does not lead into the pick over K axes (46.1 MHz at K = 32 on the
    // ECP5-25F when it did). Never less full than the FIFO: it cannot overflow. A FIFO
    // cleared at an axis's start is empty.
    assign full_d = (fifo_full | (fifo_afull & fifo_push))
                  & ~(do_init ? ini_bit : {K{1'b0}});
    always @(posedge clk) begin
        cstart <= do_sel;
        if (do_sel) begin
            sel <= 1'b0;
            m   <= pick;
        end else if (done) begin
            sel <= 1'b1;
        end
        // the axes above the one picked (none after the last: then every axis)
        if (do_sel) rr_mask <= ~((pick_bit << 1) - 1'b1);
        calc_act  <= calc_act_d;
        init_pend <= init_pend_d;
        div_req  <= (div_req | (divert & calc_act)) & ~(done ? m_bit : {K{1'b0}})
                  & ~halt & ~(do_init ? ini_bit : {K{1'b0}});
        if (start_wr) begin
            group     <= wr_data[K-1:0] & ~halt;
            pending   <= 1'b1;
        end else begin
            group <= group & ~halt;
            if (go || (group & ~halt) == {K{1'b0}}) pending <= 1'b0;
        end
    end
    assign ready = pending &&
                   ((group & (init_pend | ((calc_act | s_more) & ~fifo_full))) == {K{1'b0}});
    assign init_ax = do_init ? ini_bit : {K{1'b0}};
    assign ax_full = fifo_full;

    // ---- per axis: FIFO and pulse unit ----
    assign calc_push = done;
    // SHARED = 1: the replay decoder never pushes in the calculator's clock (its `hold`)
    /* verilator lint_off UNUSED */  // with SHARED = 0 unused
    wire [WD-1:0] din_shared = done ? period[WD-1:0] : s_din[WD-1:0];
    /* verilator lint_on UNUSED */
    genvar a;
    generate
        for (a = 0; a < K; a = a + 1) begin : axis
            // a replayed axis never has the calculator, so the two pushes never collide
            wire          push = (done && m_bit[a]) || s_push[a];
            assign fifo_push[a] = push;
            wire [WD-1:0] din  = (SHARED != 0) ? din_shared
                               : s_push[a] ? s_din[a*WD +: WD] : period[WD-1:0];
            ms_fifo #(.W(WD), .LD(LF)) u_fifo (
                .clk(clk), .clear(do_init && ini_bit[a]),
                .push(push), .din(din),
                .pop(fifo_pop[a]), .dout(fifo_dout[a*WD +: WD]),
                .empty(fifo_empty[a]), .full(fifo_full[a]), .afull(fifo_afull[a]));
            ms_pulse #(.WP(WD)) u_pulse (
                .clk(clk), .go(go && group[a]), .din(fifo_dout[a*WD +: WD]),
                .empty(fifo_empty[a]), .more(calc_act[a] || s_more[a]),
                .arrive(push), .ain(din), .pop(fifo_pop[a]),
                .halt(halt[a]), .clear(do_init && ini_bit[a]), .step(step[a]),
                .running(running[a]), .underrun(underrun[a]), .period(pulse_per[a*WD +: WD]));
        end
    endgenerate
    assign dir  = dir_r;
    assign busy = init_pend | calc_act | s_more | running | (pending ? group : {K{1'b0}});
endmodule
