// ms_replay: the replay units of K axes with one decoder (docs/HDL.md "Streamed moves"):
// each axis keeps what ms_stream keeps but the decoder, the buffer's pointers and the step
// count (ms_replay_axis); the axes' byte buffers are one block RAM (2^LB bytes each); their
// pointers, last periods and high nibbles still to decode are small memories, their step
// counts two more (ms_step_counts); and one decoder serves the axes in turn.
// A turn picks the next axis with a nibble to decode, a period to go and FIFO room, and
// decodes from where the axis stands (ms_nibble) up to one whole period; that period and
// the axis's new place are taken together, the period pushed the clock after (as
// ms_stream's) unless the calculator pushes in that clock (`hold`, never two clocks in a
// row: the FIFOs share one write-data bus), then the clock after. A turn that runs out of
// bytes, or whose axis stops, leaves the axis as it was: it decodes the same nibbles
// again once more bytes are there. A turn takes at most 14 clocks (the pick, 5 fetches,
// 8 nibbles: a 7-nibble code after a pad), so an axis with bytes and FIFO room has its
// next period within a turn of each axis, and a clock (multistep_core::tdm::stream::
// DECODE_TURN allows 16).
// A bulk frame goes to axis bax (bsel: a valid axis); the host side and the registers
// are the same as with K ms_stream units, but the free bytes are those of one axis and
// whether the open frame fits is one flag.
// The pointers: each is written at one axis a clock, the write pointer as a frame is
// committed, the read pointer as the decoder takes a period; an arm or a reset only marks
// an axis's pointers as reading 0 (flags in ms_replay_axis). Each memory has two copies:
// one read at the axis served, one at the axis looked at, which is the committed frame's
// in a commit's clock, the request's (rax) in a request's (rd), else the open frame's
// (bax): the link never opens a frame or writes its bytes in a request's clock or a
// commit's (the clock after the frame's request), nor asks in a commit's.
module ms_replay #(
    parameter K  = 2,
    parameter LK = 1,
    parameter WD = 24,
    parameter LB = 9
) (
    input  wire                clk,
    input  wire                rst,
    input  wire [K-1:0]        arm,
    input  wire [31:0]         arm_steps,
    input  wire [K-1:0]        retarget_in,
    input  wire                bsel,      // the open bulk frame is for an axis here
    input  wire [LK-1:0]       bax,       // that axis
    input  wire                bopen,     // a bulk frame for bax begins, blen bytes
    input  wire [7:0]          blen,
    input  wire                bwr,
    input  wire [7:0]          bidx,
    input  wire [7:0]          bbyte,
    input  wire [K-1:0]        bcommit,
    input  wire [K-1:0]        init,
    input  wire [K-1:0]        halt,
    input  wire [K-1:0]        full,
    input  wire                hold,      // the core's calculator pushes a period now
    input  wire                rd,        // a request (never with bopen, bwr or bcommit) ...
    input  wire [LK-1:0]       rax,       // ... for this axis: its free bytes are read back
    output wire [K-1:0]        armed,
    output reg                 bok,       // the open bulk frame fits bax's buffer
    output wire [LB:0]         free,      // rax's free bytes (in rd's clock)
    output wire [K-1:0]        push,
    output wire [WD-1:0]       period,
    output wire [K-1:0]        more,
    output wire [K-1:0]        fault
);
    localparam [1:0] S_PICK = 2'd0, S_FETCH = 2'd1, S_DEC = 2'd2;

    // ---- the axes ----
    wire [K-1:0] a_push, wz_v, rz_v, hp_v, fresh_v, ready_v, live_v, serve, left_nz_v, retarget_v;
    reg  [LK-1:0] s;           // the axis served
    reg  [LB:0]   wr;          // its next byte to fetch
    reg           lo;          // the fetched byte's low nibble is next (else nh)
    reg  [3:0]    nh;          // the next nibble when !lo: a byte's high nibble
    reg  [1:0]    st;
    reg  [1:0]    esc;
    reg  [2:0]    got;
    reg  [19:0]   acc;
    reg  [24:0]   pmem [0:(1<<LK)-1];   // each axis's last period (valid unless fresh)
    reg  [24:0]   pm;          // pmem[s], read every clock: the served axis's from its pick
    reg  [7:0]    rdata;
    reg           pv_ok;       // pv holds a period of axis pv_ax, pushed now
    reg  [24:0]   pv;
    reg  [LK-1:0] pv_ax;
    wire          done_p;      // the decoder's nibble ends a period: p
    wire [24:0]   p;
    wire          pbad = (pv == 25'd0) || (pv[24:WD] != {(25-WD){1'b0}});
    initial begin
        st = S_PICK;
        s = {LK{1'b0}};
        pv_ok = 1'b0;
        bok = 1'b0;
    end
    genvar g;
    generate
        for (g = 0; g < K; g = g + 1) begin : ax
            /* verilator lint_off WIDTH */  // the genvar against LK-bit indices
            wire penq = pv_ok && (pv_ax == g);
            /* verilator lint_on WIDTH */
            ms_replay_axis u_axis (
                .clk(clk), .rst(rst), .arm(arm[g]), .arm_steps(arm_steps),
                .retarget_in(retarget_in[g]), .bcommit(bcommit[g]), .init(init[g]),
                .halt(halt[g]), .left_nz(left_nz_v[g]), .serve(serve[g]), .n_hp(lo),
                .pend(penq), .pbad(pbad), .armed(armed[g]), .push(a_push[g]),
                .more(more[g]), .retarget(retarget_v[g]), .fault(fault[g]), .wz(wz_v[g]),
                .rz(rz_v[g]), .hp(hp_v[g]), .fresh(fresh_v[g]), .ready(ready_v[g]),
                .live(live_v[g]));
        end
    endgenerate
    assign period = pv[WD-1:0];
    assign push   = hold ? {K{1'b0}} : a_push;

    // ---- the pointers (distributed RAM, asynchronous reads), read at s and at qax ----
    // the committed frame's axis (one at a time)
    wire [LK-1:0] cax;
    ms_onehot #(.K(K), .LK(LK)) u_cax (.v(bcommit), .index(cax));
    wire          commit = |bcommit;
    wire [LK-1:0] qax    = commit ? cax : rd ? rax : bax;
    (* ram_style = "distributed" *) reg [LB:0] wm_s [0:(1<<LK)-1];
    (* ram_style = "distributed" *) reg [LB:0] wm_q [0:(1<<LK)-1];
    (* ram_style = "distributed" *) reg [LB:0] rm_s [0:(1<<LK)-1];
    (* ram_style = "distributed" *) reg [LB:0] rm_q [0:(1<<LK)-1];
    wire [LB:0] wp_s = wz_v[s] ? {(LB+1){1'b0}} : wm_s[s];
    wire [LB:0] rp_s = rz_v[s] ? {(LB+1){1'b0}} : rm_s[s];
    wire [LB:0] bwp  = wz_v[qax] ? {(LB+1){1'b0}} : wm_q[qax];
    wire [LB:0] rp_q = rz_v[qax] ? {(LB+1){1'b0}} : rm_q[qax];
    wire [LB:0] wp_n = bwp + {{(LB-7){1'b0}}, blen};   // a commit's new write pointer
    always @(posedge clk) begin
        if (commit) begin
            wm_s[cax] <= wp_n;
            wm_q[cax] <= wp_n;
        end
        if (take) begin
            rm_s[s] <= wr;
            rm_q[s] <= wr;
        end
    end

    // ---- free bytes, 2^LB - (wp - rp), of the axis looked at ----
    localparam [LB:0] SIZE = {1'b1, {LB{1'b0}}};
    assign free = SIZE - (bwp - rp_q);
    always @(posedge clk)
        if (bopen && bsel) bok <= ({{(LB-7){1'b0}}, blen} <= free) && !rst;

    // ---- the buffers: one memory, axis-major ----
    reg  [7:0] mem [0:(1<<(LK+LB))-1];
    /* verilator lint_off WIDTH */
    wire [LB-1:0] waddr = bwp[LB-1:0] + bidx;
    /* verilator lint_on WIDTH */
    /* verilator lint_off UNUSED */  // the pointer's wrap bit: the address is modulo 2^LB
    wire unused_wrap = bwp[LB];
    /* verilator lint_on UNUSED */
    always @(posedge clk) begin
        if (bwr && bsel && bok) mem[{bax, waddr}] <= bbyte;
        rdata <= mem[{s, wr[LB-1:0]}];
    end

    // ---- the decoder ----
    wire [3:0]  n = lo ? rdata[3:0] : nh;
    wire [24:0] pw = fresh_v[s] ? 25'd0 : pm;   // the axis's last period
    wire [1:0]  esc_n;
    wire [2:0]  got_n;
    wire [19:0] acc_n;
    ms_nibble u_nib (.n(n), .esc(esc), .got(got), .acc(acc), .prev(pw), .done(done_p), .p(p),
        .esc_n(esc_n), .got_n(got_n), .acc_n(acc_n));
    wire          s_live = live_v[s];
    wire          take   = (st == S_DEC) && s_live && done_p && !full[s];
    // the served axis may decode: it runs, its FIFO has room, and a nibble is there (one
    // comparison for all axes, at the axis served). From flip-flops: a halt, arm, init or
    // reset of this clock, which `live` adds, ends the turn in the next (S_FETCH, S_DEC)
    // and `take` never takes for it, so the e-stop's path to the halt stays out of the pick.
    wire          want   = ready_v[s] && !full[s] && (hp_v[s] || rp_s != wp_s);
    localparam [31:0]   KM1  = K - 1;
    localparam [LK-1:0] LAST = KM1[LK-1:0];
    wire [LK-1:0] s_next = (s == LAST) ? {LK{1'b0}} : s + 1'b1;
    ms_step_counts #(.K(K), .LK(LK)) u_counts (.clk(clk), .rst(rst), .load(arm), .halt(halt),
        .init(init), .retarget(retarget_v), .s(s), .step(take), .count(arm_steps),
        .left_nz(left_nz_v));
    generate
        for (g = 0; g < K; g = g + 1) begin : sv
            /* verilator lint_off WIDTH */
            assign serve[g] = take && (s == g);
            /* verilator lint_on WIDTH */
        end
    endgenerate
    // each axis's high nibble still to decode (valid while its hp is set): written as the
    // axis is served, read at its pick
    reg [3:0] hmem [0:(1<<LK)-1];
    always @(posedge clk)
        if (take) hmem[s] <= rdata[7:4];
    always @(posedge clk) begin
        pm <= pmem[s];
        if (take) pmem[s] <= p;
    end
    always @(posedge clk) begin
        // a held period is pushed the clock after (a take needs two clocks after one)
        pv_ok <= take || (pv_ok && hold);
        if (take) begin
            pv    <= p;
            pv_ax <= s;
        end
        if (rst) begin
            st <= S_PICK;
            s  <= {LK{1'b0}};
        end else begin
            case (st)
                S_PICK: if (want) begin
                    wr  <= rp_s;
                    lo  <= 1'b0;
                    nh  <= hmem[s];
                    esc <= 2'd0;
                    st  <= hp_v[s] ? S_DEC : S_FETCH;
                end else begin
                    s <= s_next;
                end
                // the read of {s, wr} is in flight; its byte is rdata in S_DEC
                S_FETCH: if (!s_live || wr == wp_s) begin
                    st <= S_PICK;
                    s  <= s_next;
                end else begin
                    wr <= wr + 1'b1;
                    lo <= 1'b1;
                    st <= S_DEC;
                end
                // a period ends the turn, taken (take) if the FIFO has room
                default: if (!s_live || done_p) begin
                    st <= S_PICK;
                    s  <= s_next;
                end else begin
                    if (lo) nh <= rdata[7:4];
                    lo <= 1'b0;
                    if (!lo) st <= S_FETCH;
                    esc <= esc_n;
                    got <= got_n;
                    acc <= acc_n;
                end
            endcase
        end
    end
endmodule
