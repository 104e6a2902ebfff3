// ms_pulse: one axis's pulse unit, the core TDM model's (multistep_core::tdm::pulse). On
// `go` it takes the first period from its FIFO; STEP rises when a period has elapsed (the
// edge tick) and stays high for half of the interval to the next edge (50 % duty, seed 000;
// the last pulse for half of its own interval, at least one tick). An underrun (period
// over, FIFO empty, more steps to come) is flagged; the period is loaded as it arrives, so
// that edge and the later ones are late by the delay, and STEP stays high until then, then
// for what is left of half the interval from its rise to the next edge. The wait is
// counted up to 2^(WP-1) ticks (0.168 s at 50 MHz, WP = 24); a longer one as that long.
//
// One counter and one period: `u` counts the clocks since STEP's last rise, `per` is the
// interval from that rise to the next edge, so the edge is `u == per` and the fall
// `u == per / 2`: half an interval is wiring, not a second counter (ECP5 327 LUT4-eq and 55
// flip-flops alone, against 379 and 77 for a down-counter of the period, one of the high
// time and a register of the half; iCE40 224 SB_LUT4 against 359).
module ms_pulse #(
    parameter WP = 24
) (
    input  wire          clk,
    input  wire          go,
    input  wire [WP-1:0] din,
    input  wire          empty,
    input  wire          more,      // the calculator still owes this axis periods
    input  wire          arrive,    // a period is being pushed into this axis's FIFO
    input  wire [WP-1:0] ain,       // that period
    input  wire          halt,     // stop now: STEP low, not running (the FIFO is not popped)
    output wire          pop,
    output reg           step,
    output reg           running,
    output reg           underrun
);
    // after an underrun the interval is the wait (at most 2^(WP-1)) plus a period: WP+1 bits
    reg [WP:0] u;       // clocks since the last rise (or the start); saturates while waiting
    reg [WP:0] per;     // the interval that ends at the next edge (the last one's after it)
    reg        waiting; // an underrun: STEP high until the period arrives
    reg        last;    // the edge of the last step has been made
    localparam [WP:0] ONE = 1;
    localparam [WP:0] SAT = ONE << (WP - 1);
    wire edge_now = running && !waiting && !last && (u == per);
    wire start    = go && !running && !empty;
    wire late_in  = waiting && arrive;   // the missing period, loaded as it is pushed
    assign pop = !halt && (start || late_in || (edge_now && (!empty || arrive)));
    // the next period: the FIFO's head, or the one being pushed into an empty FIFO (`start`
    // needs a non-empty FIFO, so din there)
    wire [WP-1:0] nx   = empty ? ain : din;
    wire [WP:0]   u1   = u + ONE;
    // a late period: the interval from the held rise is the wait plus the period
    wire [WP:0]   span = u + {1'b0, ain};
    // STEP falls when half the interval (at least 1) has passed since the rise; at a late
    // arrival at once if that half is already over: span / 2 <= u, that is ain <= u + 1
    wire [WP:0]   h    = (per[WP:1] == {WP{1'b0}}) ? ONE : {1'b0, per[WP:1]};
    wire          fall = (u == h);
    wire          fall_now = ({1'b0, ain} <= u1);
    initial begin
        step = 1'b0;
        running = 1'b0;
        underrun = 1'b0;
        waiting = 1'b0;
        last = 1'b0;
    end
    always @(posedge clk) begin
        if (halt) begin
            step    <= 1'b0;
            running <= 1'b0;
            waiting <= 1'b0;
            last    <= 1'b0;
        end else if (start) begin
            u        <= ONE;
            per      <= {1'b0, nx};
            running  <= 1'b1;
            underrun <= 1'b0;
            waiting  <= 1'b0;
            last     <= 1'b0;
        end else if (running) begin
            if (edge_now) begin
                step <= 1'b1;
                u    <= ONE;
                if (!empty || arrive) begin
                    // from the FIFO, or the period arrives just in time
                    per <= {1'b0, nx};
                end else if (more) begin
                    // STEP stays high until the period arrives; u counts the wait
                    underrun <= 1'b1;
                    waiting  <= 1'b1;
                end else begin
                    // the last step: high for half of the period just ended (>= 1)
                    last <= 1'b1;
                end
            end else if (late_in) begin
                per     <= span;
                u       <= u1;
                waiting <= 1'b0;
                if (fall_now) step <= 1'b0;
            end else if (waiting) begin
                // the wait saturates at 2^(WP-1) rather than wrap: a longer wait is taken
                // as 2^(WP-1) ticks for the held pulse's fall (before the next edge, later
                // than the model's when ain > 2^(WP-1) + 1) and the half interval after it
                // (the last pulse's width); the edges stay exact
                if (u != SAT) u <= u1;
                if (!more) begin
                    waiting <= 1'b0;   // cannot happen: `more` falls with the last push
                    running <= 1'b0;
                end
            end else begin
                u <= u1;
                if (step && fall) begin
                    step <= 1'b0;
                    if (last) running <= 1'b0;
                end
            end
        end
    end
endmodule
