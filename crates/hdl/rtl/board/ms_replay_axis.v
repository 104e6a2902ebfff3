// ms_replay_axis: one axis's part of the shared replay unit (ms_replay): whether its
// buffer's pointers read as 0 (since an arm or a reset; the pointers themselves are in
// ms_replay's memories: the write pointer, the next byte to fetch), and where its
// decoding stands between the decoder's turns: whether the high nibble of the byte before
// is still to be decoded (hp; the byte itself is free for the host again, the nibble is in
// ms_replay's memory), and whether it has a last period yet (`fresh`: not since init; the
// period itself is in ms_replay's memory too). Arm, retarget, init, halt and the fault are ms_stream's; the step count is
// ms_replay's (ms_step_counts, all axes' in two memories), which tells `left_nz`.
module ms_replay_axis (
    input  wire          clk,
    input  wire          rst,
    input  wire          arm,       // StreamSteps write: the next start of the axis replays
    input  wire [31:0]   arm_steps, // that many steps (0 disarms)
    input  wire          retarget_in, // StreamSteps write while the axis runs: its count
    input  wire          bcommit,   // a frame for this axis: its CRC checked, and it fit
    input  wire          init,      // the core initializes the axis (the group's start)
    input  wire          halt,
    input  wire          left_nz,   // periods to go (ms_step_counts)
    // the decoder
    input  wire          serve,     // it decoded this axis's next period: take n_hp
    input  wire          n_hp,
    input  wire          pend,      // a decoded period of this axis is pushed this clock
    input  wire          pbad,      // ... unless it is bad (0 or too wide): the fault
    output wire          armed,
    output wire          push,
    output wire          more,      // periods still to push
    output wire          retarget,  // the count's retarget: the stream runs
    output reg           fault,
    output reg           wz,        // the write pointer reads 0 (not written since)
    output reg           rz,        // the read pointer reads 0 (not written since)
    output reg           hp,
    output reg           fresh,
    output wire          ready,     // running with periods to go and no fault (flip-flops)
    output wire          live       // ... and not stopped now: a period decoded may be taken
);
    reg        arm_q, run;
    initial begin
        wz = 1'b1;
        rz = 1'b1;
        hp = 1'b0;
        fresh = 1'b1;
        arm_q = 1'b0;
        run = 1'b0;
        fault = 1'b0;
    end
    assign armed = arm_q;
    assign more  = run && (left_nz || pend || fault);
    assign push  = pend && !pbad && run;
    assign ready = run && left_nz && !fault;
    assign live  = ready && !arm && !halt && !init && !rst;
    assign retarget = retarget_in && more;

    always @(posedge clk) begin
        // the memories take the new pointer in the same clock
        if (bcommit) wz <= 1'b0;
        if (rst) begin
            wz    <= 1'b1;
            rz    <= 1'b1;
            arm_q <= 1'b0;
            run   <= 1'b0;
            fault <= 1'b0;
        end else if (arm) begin
            wz    <= 1'b1;
            rz    <= 1'b1;
            hp    <= 1'b0;
            arm_q <= (arm_steps != 32'd0);
        end else if (halt) begin
            run <= 1'b0;
        end else if (init) begin
            run     <= arm_q;
            arm_q   <= 1'b0;
            fresh   <= 1'b1;
            hp      <= 1'b0;
            fault   <= 1'b0;
        end else begin
            if (pend && pbad) fault <= 1'b1;
            if (serve) begin
                rz    <= 1'b0;
                hp    <= n_hp;
                fresh <= 1'b0;
            end
        end
    end
endmodule
