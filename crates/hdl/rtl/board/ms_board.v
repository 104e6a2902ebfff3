// ms_board: the board top level around ms_core (docs/HDL.md, "The board"). The host talks
// to the registers (ms_regs) over a UART (8N1, BAUD) in request/reply frames (ms_link);
// the per-board wrapper adds the PLL (clk is the core clock, CLK_HZ) and the pins.
// Asynchronous inputs pass two-flop synchronizers; the e-stop input also forces every
// STEP pin inactive combinationally, before its synchronizer, and latches.
module ms_board #(
    parameter K        = 2,
    parameter LK       = 1,
    parameter LS       = 2,
    parameter LF       = 4,
    parameter WN       = 20,
    parameter WD       = 24,
    parameter WQ       = 24,
    parameter WT       = 27,
    parameter WY       = 128,
    parameter WK       = 68,
    parameter RB       = 2,
    parameter MD       = 16,
    parameter AW       = 7,
    parameter CLK_HZ   = 50000000,
    parameter BAUD     = 3000000,
    parameter ESTOP_ACTIVE = 1,        // the level of estop_in that stops (1: high)
    parameter VERSION  = 16'h0001,
    parameter LB       = 9,            // each axis's stream buffer: 2^LB bytes (8..16;
                                       // 0: no replay units, streamed moves refused)
    parameter SYNC     = 1,            // 1: the SYNC line (Arm, Fire, SyncTick); 0: none
    parameter CHAINS   = 0,            // 1: a chain unit per axis (ms_chain_axis; LB > 0)
    parameter LUTRAM   = 0,            // 1: the family has distributed RAM (ms_core)
    parameter LIMITS   = 1,            // 0: the pins have no limit inputs (they read 0)
    parameter WB       = 10,           // the Hall and limit filters' counters (ms_filter_clock)
    parameter RECUR    = 0,            // 1: the per-step recurrence in the core (ms_core)
    parameter MR       = 0,            // its multiplier digit bits (0: full width, <= 15)
    parameter WRA      = 56,           // and its widths (ms_core)
    parameter WRB      = 40,
    parameter WRU      = 80
) (
    input  wire         clk,
    input  wire         rst_n_async,
    input  wire         uart_rx,
    output wire         uart_tx,
    input  wire         estop_in,
    input  wire [K-1:0] hall_in,
    input  wire [K-1:0] limit_in,
    output wire [K-1:0] step_out,
    output wire [K-1:0] dir_out,
    output wire [K-1:0] enable_out,
    output wire [3:0]   led,
    input  wire         sync_in,       // the shared SYNC line (open drain, pulled up)
    output wire         sync_oe        // 1: pull SYNC low (the wrapper's tristate)
);
    localparam DIV = (CLK_HZ + BAUD / 2) / BAUD;
    localparam LBR = (LB == 0) ? 8 : LB;   // the registers' free-count width
    localparam CHAIN_BYTES = 219;          // ms_chain_axis's record at its default widths

    wire rst;
    ms_reset u_reset (.clk(clk), .rst_n_async(rst_n_async), .rst(rst));

    // ---- synchronizers ----
    wire         rx_s, estop_s, sync_s;
    wire [K-1:0] hall_s, limit_s;
    ms_sync #(.W(1), .INIT(1)) u_sync_rx (.clk(clk), .d(uart_rx), .q(rx_s));
    ms_sync #(.W(1), .INIT(ESTOP_ACTIVE)) u_sync_estop (.clk(clk), .d(estop_in), .q(estop_s));
    // every board, the firing one too, sees SYNC through this synchronizer
    ms_sync #(.W(1), .INIT(1)) u_sync_line (.clk(clk), .d(sync_in || (SYNC == 0)), .q(sync_s));
    ms_sync #(.W(K), .INIT(0)) u_sync_hall (.clk(clk), .d(hall_in), .q(hall_s));
    ms_sync #(.W(K), .INIT(0)) u_sync_limit (.clk(clk), .d(limit_in), .q(limit_s));
    wire estop_raw = (estop_in == ESTOP_ACTIVE[0]);   // unsynchronized: only gates STEP
    wire estop_act = (estop_s == ESTOP_ACTIVE[0]);

    // ---- UART and framing ----
    wire       rx_valid, rx_ferr, rx_busy;
    wire [7:0] rx_byte;
    ms_uart_rx #(.DIV(DIV)) u_rx (.clk(clk), .rst(rst), .rx(rx_s), .valid(rx_valid),
        .data(rx_byte), .frame_err(rx_ferr), .busy(rx_busy));
    wire        tx_start, tx_busy;
    wire [7:0]  tx_byte;
    ms_uart_tx #(.DIV(DIV)) u_tx (.clk(clk), .rst(rst), .start(tx_start), .data(tx_byte),
        .tx(uart_tx), .busy(tx_busy));
    wire        req, req_wr, req_bulk, bad_frame;
    wire        bulk_open, bulk_wr;
    wire [15:0] bulk_addr;
    wire [7:0]  bulk_len, bulk_idx, bulk_byte;
    wire [15:0] req_addr;
    wire [31:0] req_data, rsp_data;
    wire [7:0]  rsp_status;
    // a gap of 4 character times ends a frame
    ms_link #(.GAP(DIV * 40), .BULK(LB > 0)) u_link (.clk(clk), .rst(rst), .rx_valid(rx_valid),
        .rx_byte(rx_byte), .req(req), .req_wr(req_wr), .req_addr(req_addr),
        .req_data(req_data), .req_bulk(req_bulk), .bulk_open(bulk_open),
        .bulk_addr(bulk_addr), .bulk_len(bulk_len), .bulk_wr(bulk_wr), .bulk_idx(bulk_idx),
        .bulk_byte(bulk_byte), .rsp_status(rsp_status), .rsp_data(rsp_data),
        .tx_start(tx_start), .tx_byte(tx_byte), .tx_busy(tx_busy), .bad_frame(bad_frame));

    // ---- registers and core ----
    wire          core_wr, go, ready, pending, estop;
    wire [AW-1:0] core_addr;
    wire [31:0]   core_data;
    wire [K-1:0]  step, dir, busy, underrun, halt, divert, dir_q, enable;
    wire [LK-1:0] slot_ax;   // the register map asks for the slot of this axis's next period
    wire [LS-1:0] slot_at;
    wire [K-1:0]  dir_inv, en_low;
    wire [K-1:0]  pos_wr, hall_clr, hall_flag, hall_lvl, hall_edge, limit_lvl, limit_edge;
    wire [K*LS-1:0] div_slot;
    wire [WD-1:0] pulse_width, debounce;
    wire [5:0]    levels;
    wire [K-1:0]  count, latch;
    wire [31:0]   rd_pos, rd_hall;
    wire [K*WD-1:0] period;    // each pulse unit's period, read back
    wire          calc_push;
    // the replay units
    wire [K-1:0]  s_chain, s_arm, s_retarget, s_commit, s_armed, s_more, s_fault, s_push, init_ax, ax_full;
    wire          s_bok;    // the open bulk frame fits its axis's buffer
    wire [LBR:0]  s_free;   // the free bytes of the request's axis
    // per axis, from the chain boards' own replay units (unused with the shared one)
    /* verilator lint_off UNUSED */
    wire [K-1:0]  s_bok_v;
    wire [K*(LBR+1)-1:0] s_free_v;
    /* verilator lint_on UNUSED */
    wire [K*WD-1:0] s_din;
    ms_regs #(.K(K), .LK(LK), .LS(LS), .AW(AW), .WD(WD), .LF(LF), .WN(WN), .WY(WY), .WK(WK), .RB(RB),
              .VERSION(VERSION), .CLK_HZ(CLK_HZ), .BAUD(BAUD), .LB(LBR), .SYNC(SYNC),
              .CHAINS((CHAINS != 0 && LB > 0) ? CHAIN_BYTES : 0), .RECUR(RECUR), .MR(MR)) u_regs (
        .clk(clk), .rst(rst), .req(req), .req_wr(req_wr), .req_addr(req_addr),
        .req_data(req_data), .req_bulk(req_bulk), .s_arm(s_arm), .s_retarget(s_retarget),
        .s_commit(s_commit), .s_chain(s_chain),
        .s_armed(s_armed), .s_bok(s_bok), .s_free(s_free), .s_more(s_more), .s_fault(s_fault), .rsp_status(rsp_status), .rsp_data(rsp_data),
        .core_wr(core_wr), .core_addr(core_addr), .core_data(core_data),
        .core_busy(busy), .core_underrun(underrun), .core_dir(dir), .core_pending(pending),
        .core_slot_ax(slot_ax), .core_slot(slot_at),
        .core_ready(ready), .go(go), .halt(halt), .divert(divert), .div_slot(div_slot),
        .dir_q(dir_q), .pulse_width(pulse_width), .debounce(debounce),
        .enable(enable), .levels(levels), .dir_inv(dir_inv), .en_low(en_low), .pos_wr(pos_wr), .hall_clr(hall_clr),
        .rd_pos(rd_pos), .rd_hall(rd_hall), .hall_flag(hall_flag), .hall_lvl(hall_lvl),
        .hall_edge(hall_edge), .limit_lvl(limit_lvl), .limit_edge(limit_edge),
        .period(period), .estop_in(estop_act), .estop(estop), .rx_line(rx_s),
        .bad_frame(bad_frame), .sync_line(sync_s), .sync_oe(sync_oe));
    ms_core #(.K(K), .LK(LK), .LS(LS), .LF(LF), .WN(WN), .WD(WD), .WQ(WQ), .WT(WT), .WY(WY),
              .WK(WK), .RB(RB), .MD(MD), .AW(AW), .LUTRAM(LUTRAM), .RECUR(RECUR),
              .MR(MR), .WRA(WRA), .WRB(WRB), .WRU(WRU),
              .SHARED((LB > 0 && CHAINS == 0) ? 1 : 0)) u_core (
        .clk(clk), .wr_en(core_wr), .wr_addr(core_addr), .wr_data(core_data),
        .ready(ready), .pending(pending), .go(go), .halt(halt), .divert(divert),
        .div_slot(div_slot), .step(step), .dir(dir), .busy(busy), .underrun(underrun),
        .stream(s_armed), .s_push(s_push), .s_din(s_din), .s_more(s_more), .init_ax(init_ax),
        .ax_full(ax_full), .calc_push(calc_push), .pulse_per(period), .slot_ax(slot_ax),
        .slot_at(slot_at));
    // a bulk frame's axis: the StreamData register 0x2000 | axis << 4 | 7
    wire          b_data = (bulk_addr[15:10] == 6'b001000) && (bulk_addr[3:0] == 4'h7);
    wire [5:0]    b_ax   = bulk_addr[9:4];

    // ---- the replay units: one decoder for every axis (the chain boards: one per axis) ----
    wire [WD-1:0] r_period;
    genvar gr;
    generate
        if (LB > 0 && CHAINS == 0) begin : shared_replay
            ms_replay #(.K(K), .LK(LK), .WD(WD), .LB(LBR)) u_replay (
                .clk(clk), .rst(rst), .arm(s_arm), .arm_steps(req_data),
                .retarget_in(s_retarget), .bsel(b_data && ({26'd0, b_ax} < K)),
                .bax(b_ax[LK-1:0]), .bopen(bulk_open), .blen(bulk_len), .bwr(bulk_wr),
                .bidx(bulk_idx), .bbyte(bulk_byte), .bcommit(s_commit), .init(init_ax),
                .halt(halt), .full(ax_full), .hold(calc_push), .rd(req), .rax(req_addr[4 +: LK]),
                .armed(s_armed),
                .bok(s_bok), .free(s_free),
                .push(s_push), .period(r_period), .more(s_more), .fault(s_fault));
        end else begin : per_axis_replay
            // each axis's replay unit has its own free bytes and fit flag
            wire [LBR:0] free_w [0:K-1];
            for (gr = 0; gr < K; gr = gr + 1) begin : rb
                assign free_w[gr] = s_free_v[gr*(LBR+1) +: LBR+1];
            end
            assign s_bok    = s_bok_v[b_ax[LK-1:0]];
            assign s_free   = free_w[req_addr[4 +: LK]];
            assign r_period = {WD{1'b0}};
        end
    endgenerate

    // ---- per axis ----
    // the Hall and limit filters' shared time base
    wire          filter_strobe;
    wire [WB-1:0] filter_load;
    ms_filter_clock #(.WD(WD), .WB(WB)) u_filter_clock (.clk(clk), .ticks(debounce),
        .load(filter_load), .strobe(filter_strobe));
    wire kill = estop_act || estop;
    // the fixed-width pulses' clock and the end of a pulse rising now (registered: the
    // width changes only while no axis is busy, and end_at is now + width at every clock)
    wire          fixed_width = (pulse_width != {WD{1'b0}});
    reg  [WD-1:0] now, end_at;
    initial begin
        now = {WD{1'b0}};
        end_at = {WD{1'b0}};
    end
    always @(posedge clk) begin
        now    <= now + 1'b1;
        end_at <= now + pulse_width + 1'b1;
    end
    wire en_off = levels[5] && estop;
    genvar a;
    generate
        for (a = 0; a < K; a = a + 1) begin : axis
            if (LB > 0 && CHAINS != 0) begin : chain
                wire mine = b_data && (b_ax == a);
                ms_chain_axis #(.WD(WD), .LB(LBR)) u_chain (
                    .clk(clk), .rst(rst), .arm(s_arm[a]), .arm_ch(s_chain[a]),
                    .arm_steps(req_data), .retarget_in(s_retarget[a]),
                    .bopen(bulk_open && mine), .blen(bulk_len), .bwr(bulk_wr && mine),
                    .bidx(bulk_idx), .bbyte(bulk_byte), .bcommit(s_commit[a]),
                    .init(init_ax[a]), .halt(halt[a]), .full(ax_full[a]),
                    .armed(s_armed[a]), .bok(s_bok_v[a]),
                    .free(s_free_v[a*(LBR+1) +: LBR+1]),
                    .push(s_push[a]), .period(s_din[a*WD +: WD]), .more(s_more[a]),
                    .fault(s_fault[a]));
            end else if (LB > 0) begin : replay
                // the shared replay unit (above)
                assign s_din[a*WD +: WD] = r_period;
                assign s_bok_v[a] = 1'b0;
                assign s_free_v[a*(LBR+1) +: LBR+1] = {(LBR+1){1'b0}};
            end else begin : no_replay
                assign s_armed[a] = 1'b0;
                assign s_bok_v[a] = 1'b0;
                assign s_free_v[a*(LBR+1) +: LBR+1] = {(LBR+1){1'b0}};
                assign s_push[a] = 1'b0;
                assign s_din[a*WD +: WD] = {WD{1'b0}};
                assign s_more[a] = 1'b0;
                assign s_fault[a] = 1'b0;
            end
            ms_axis_io #(.WD(WD), .WB(WB), .LIMIT(LIMITS)) u_io (
                .clk(clk), .rst(rst), .core_step(step[a]), .dir(dir_q[a]),
                .halt(halt[a]), .kill(kill), .kill_pin(estop_raw),
                .fixed(fixed_width), .now(now), .end_at(end_at),
                .strobe(filter_strobe), .load(filter_load), .hall(hall_s[a] == levels[3]),
                .limit(limit_s[a] == levels[4]),
                .hall_clr(hall_clr[a]), .en(enable[a] && !en_off), .lvl_step(levels[0]),
                .lvl_dir(levels[1] ^ dir_inv[a]), .lvl_en(levels[2] ^ en_low[a]),
                .step_pin(step_out[a]),
                .dir_pin(dir_out[a]), .en_pin(enable_out[a]), .count(count[a]),
                .latch(latch[a]), .hall_flag(hall_flag[a]),
                .hall_lvl(hall_lvl[a]), .hall_edge(hall_edge[a]), .limit_lvl(limit_lvl[a]),
                .limit_edge(limit_edge[a]));
        end
    endgenerate

    // every axis's position and Hall latch, read back at the request's axis (0x2000 |
    // axis << 4 | r)
    ms_positions #(.K(K), .LK(LK), .MEM(LUTRAM)) u_positions (.clk(clk), .rst(rst),
        .cnt(count), .up(dir_q), .latch(latch), .wr(pos_wr), .din(req_data),
        .rd(req), .ax(req_addr[4 +: LK]), .rd_pos(rd_pos), .rd_hall(rd_hall));

    // LEDs: 0 heartbeat (about 1.5 Hz), 1 any axis busy, 2 e-stop latched, 3 link activity
    // (registered: the K-wide busy OR ran across the die to the pin, the 14-axis ULX3S
    // build's critical path)
    reg [24:0] beat;
    reg [19:0] act;
    reg [3:0]  led_q;
    initial begin
        beat = 25'd0;
        act = 20'd0;
        led_q = 4'd0;
    end
    always @(posedge clk) begin
        beat <= beat + 1'b1;
        if (rx_busy) act <= {20{1'b1}};
        else if (act != 20'd0) act <= act - 1'b1;
        led_q <= {act != 20'd0, estop || estop_act, |busy, beat[24]};
    end
    assign led = led_q;
    /* verilator lint_off UNUSED */  // the bulk path is unused without replay units (LB = 0)
    wire unused = rx_ferr ^ bulk_open ^ bulk_wr ^ (^bulk_len) ^ (^bulk_idx) ^ (^bulk_byte) ^
                  (^s_arm) ^ (^s_chain) ^ (^r_period) ^ calc_push ^ (^s_retarget) ^ (^s_commit) ^ (^init_ax) ^ (^ax_full) ^ b_data ^ (^b_ax);
    /* verilator lint_on UNUSED */
endmodule
