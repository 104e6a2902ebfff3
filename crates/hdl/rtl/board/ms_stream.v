// ms_stream: one axis's replay unit for a host-computed edge schedule (multistep_core::
// stream, docs/HDL.md "Streamed moves"). The host arms it with the move's step count
// (which clears its byte buffer), fills the buffer with bulk frames and keeps it ahead;
// from the core's init of the axis at the group's start the unit decodes the nibble code
// into periods (ms_nibble) and pushes them into the axis's FIFO, whose pulse unit makes
// the edges as for computed pieces. (ms_replay is the same for K axes with one decoder.)
// A bulk frame's bytes are written past the committed data and committed only when its
// CRC checked (bcommit), and only if it fit the free space when it began (bok).
// A decoded period of 0 or wider than WD bits stops the decoder (fault): the axis
// underruns, flagged, until the host stops it.
// A StreamSteps write while the axis runs (retarget) sets the running stream's step count
// to arm_steps, so an open-ended stream (armed for the most steps) ends cleanly after the
// steps the host coded; a count at or below the steps decoded ends it after them.
// With CH = 1 a ChainSteps write (arm_ch) arms a chain run instead: the decoder rests, a
// chain unit (ms_chain_axis) takes the buffer's bytes (pop, avail, rbyte) as piece records
// and each period it pushes (xpush) counts as a step.
module ms_stream #(
    parameter WD = 24,
    parameter LB = 9,      // buffer of 2^LB bytes
    parameter CH = 0       // 1: chain runs (arm_ch, pop, xpush)
) (
    input  wire          clk,
    input  wire          rst,
    input  wire          arm,       // StreamSteps write: the next start of the axis replays
    input  wire [31:0]   arm_steps, // that many steps (0 disarms)
    input  wire          retarget_in, // StreamSteps write while the axis runs: its count
    input  wire          bopen,     // a bulk frame for this axis begins, blen bytes
    input  wire [7:0]    blen,
    input  wire          bwr,       // its byte bidx
    input  wire [7:0]    bidx,
    input  wire [7:0]    bbyte,
    input  wire          bcommit,   // its CRC checked and it was accepted
    input  wire          init,      // the core initializes the axis (the group's start)
    input  wire          halt,
    input  wire          full,      // the axis's FIFO
    input  wire          arm_ch,    // ChainSteps write: the next start runs a chain
    input  wire          pop,       // a chain run takes the byte at rbyte
    input  wire          xpush,     // a chain run pushed a period
    output wire          avail,     // bytes in the buffer
    output wire [7:0]    rbyte,     // the next byte (valid a clock after it became next)
    output wire          feed,      // a chain run with steps left
    output wire          armed,
    output reg           bok,       // the open bulk frame fits
    output wire [LB:0]   free,      // free bytes in the buffer
    output wire          push,
    output wire [WD-1:0] period,
    output wire          more,      // periods still to push
    output reg           fault
);
    localparam [1:0] S_FETCH = 2'd0, S_LOAD = 2'd1, S_DEC = 2'd2;
    reg [7:0]  mem [0:(1<<LB)-1];
    reg [LB:0] wp, rp;
    reg [7:0]  rdata, cur;
    reg        arm_q, run, half;
    reg        ch_q, ch;   // armed for / running a chain
    wire       left_nz;    // periods to go (ms_step_count)
    reg [1:0]  st;
    reg [1:0]  esc;        // 0 op, 1 change (2 nibbles), 2 period (6 nibbles)
    reg [2:0]  got;
    reg [19:0] acc;        // the nibbles so far of a 14 or 15 code, shifted in at the top
    reg [24:0] prev;
    initial begin
        wp = {(LB+1){1'b0}};
        rp = {(LB+1){1'b0}};
        arm_q = 1'b0;
        run = 1'b0;
        ch_q = 1'b0;
        ch = 1'b0;
        pv_ok = 1'b0;
        fault = 1'b0;
        bok = 1'b0;
    end
    assign armed = arm_q;
    assign free  = {1'b1, {LB{1'b0}}} - (wp - rp);
    assign more  = run && (left_nz || pv_ok || fault);
    wire        chain   = (CH != 0) && ch;
    assign avail = (rp != wp);
    assign rbyte = rdata;
    assign feed  = run && chain && left_nz;

    // ---- the buffer ----
    /* verilator lint_off WIDTH */
    wire [LB-1:0] waddr = wp[LB-1:0] + bidx;
    /* verilator lint_on WIDTH */
    always @(posedge clk) begin
        if (bwr && bok) mem[waddr] <= bbyte;
        rdata <= mem[rp[LB-1:0]];
    end

    // ---- the nibble decoder ----
    wire [3:0]  n      = half ? cur[7:4] : cur[3:0];
    wire        done_p;
    wire [24:0] p;
    wire [1:0]  esc_n;
    wire [2:0]  got_n;
    wire [19:0] acc_n;
    ms_nibble u_nib (.n(n), .esc(esc), .got(got), .acc(acc), .prev(prev), .done(done_p), .p(p),
        .esc_n(esc_n), .got_n(got_n), .acc_n(acc_n));
    // a decoded period waits one clock in pv (checked there), so no nibble is decoded
    // while one waits: the FIFO's room seen at decode is still there at the push
    reg         pv_ok;     // pv holds a decoded period
    reg  [24:0] pv;
    wire dec     = run && (st == S_DEC) && !full && left_nz && !fault && !pv_ok;
    wire p_bad   = (pv == 25'd0) || (pv[24:WD] != {(25-WD){1'b0}});
    assign push   = pv_ok && !p_bad && run;
    assign period = pv[WD-1:0];

    // a step: a chain run's period pushed, or a decoded one (pushed the clock after)
    wire stepped = run && (chain ? xpush : (st == S_DEC && dec && done_p));
    ms_step_count u_steps (.clk(clk), .rst(rst), .load(arm || (arm_ch && CH != 0)),
        .halt(halt), .init(init), .retarget(retarget_in && more), .step(stepped),
        .count(arm_steps), .left_nz(left_nz));
    always @(posedge clk) begin
        if (bcommit) wp <= wp + {{(LB-7){1'b0}}, blen};
        if (rst) begin
            wp    <= {(LB+1){1'b0}};
            rp    <= {(LB+1){1'b0}};
            arm_q <= 1'b0;
            run   <= 1'b0;
            fault <= 1'b0;
            pv_ok <= 1'b0;
        end else if (arm || (arm_ch && CH != 0)) begin
            wp    <= {(LB+1){1'b0}};
            rp    <= {(LB+1){1'b0}};
            arm_q <= (arm_steps != 32'd0);
            ch_q  <= arm_ch && !arm;
        end else if (halt) begin
            run   <= 1'b0;
            pv_ok <= 1'b0;
        end else if (init) begin
            run   <= arm_q;
            ch    <= ch_q;
            arm_q <= 1'b0;
            prev  <= 25'd0;
            st    <= S_FETCH;
            esc   <= 2'd0;
            fault <= 1'b0;
            pv_ok <= 1'b0;
        end else begin
            pv_ok <= 1'b0;
            if (pv_ok && p_bad) fault <= 1'b1;
            if (run && chain) begin
                if (pop && avail) rp <= rp + 1'b1;
            end else if (run) begin
                case (st)
                    S_FETCH: if (rp != wp && left_nz) begin
                        rp <= rp + 1'b1;
                        st <= S_LOAD;
                    end
                    S_LOAD: begin
                        cur  <= rdata;
                        half <= 1'b0;
                        st   <= S_DEC;
                    end
                    default: if (dec) begin
                        half <= 1'b1;
                        if (half) st <= S_FETCH;
                        if (done_p) begin
                            esc   <= 2'd0;
                            prev  <= p;
                            pv    <= p;
                            pv_ok <= 1'b1;
                        end else begin
                            esc <= esc_n;
                            got <= got_n;
                            acc <= acc_n;
                        end
                    end
                endcase
            end
        end
        if (bopen) bok <= ({{(LB-7){1'b0}}, blen} <= free) && !rst;
    end
endmodule
