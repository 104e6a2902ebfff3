// ms_regs: the board's registers behind the host link (docs/HDL.md, "Host link"). A
// request {req_wr, req_addr, req_data} is executed in its clock; its status and read data
// are valid in the next. A request that fails a check changes nothing.
//   0x0000-0x001A  board registers     0x1000 | a  the core's bus word a (write only)
//   0x2000 | axis << 4 | r              axis registers
// Cross-board start (SYNC = 1): Arm loads a group as Start does but holds its go until the
// shared SYNC line falls (sync_line, synchronized); Fire pulls the line low for SP clocks.
// Every board, the firing one too, sees the edge through its own synchronizer, so all
// start at the same edge; SyncTick latches the free-running count there. ArmTimeout
// (nonzero) bounds how long a group stays armed: that many clocks after its Arm write,
// with no SYNC edge yet, the group is cut (its axes halted before they ever go) and
// Status bit 7 is set until the next Arm, so a host that died between Arm and Fire never
// leaves a share that a later SYNC edge starts stale.
// A bulk write (req_bulk, req_data = its length) goes only to an axis's StreamData (r = 7):
// its bytes went to the axis's replay unit (ms_stream) as they arrived; here it is
// committed if it fit, and the reply's data is the free bytes left.
// Ticks (0x1A) reads the free-running count: the host stamps its reads with its own clock
// and fits the board's crystal against it (tracking kept to host time).
// Session (0x05) is the host's: it writes a nonzero token after connecting; configuration
// and every reset clear it, so a readback other than the token means the board lost its
// state, whatever the timing.
// Status: 0 ok, 3 unknown register (or the wrong direction), 4 busy (the write would
// change a running move), 5 e-stop latched, 6 bad value, 7 the stream buffer has no room
// for the bulk write. (1 and 2 are ms_link's.)
module ms_regs #(
    parameter K       = 2,
    parameter LK      = 1,
    parameter LS      = 2,
    parameter AW      = 7,
    parameter WD      = 24,
    parameter LF      = 4,
    parameter WN      = 20,
    parameter WY      = 128,
    parameter WK      = 68,
    parameter RB      = 2,
    parameter VERSION = 16'h0001,
    parameter CLK_HZ  = 50000000,
    parameter BAUD    = 3000000,
    parameter LB      = 9,
    parameter SYNC    = 1,
    parameter CHAINS  = 0,     // a chain record's bytes (ChainSteps), 0: no chain units
    parameter RECUR   = 0,     // Config: the core has the per-step recurrence
    parameter MR      = 0      // and its digit bits (0..15)
) (
    input  wire          clk,
    input  wire          rst,
    input  wire          req,
    input  wire          req_wr,
    input  wire [15:0]   req_addr,
    input  wire [31:0]   req_data,
    input  wire          req_bulk,
    output reg  [7:0]    rsp_status,
    output reg  [31:0]   rsp_data,
    // the core
    output reg           core_wr,
    output reg  [AW-1:0] core_addr,
    output reg  [31:0]   core_data,
    input  wire [K-1:0]  core_busy,
    input  wire [K-1:0]  core_underrun,
    input  wire [K-1:0]  core_dir,
    output wire [LK-1:0] core_slot_ax, // the core bus request's axis ...
    input  wire [LS-1:0] core_slot,    // ... its next period's piece slot
    input  wire          core_pending,
    input  wire          core_ready,
    output wire          go,
    output wire [K-1:0]  halt,
    output reg  [K-1:0]  divert,
    output wire [K*LS-1:0] div_slot,
    // the axes
    output reg  [K-1:0]  dir_q,      // DIR, latched at the start
    output reg  [WD-1:0] pulse_width,
    output reg  [WD-1:0] debounce,
    output reg  [K-1:0]  enable,
    output reg  [5:0]    levels,     // active levels: STEP, DIR, ENABLE, Hall, limit; e-stop drops ENABLE
    // per axis: DIR inverted, ENABLE active low (flip `levels`); kept over a reset, so the
    // ENABLE a reset or e-stop forces off stays at the axis's inactive level
    output reg  [K-1:0]  dir_inv,
    output reg  [K-1:0]  en_low,
    output reg  [K-1:0]  pos_wr,
    output reg  [K-1:0]  hall_clr,
    input  wire [31:0]   rd_pos,     // the addressed axis's position and Hall latch
    input  wire [31:0]   rd_hall,    // (ms_positions, read at req_addr's axis)
    input  wire [K-1:0]  hall_flag,
    input  wire [K-1:0]  hall_lvl,
    input  wire [K-1:0]  hall_edge,
    input  wire [K-1:0]  limit_lvl,
    input  wire [K-1:0]  limit_edge,
    input  wire [K*WD-1:0] period,
    // board
    input  wire          estop_in,   // the e-stop input, synchronized, active high
    output reg           estop,      // latched
    /* verilator lint_off UNUSED */
    input  wire          rx_line,    // the UART input, synchronized (not used)
    /* verilator lint_on UNUSED */
    input  wire          bad_frame,
    input  wire          sync_line,  // the SYNC line, synchronized (idle high)
    output wire          sync_oe,    // pull the SYNC line low
    // the replay units (ms_stream)
    output reg  [K-1:0]  s_arm,      // one clock: StreamSteps of these axes = req_data
    output reg  [K-1:0]  s_retarget, // one clock: the running streams' step count = req_data
    output reg  [K-1:0]  s_commit,   // one clock: commit the bulk write
    output reg  [K-1:0]  s_chain,    // one clock: ChainSteps of these axes = req_data
    input  wire [K-1:0]  s_armed,
    input  wire          s_bok,      // the open bulk frame fits its axis's buffer
    input  wire [LB:0]   s_free,     // the free bytes of req_addr's axis
    input  wire [K-1:0]  s_more,
    input  wire [K-1:0]  s_fault
);
    localparam [7:0] OK = 8'd0, E_ADDR = 8'd3, E_BUSY = 8'd4, E_ESTOP = 8'd5, E_VALUE = 8'd6,
                     E_FULL = 8'd7;
    // the Fire pulse: 1 us, at least 4 clocks (long enough for a slower board to sample)
    localparam SP_US = CLK_HZ / 1000000;
    localparam [7:0] SP = (SP_US < 4) ? 8'd4 : (SP_US > 255) ? 8'd255 : SP_US[7:0];
    localparam [31:0] AXES_MASK = (K == 32) ? 32'hFFFF_FFFF : ((32'd1 << K) - 1);

    reg [31:0]   dir_setup;
    reg [K-1:0]  hall_stop, limit_stop, stopped, estopped, stop_req;
    reg [K-1:0]  diverted;     // a Hall stop diverted the busy axis to its stop ramp
    reg [LS-1:0] slot [0:K-1];
    reg [31:0]   free;         // free-running clock count (never reset)
    reg [31:0]   session;      // the host's token; 0 after configuration and every reset
    reg [15:0]   bad_frames;
    reg [31:0]   setup_cnt;    // clocks since the last start write
    reg [31:0]   setup_need;   // the go may come this many clocks after it
    reg          armed;        // the pending group waits for the SYNC edge
    reg          sync_hit;     // the SYNC edge came; the armed group goes when ready
    reg          sync_late;    // the SYNC edge came before the armed group was ready
    reg          sync_prev;
    reg [7:0]    fire_cnt;
    reg [31:0]   sync_tick;    // free at the last SYNC edge
    reg [31:0]   arm_timeout;  // clocks an armed group may wait for SYNC (0: no bound)
    reg [K-1:0]  arm_mask;     // the armed group's axes
    reg          arm_expired;  // an armed group was cut by ArmTimeout (until the next Arm)
    reg          arm_cut;      // one clock: the cut group's axes halt, and it must not go
    initial begin
        dir_inv = {K{1'b0}};
        en_low = {K{1'b0}};
        armed = 1'b0;
        sync_hit = 1'b0;
        sync_late = 1'b0;
        sync_prev = 1'b1;
        fire_cnt = 8'd0;
        sync_tick = 32'd0;
        arm_timeout = 32'd0;
        arm_mask = {K{1'b0}};
        arm_expired = 1'b0;
        arm_cut = 1'b0;
        free = 32'd0;
        session = 32'd0;
        estop = 1'b0;
        core_wr = 1'b0;
        divert = {K{1'b0}};
        diverted = {K{1'b0}};
        s_arm = {K{1'b0}};
        s_retarget = {K{1'b0}};
        s_commit = {K{1'b0}};
        s_chain = {K{1'b0}};
        setup_cnt = 32'd0;
        setup_need = 32'd0;
    end

    genvar g;
    generate
        for (g = 0; g < K; g = g + 1) begin : slots
            assign div_slot[g*LS +: LS] = slot[g];
        end
    endgenerate

    // ---- SYNC: the line's falling edge (after the synchronizer) ----
    wire       sync_en    = (SYNC != 0);
    wire       sync_edge  = sync_en && sync_prev && !sync_line;
    wire       ready_now  = core_ready && (setup_cnt >= setup_need);
    wire       sync_ready = armed && ready_now;
    // setup_cnt counts clocks from the Arm write (no start write is accepted while armed)
    wire       arm_expire = armed && !sync_hit && !sync_edge && arm_timeout != 32'd0 &&
                            setup_cnt >= arm_timeout;
    wire [K-1:0] cut_mask = arm_expire ? arm_mask : {K{1'b0}};

    // ---- decode ----
    wire        is_board = (req_addr[15:12] == 4'h0);
    wire        is_core  = (req_addr[15:12] == 4'h1);
    wire        is_axis  = (req_addr[15:12] == 4'h2);
    wire [7:0]  breg     = req_addr[7:0];
    wire [5:0]  ax       = req_addr[9:4];
    wire [3:0]  areg     = req_addr[3:0];
    wire        ax_ok    = is_axis && ({26'd0, ax} < K) && (req_addr[11:10] == 2'b00);
    wire        any_busy = |core_busy;
    wire        ax_busy  = core_busy[ax[LK-1:0]];
    wire [K-1:0] mask    = req_data[K-1:0];
    // the core's bus: {cmd, axis, word}
    wire        c_cmd    = req_addr[AW-1];
    wire [4:0]  c_word   = req_addr[4:0];
    wire [5:0]  c_ax     = {{(6-LK){1'b0}}, req_addr[AW-2:5]};
    wire        c_ok     = is_core && (req_addr[11:AW] == 0) &&
                           (c_cmd ? (c_word <= 5'd1 && {26'd0, c_ax} < K)
                                  : (c_word <= 5'd16 || RECUR != 0));   // staging words
    // A busy axis takes a commit into a slot its calculator is not in and a control word
    // that keeps its DIR: a move of more pieces than slots is loaded while it runs
    // (docs/HDL.md, "Pieces and the calculator"). Its slot is its next period's piece;
    // the host loads a slot only once the calculator is past it. Once a Hall stop has
    // diverted it, neither: the stop ramp is its last piece, whatever the host sends.
    assign      core_slot_ax = c_ax[LK-1:0];
    wire        c_busy   = c_cmd && core_busy[c_ax[LK-1:0]] &&
                           (diverted[c_ax[LK-1:0]] ||
                            ((c_word == 5'd0) ? (req_data[LS-1:0] == core_slot)
                                              : (req_data[31] != core_dir[c_ax[LK-1:0]])));
    integer n, i;
    always @(*) begin
        n = 0;
        for (i = 0; i < K; i = i + 1) n = n + {31'd0, mask[i]};
    end

    // a start's setup, DirSetup + n + 2 clocks, saturated: a DirSetup near 2^32 must not wrap
    // to a go without setup (the count it is compared with saturates too)
    wire [32:0] setup_sum = {1'b0, dir_setup} + {1'b0, n[31:0]} + 33'd2;

    // the period's readback as an array indexed by the axis: a multiplexer tree (a run-time
    // part-select of the K-word bus synthesized as a shifter)
    wire [WD-1:0] per_w  [0:K-1];
    generate
        for (g = 0; g < K; g = g + 1) begin : rb
            assign per_w[g]  = period[g*WD +: WD];
        end
    endgenerate
    // ---- read data ----
    reg [31:0] rd;
    reg        rd_ok;
    wire [2:0] state_code =
        estopped[ax[LK-1:0]] ? 3'd4 : stopped[ax[LK-1:0]] ? 3'd3 : core_underrun[ax[LK-1:0]] ? 3'd2 :
        core_busy[ax[LK-1:0]] ? 3'd1 : 3'd0;
    always @(*) begin
        rd = 32'd0;
        rd_ok = 1'b1;
        if (is_board) begin
            case (breg)
                8'h00: rd = {16'h4D53, VERSION[15:0]};
                8'h01: rd = {K[7:0], LF[7:0], LS[7:0], RECUR[0], MR[3:0], RB[2:0]};
                8'h02: rd = {WN[7:0], WD[7:0], WY[7:0], WK[7:0]};
                8'h03: rd = CLK_HZ;
                8'h04: rd = BAUD;
                8'h05: rd = session;
                8'h06: rd = {bad_frames, 8'd0, arm_expired, sync_ready, sync_line, sync_late, armed,
                             core_pending, estop_in, estop};
                8'h07: rd = {{(32-K){1'b0}}, core_busy};
                8'h08: rd = {31'd0, estop};
                8'h0B: rd = {{(32-WD){1'b0}}, pulse_width};
                8'h0C: rd = dir_setup;
                8'h0D: rd = {{(32-WD){1'b0}}, debounce};
                8'h0E: rd = {{(32-K){1'b0}}, enable};
                8'h0F: rd = {26'd0, levels};
                8'h10: rd = {{(32-K){1'b0}}, hall_stop};
                8'h11: rd = {{(32-K){1'b0}}, limit_stop};
                8'h15: begin rd = sync_tick; rd_ok = sync_en; end
                8'h16: rd = {{(32-K){1'b0}}, dir_inv};
                8'h17: rd = {{(32-K){1'b0}}, en_low};
                8'h18: begin rd = CHAINS; rd_ok = (CHAINS != 0); end
                8'h19: begin rd = arm_timeout; rd_ok = sync_en; end
                8'h1A: rd = free;
                default: rd_ok = 1'b0;
            endcase
            if (req_addr[11:8] != 4'h0) rd_ok = 1'b0;
        end else if (ax_ok) begin
            case (areg)
                4'h0: rd = {19'd0, s_fault[ax[LK-1:0]], s_armed[ax[LK-1:0]], core_dir[ax[LK-1:0]], limit_lvl[ax[LK-1:0]], hall_lvl[ax[LK-1:0]],
                            hall_flag[ax[LK-1:0]], estopped[ax[LK-1:0]], stopped[ax[LK-1:0]],
                            core_underrun[ax[LK-1:0]], core_busy[ax[LK-1:0]], state_code};
                4'h1: rd = rd_pos;
                4'h2: rd = rd_hall;
                4'h3: rd = {{(32-WD){1'b0}}, per_w[ax[LK-1:0]]};
                4'h4: rd = {{(32-LS){1'b0}}, slot[ax[LK-1:0]]};
                4'h5: rd = {31'd0, s_armed[ax[LK-1:0]]};
                4'h6: rd = {{(31-LB){1'b0}}, s_free};
                default: rd_ok = 1'b0;
            endcase
        end else begin
            rd_ok = 1'b0;
        end
    end

    // ---- write checks: the status of a write ----
    wire [7:0] start_st = (mask == {K{1'b0}} || (req_data & ~AXES_MASK) != 32'd0) ? E_VALUE
                        : estop ? E_ESTOP
                        // one group at a time: a pending group keeps its members
                        : (core_pending || (mask & core_busy) != {K{1'b0}}) ? E_BUSY : OK;
    reg [7:0] wst;
    always @(*) begin
        wst = E_ADDR;
        if (is_board && req_addr[11:8] == 4'h0) begin
            case (breg)
                8'h05: wst = OK;
                8'h08: wst = (req_data[0] == 1'b0 && estop_in) ? E_ESTOP : OK;
                8'h09: wst = start_st;
                8'h13: wst = sync_en ? start_st : E_ADDR;
                8'h14, 8'h19: wst = sync_en ? OK : E_ADDR;
                8'h0A, 8'h0E, 8'h10, 8'h11, 8'h12, 8'h17:
                    wst = ((req_data & ~AXES_MASK) != 32'd0) ? E_VALUE : OK;
                // a running axis's DIR pin must not flip
                8'h16: wst = ((req_data & ~AXES_MASK) != 32'd0) ? E_VALUE
                           : (((req_data[K-1:0] ^ dir_inv) & core_busy) != {K{1'b0}}) ? E_BUSY : OK;
                8'h0B, 8'h0C, 8'h0F: wst = any_busy ? E_BUSY : OK;
                8'h0D: wst = OK;
                default: wst = E_ADDR;
            endcase
        end else if (ax_ok) begin
            case (areg)
                4'h1: wst = ax_busy ? E_BUSY : OK;
                // StopSlot: the stop ramp moves as a move loaded while it runs takes slots
                4'h4: wst = OK;
                // StreamSteps of an axis replaying a stream: its new step count
                4'h5: wst = (ax_busy && !s_more[ax[LK-1:0]]) ? E_BUSY : OK;
                4'h8: wst = (CHAINS == 0) ? E_ADDR : ax_busy ? E_BUSY : OK;
                default: wst = E_ADDR;
            endcase
        end else if (c_ok) begin
            wst = c_busy ? E_BUSY : OK;
        end
        if (req_bulk) wst = (ax_ok && areg == 4'h7) ? (s_bok ? OK : E_FULL) : E_ADDR;
    end
    wire wr_ok = req && req_wr && (wst == OK);
    wire w_board = wr_ok && is_board;
    wire w_axis  = wr_ok && ax_ok;

    // ---- registers ----
    always @(posedge clk) begin
        free <= free + 1'b1;
        core_wr  <= 1'b0;
        pos_wr   <= {K{1'b0}};
        hall_clr <= {K{1'b0}};
        stop_req <= cut_mask;
        arm_cut  <= arm_expire;
        divert   <= hall_edge & hall_stop & core_busy;
        diverted <= (diverted | (hall_edge & hall_stop)) & core_busy;
        s_arm    <= {K{1'b0}};
        s_retarget <= {K{1'b0}};
        s_commit <= {K{1'b0}};
        s_chain  <= {K{1'b0}};
        sync_prev <= sync_line;
        if (fire_cnt != 8'd0) fire_cnt <= fire_cnt - 1'b1;
        if (sync_edge) sync_tick <= free;
        if (sync_edge && armed) begin
            sync_hit <= 1'b1;
            if (!ready_now) sync_late <= 1'b1;
        end
        if (go || estop || estop_in) begin
            armed    <= 1'b0;
            sync_hit <= 1'b0;
        end
        if (arm_expire) begin
            armed       <= 1'b0;
            arm_expired <= 1'b1;
        end
        if (req) begin
            rsp_status <= req_wr ? wst : (rd_ok ? OK : E_ADDR);
            rsp_data   <= (req_bulk && wst == OK) ? {{(31-LB){1'b0}}, s_free - {{(LB-7){1'b0}}, req_data[7:0]}}
                        : (req_wr || !rd_ok) ? 32'd0 : rd;
        end
        if (rst) begin
            estop        <= 1'b0;
            session      <= 32'd0;
            bad_frames   <= 16'd0;
            pulse_width  <= {WD{1'b0}};
            dir_setup    <= 32'd0;
            debounce     <= {WD{1'b0}};
            enable       <= {K{1'b0}};
            levels       <= 6'b111111;
            hall_stop    <= {K{1'b0}};
            limit_stop   <= {K{1'b0}};
            stopped      <= {K{1'b0}};
            estopped     <= {K{1'b0}};
            dir_q        <= {K{1'b0}};
            setup_need   <= 32'd0;
            armed        <= 1'b0;
            sync_hit     <= 1'b0;
            sync_late    <= 1'b0;
            fire_cnt     <= 8'd0;
            arm_timeout  <= 32'd0;
            arm_expired  <= 1'b0;
            for (i = 0; i < K; i = i + 1) slot[i] <= {LS{1'b0}};
        end else begin
            if (bad_frame && bad_frames != 16'hFFFF) bad_frames <= bad_frames + 1'b1;
            if (estop_in || (w_board && breg == 8'h08 && req_data[0])) estop <= 1'b1;
            else if (w_board && breg == 8'h08) estop <= 1'b0;
            if (estop_in || estop) estopped <= estopped | core_busy;
            stopped <= stopped | (limit_edge & limit_stop & core_busy)
                               | (hall_edge & hall_stop & core_busy);
            if (w_board) begin
                case (breg)
                    8'h09, 8'h13: begin
                        armed      <= (breg == 8'h13);
                        if (breg == 8'h13) begin
                            arm_mask    <= mask;
                            arm_expired <= 1'b0;
                        end
                        sync_hit   <= 1'b0;
                        sync_late  <= 1'b0;
                        core_wr    <= 1'b1;
                        core_addr  <= {1'b1, {(AW-6){1'b0}}, 5'd2};
                        core_data  <= req_data;
                        dir_q      <= (dir_q & ~mask) | (core_dir & mask);
                        stopped    <= stopped & ~mask;
                        estopped   <= estopped & ~mask;
                        setup_need <= setup_sum[32] ? 32'hFFFF_FFFF : setup_sum[31:0];
                    end
                    8'h0A: begin
                        armed    <= 1'b0;   // a stop cancels a group waiting for SYNC
                        stop_req <= mask | cut_mask;
                        stopped  <= stopped | (mask & core_busy);
                    end
                    8'h05: session     <= req_data;
                    8'h0B: pulse_width <= req_data[WD-1:0];
                    8'h0C: dir_setup   <= req_data;
                    8'h0D: debounce    <= req_data[WD-1:0];
                    8'h0E: enable      <= mask;
                    8'h0F: levels      <= req_data[5:0];
                    8'h10: hall_stop   <= mask;
                    8'h11: limit_stop  <= mask;
                    8'h16: dir_inv     <= mask;
                    8'h17: en_low      <= mask;
                    8'h12: begin
                        hall_clr <= mask;
                        stopped  <= stopped & ~mask;
                        estopped <= estopped & ~mask;
                    end
                    8'h14: fire_cnt <= SP;
                    8'h19: arm_timeout <= req_data;
                    default: ;
                endcase
            end
            if (w_axis) begin
                if (areg == 4'h1) pos_wr[ax[LK-1:0]] <= 1'b1;
                if (areg == 4'h4) slot[ax[LK-1:0]] <= req_data[LS-1:0];
                // on an axis replaying a stream: its new step count
                if (areg == 4'h5 && !req_bulk) begin
                    if (ax_busy) s_retarget[ax[LK-1:0]] <= 1'b1;
                    else s_arm[ax[LK-1:0]] <= 1'b1;
                end
                if (areg == 4'h8 && !req_bulk) s_chain[ax[LK-1:0]] <= 1'b1;
                if (req_bulk) s_commit[ax[LK-1:0]] <= 1'b1;
            end
            if (wr_ok && is_core) begin
                core_wr   <= 1'b1;
                core_addr <= req_addr[AW-1:0];
                core_data <= req_data;
            end
        end
    end
    // the DIR setup: the group goes no earlier than dir_setup + n + 2 clocks after the
    // start write (n axes), as the core TDM model's start = max(dir_setup, prefill) from
    // its tick 0, which is n + 2 clocks after the start write (docs/HDL.md, "Tick 0");
    // an Arm is a start write too (its group then also waits for SYNC)
    always @(posedge clk) begin
        if (w_board && (breg == 8'h09 || breg == 8'h13)) setup_cnt <= 32'd0;
        else if (setup_cnt != 32'hFFFF_FFFF) setup_cnt <= setup_cnt + 1'b1;
    end
    assign sync_oe = sync_en && (fire_cnt != 8'd0);
    assign go = ready_now && !estop && !estop_in && !arm_cut && (!armed || sync_hit || sync_edge);
    assign halt = (rst || estop || estop_in) ? {K{1'b1}}
                 : (stop_req | (limit_edge & limit_stop) | (hall_edge & hall_stop & s_more));
endmodule
