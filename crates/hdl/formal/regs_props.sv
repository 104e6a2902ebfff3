// ms_regs, its DIR setup (K = 2): a group's go comes no earlier than DirSetup + n + 2 clocks
// after its start write took effect (n axes in the group; the core's tick 0 is n + 2 clocks
// after it, docs/HDL.md "Tick 0"), with DirSetup as the host last wrote it; and an axis's DIR
// level (its latched DIR, its DirInvert bit and the board's DIR level) never changes while
// the core reports the axis busy, which it does from the start write on, so DIR holds from
// the start through the setup to the move's last edge.
// The core is modelled as far as the checks need: pending from the clock after its start
// write until the go, busy for the pending group and whenever the environment says so,
// ready whenever the environment says so while pending. Requests come at least 4 clocks
// apart (a link frame takes hundreds of clocks); the board is reset in the first clock and
// not again (a reset halts every axis).
// MUTATE expects one clock more of setup: the check must then fail.
module regs_props (
    input wire        clk,
    input wire        req,
    input wire        req_wr,
    input wire [15:0] req_addr,
    input wire [31:0] req_data,
    input wire        req_bulk,
    input wire [1:0]  busy_x,     // the axes' moves (the core's busy beside the pending group)
    input wire        ready_x,
    input wire [1:0]  core_dir,   // the DIR bits of the core's control words
    input wire [1:0]  slot_x,     // the slot the core reports for the bus request's axis
    input wire        estop_in,
    input wire        sync_line,
    input wire [1:0]  hall_edge,
    input wire [1:0]  limit_edge
);
    wire [7:0]  rsp_status;
    wire        core_wr, go;
    wire [6:0]  core_addr;
    wire [31:0] core_data;
    wire [1:0]  dir_q, dir_inv;
    wire [5:0]  levels;
    reg         pending = 1'b0;   // the core's pending group
    reg  [1:0]  group = 2'b00;
    wire [1:0]  core_busy = busy_x | (pending ? group : 2'b00);
    /* the outputs not checked here are left open */
    ms_regs #(.K(2), .LK(1), .LS(2), .AW(7), .WD(4), .LF(2), .LB(8), .SYNC(1), .CHAINS(0))
    dut (
        .clk(clk), .rst(init), .req(req), .req_wr(req_wr), .req_addr(req_addr),
        .req_data(req_data), .req_bulk(req_bulk), .rsp_status(rsp_status), .rsp_data(),
        .core_wr(core_wr), .core_addr(core_addr), .core_data(core_data),
        .core_busy(core_busy), .core_underrun(2'b00), .core_dir(core_dir),
        .core_slot_ax(), .core_slot(slot_x),
        .core_pending(pending), .core_ready(ready_x && pending), .go(go), .halt(),
        .divert(), .div_slot(), .dir_q(dir_q), .pulse_width(),
        .debounce(), .enable(), .levels(levels), .dir_inv(dir_inv), .en_low(), .pos_wr(),
        .hall_clr(), .rd_pos(32'd0), .rd_hall(32'd0), .hall_flag(2'b00), .hall_lvl(2'b00),
        .hall_edge(hall_edge), .limit_lvl(2'b00), .limit_edge(limit_edge), .period(8'd0),
        .estop_in(estop_in), .estop(), .rx_line(1'b1), .bad_frame(1'b0),
        .sync_line(sync_line), .sync_oe(), .s_arm(), .s_retarget(), .s_commit(), .s_chain(),
        .s_armed(2'b00), .s_bok(1'b1), .s_free(9'd0), .s_more(2'b00), .s_fault(2'b00));

`ifdef MUTATE
    localparam [33:0] SLIP = 1;
`else
    localparam [33:0] SLIP = 0;
`endif
    reg        init = 1'b1;
    reg        reset_d = 1'b1;     // the clock after the reset (the levels take their value)
    reg  [3:0] quiet = 4'd0;       // clocks since the last request (saturating)
    reg        last_ds = 1'b0;     // the last request wrote DirSetup
    reg [31:0] last_data;
    reg [31:0] ds = 32'd0;         // DirSetup as the host wrote it
    reg        armed = 1'b0;       // a start write took effect; its go has not come
    reg [33:0] age = 0;            // clocks since then
    reg [33:0] need = 0;           // DirSetup + n + 2 at that time
    reg  [1:0] busy_d = 2'b00;
    wire [1:0] level = dir_q ^ dir_inv ^ {2{levels[1]}};
    reg  [1:0] level_d;
    // a start write on the core's bus: its axes
    wire       start_wr  = core_wr && core_addr == 7'b1000010;
    wire [1:0] start_ax  = start_wr ? core_data[1:0] : 2'b00;
    wire       start_now = (start_ax != 2'b00);
    wire [1:0] n = {1'b0, start_ax[0]} + {1'b0, start_ax[1]};

    always @(*) begin
        if (req) assume(quiet >= 4'd4 || init);
        if (init) assume(!req);
        if (armed && go) assert(age >= need + SLIP);
        if (!reset_d && busy_d[0]) assert(level[0] == level_d[0]);
        if (!reset_d && busy_d[1]) assert(level[1] == level_d[1]);
        // every checked case is reached (yosys-smtbmc -c)
        cover(armed && go && need == 34'd6 && age == need);
        cover(start_now && level != level_d);
    end

    always @(posedge clk) begin
        init    <= 1'b0;
        reset_d <= init;
        busy_d  <= core_busy;
        level_d <= level;
        quiet   <= req ? 4'd1 : (quiet == 4'd15 ? quiet : quiet + 1'b1);
        // a request's status comes the clock after it
        last_ds   <= req && req_wr && !req_bulk && req_addr == 16'h000C;
        last_data <= req_data;
        if (last_ds && rsp_status == 8'd0) ds <= last_data;
        // the core: a start write on its bus makes the group pending until the go
        if (start_wr) begin
            pending <= 1'b1;
            group   <= core_data[1:0];
        end else if (go) begin
            pending <= 1'b0;
        end
        if (start_now) begin
            armed <= 1'b1;
            age   <= 1;
            need  <= {2'b00, ds} + n + 2;
        end else begin
            age <= age + 1'b1;
            if (go) armed <= 1'b0;
        end
    end
endmodule
