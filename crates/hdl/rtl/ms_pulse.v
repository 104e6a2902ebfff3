// ms_pulse: one axis's pulse unit, the core TDM model's (multistep_core::tdm::pulse). On
// `go` it takes the first period from its FIFO; STEP rises when a period has elapsed (the
// edge tick) and stays high for half of the interval to the next edge (50 % duty, seed 000;
// the last pulse for half of its own interval, at least one tick). An underrun (period
// over, FIFO empty, more steps to come) is flagged; the period is loaded as it arrives, so
// that edge and the later ones are late by the delay, and STEP stays high until then, then
// for what is left of half the interval from its rise to the next edge. The wait is
// counted up to 2^(WP-1) ticks (0.168 s at 50 MHz, WP = 24); a longer one as that long.
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
    // ticks left in the current period; while waiting for a period, minus the ticks waited
    // (at most 2^(WP-1))
    reg [WP-1:0] cnt;
    reg [WP-1:0] hcnt;   // ticks left of STEP high
    reg [WP-1:0] half;   // half of the interval in progress: the last pulse's high time
    reg          waiting;
    reg          last;   // the edge of the last step has been made
    wire edge_now = running && !waiting && !last && (cnt == {{(WP-1){1'b0}}, 1'b1});
    wire start    = go && !running && !empty;
    wire late_in  = waiting && arrive;   // the missing period, loaded as it is pushed
    assign pop = !halt && (start || late_in || (edge_now && (!empty || arrive)));
    // The held pulse rose `w` = -cnt ticks ago; the interval to the next edge is ain + w:
    // STEP stays high for (ain - w) / 2 more ticks when positive.
    // the next period: the FIFO's head, or the one being pushed into an empty FIFO (one
    // multiplexer for cnt, hcnt and half; `start` needs a non-empty FIFO, so din there)
    wire [WP-1:0] nx   = empty ? ain : din;
    wire [WP-1:0] nx_h = {1'b0, nx[WP-1:1]};
    wire [WP:0] cnt_s = {cnt[WP-1], cnt};
    wire [WP:0] rest  = {1'b0, ain} + cnt_s;
    /* verilator lint_off UNUSED */  // only half of it is kept
    wire [WP:0] span  = {1'b0, ain} - cnt_s;
    /* verilator lint_on UNUSED */
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
            cnt      <= nx;
            half     <= nx_h;
            running  <= 1'b1;
            underrun <= 1'b0;
            waiting  <= 1'b0;
            last     <= 1'b0;
        end else if (running) begin
            if (edge_now) begin
                step <= 1'b1;
                if (!empty || arrive) begin
                    // from the FIFO, or the period arrives just in time
                    cnt  <= nx;
                    hcnt <= nx_h;
                    half <= nx_h;
                end else if (more) begin
                    // STEP stays high until the period arrives; cnt counts the wait down
                    underrun <= 1'b1;
                    waiting  <= 1'b1;
                    cnt      <= {WP{1'b1}};
                end else begin
                    // the last step: high for half of the period just ended (>= 1)
                    hcnt <= (half == {WP{1'b0}}) ? {{(WP-1){1'b0}}, 1'b1} : half;
                    last <= 1'b1;
                end
            end else if (late_in) begin
                cnt     <= ain;
                half    <= span[WP:1];
                waiting <= 1'b0;
                if (rest[WP] || rest[WP:1] == {WP{1'b0}}) begin
                    step <= 1'b0;
                end else begin
                    hcnt <= rest[WP:1];
                end
            end else if (waiting) begin
                // the count saturates at -2^(WP-1) rather than wrap: a longer wait is taken
                // as 2^(WP-1) ticks for the held pulse's fall (before the next edge, later
                // than the model's when ain > 2^(WP-1) + 1) and the half interval after it
                // (the last pulse's width); the edges stay exact
                if (cnt != {1'b1, {(WP-1){1'b0}}}) cnt <= cnt - 1'b1;
                if (!more) begin
                    waiting <= 1'b0;   // cannot happen: `more` falls with the last push
                    running <= 1'b0;
                end
            end else begin
                if (!last) cnt <= cnt - 1'b1;
                if (step) begin
                    if (hcnt == {{(WP-1){1'b0}}, 1'b1}) begin
                        step <= 1'b0;
                        if (last) running <= 1'b0;
                    end
                    hcnt <= hcnt - 1'b1;
                end
            end
        end
    end
endmodule
