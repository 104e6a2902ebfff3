// ms_core: K axes sharing one period calculator by time-division multiplexing
// (seed 000 section 1.2, DESIGN.md section 3). Each axis has its own segment registers,
// its own FIFO of periods (a separate memory) and its own pulse unit. Round-robin: if axis
// m's FIFO has room and steps remain, compute one period for it, then go to m+1.
//
// Register bus (write-only, synchronous, 32-bit data; status on the output ports):
//   wr_addr = {1'b0, axis[LK], seg[LS], field[2]}   axis segment registers
//     field 0: n   steps of the segment (>= 1)
//     field 1: d   duration in ticks
//     field 2: s   start speed v0 * 2^WF * d   (v0 in steps/tick)
//     field 3: ctl bit 31 = DIR level, bits LS-1:0 = index of the axis's last segment
//   wr_addr = {1'b1, ..., 2'd0}: start; data bits K-1:0 = the axes of a synchronous group.
// The group's pulse units start together (tick 0) once every member's FIFO is full or
// holds its whole move. Do not write an axis's registers while busy[axis] is high.
module ms_core #(
    parameter K   = 2,
    parameter LK  = 1,     // axis index bits (>= 1)
    parameter LS  = 2,     // segment index bits (2^LS segments per axis)
    parameter LF  = 4,     // FIFO depth 2^LF
    parameter WN  = 20,
    parameter WD  = 24,
    parameter WF  = 8,
    parameter WM  = 57,
    parameter WX  = 114,
    parameter WNU = 60,
    parameter WDE = 36,
    parameter WQ  = 25,
    parameter WT  = 26,    // move tick bits: WD + LS
    parameter AW  = 6      // 1 + LK + LS + 2
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
    output wire [K-1:0]  step,
    output wire [K-1:0]  dir,
    output wire [K-1:0]  busy,
    output wire [K-1:0]  underrun
);
    localparam WS  = WD + WF;
    localparam WST = LS + WN + 2 * WT;

    // ---- register bus ----
    wire          is_glob = wr_addr[AW-1];
    wire [1:0]    field   = wr_addr[1:0];
    wire [LS-1:0] wseg    = wr_addr[LS+1:2];
    wire [LK-1:0] wax     = wr_addr[LS+LK+1:LS+2];
    wire          ax_ok   = ({1'b0, wax} < K);
    reg [WN-1:0] seg_n [0:(1<<(LK+LS))-1];
    reg [WD-1:0] seg_d [0:(1<<(LK+LS))-1];
    reg [WS-1:0] seg_s [0:(1<<(LK+LS))-1];
    reg [LS-1:0] last_seg [0:K-1];
    reg [K-1:0]  dir_r;
    reg [K-1:0]  group;
    always @(posedge clk) begin
        if (wr_en && !is_glob && ax_ok) begin
            case (field)
                2'd0: seg_n[{wax, wseg}] <= wr_data[WN-1:0];
                2'd1: seg_d[{wax, wseg}] <= wr_data[WD-1:0];
                2'd2: seg_s[{wax, wseg}] <= wr_data[WS-1:0];
                default: begin
                    last_seg[wax] <= wr_data[LS-1:0];
                    dir_r[wax]    <= wr_data[31];
                end
            endcase
        end
    end
    wire start_wr = wr_en && is_glob && (field == 2'd0);

    // ---- scheduler and per-axis calculator state {j, i, t0, last edge} ----
    reg  [LK-1:0]  m;
    reg  [WST-1:0] st_mem [0:K-1];
    reg  [K-1:0]   init_pend;
    reg  [K-1:0]   calc_act;
    reg            sch_wait;
    wire [WST-1:0] cur    = st_mem[m];
    wire [LS-1:0]  cur_j  = cur[WST-1:WST-LS];
    wire [WN-1:0]  cur_i  = cur[2*WT+WN-1:2*WT];
    wire [WT-1:0]  cur_t0 = cur[2*WT-1:WT];
    wire [WT-1:0]  cur_lt = cur[WT-1:0];
    wire [WN-1:0]  cn = seg_n[{m, cur_j}];
    wire [WD-1:0]  cd = seg_d[{m, cur_j}];
    wire [WS-1:0]  cs = seg_s[{m, cur_j}];
    wire [K-1:0]   fifo_full, fifo_empty, fifo_pop, running;
    wire [K*WD-1:0] fifo_dout;
    wire [LK-1:0]  m_next = ({1'b0, m} == K - 1) ? {LK{1'b0}} : m + 1'b1;
    wire           calc_go = !sch_wait && !init_pend[m] && calc_act[m] && !fifo_full[m];
    wire           calc_busy;
    wire [WQ-1:0]  q;
    ms_calc #(.WN(WN), .WD(WD), .WF(WF), .WM(WM), .WX(WX), .WNU(WNU), .WDE(WDE), .WQ(WQ))
        u_calc (.clk(clk), .start(calc_go), .n(cn), .d(cd), .s(cs), .i(cur_i),
                .busy(calc_busy), .q(q));
    wire           done    = sch_wait && !calc_busy;
    wire [WT-1:0]  edge_t  = cur_t0 + {{(WT-WQ){1'b0}}, q};
    /* verilator lint_off UNUSED */  // a period is < 2^WD; the top bits are zero
    wire [WT-1:0]  period  = edge_t - cur_lt;
    /* verilator lint_on UNUSED */
    wire           seg_end = (cur_i == cn);
    wire           mov_end = seg_end && (cur_j == last_seg[m]);
    wire [WST-1:0] init_st = {{LS{1'b0}}, {{(WN-1){1'b0}}, 1'b1}, {(2*WT){1'b0}}};
    wire [WST-1:0] next_st = seg_end
        ? {cur_j + 1'b1, {{(WN-1){1'b0}}, 1'b1}, cur_t0 + {{(WT-WD){1'b0}}, cd}, edge_t}
        : {cur_j, cur_i + 1'b1, cur_t0, edge_t};
    wire           do_init = !sch_wait && init_pend[m];
    always @(posedge clk) begin
        if (do_init || done) st_mem[m] <= do_init ? init_st : next_st;
    end
    initial begin
        m = {LK{1'b0}};
        init_pend = {K{1'b0}};
        calc_act = {K{1'b0}};
        sch_wait = 1'b0;
        pending = 1'b0;
        group = {K{1'b0}};
    end
    always @(posedge clk) begin
        if (do_init) begin
            calc_act[m] <= 1'b1;
            m <= m_next;
        end else if (calc_go) begin
            sch_wait <= 1'b1;
        end else if (done) begin
            sch_wait <= 1'b0;
            if (mov_end) calc_act[m] <= 1'b0;
            m <= m_next;
        end else if (!sch_wait) begin
            m <= m_next;
        end
        if (start_wr) begin
            init_pend <= (init_pend | wr_data[K-1:0]) & ~(do_init ? ({{(K-1){1'b0}}, 1'b1} << m) : {K{1'b0}});
            group     <= wr_data[K-1:0];
            pending   <= 1'b1;
        end else begin
            if (do_init) init_pend[m] <= 1'b0;
            if (go) pending <= 1'b0;
        end
    end
    assign ready = pending && ((group & (init_pend | (calc_act & ~fifo_full))) == {K{1'b0}});

    // ---- per axis: FIFO and pulse unit ----
    genvar a;
    generate
        for (a = 0; a < K; a = a + 1) begin : axis
            ms_fifo #(.W(WD), .LD(LF)) u_fifo (
                .clk(clk), .clear(do_init && ({1'b0, m} == a)),
                .push(done && ({1'b0, m} == a)), .din(period[WD-1:0]),
                .pop(fifo_pop[a]), .dout(fifo_dout[a*WD +: WD]),
                .empty(fifo_empty[a]), .full(fifo_full[a]));
            ms_pulse #(.WP(WD)) u_pulse (
                .clk(clk), .go(go && group[a]), .din(fifo_dout[a*WD +: WD]),
                .empty(fifo_empty[a]), .more(calc_act[a]), .pop(fifo_pop[a]),
                .step(step[a]), .running(running[a]), .underrun(underrun[a]));
        end
    endgenerate
    assign dir  = dir_r;
    assign busy = init_pend | calc_act | running | (pending ? group : {K{1'b0}});
endmodule
