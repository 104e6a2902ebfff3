// ms_pulse: one axis's pulse unit, the core TDM model's (multistep_core::tdm::pulse). On
// `go` it takes the first period from its FIFO; STEP rises when a period has elapsed (the
// edge tick) and falls half that period after it was loaded (50 % duty on time, seed 000;
// the last pulse half of its own period, at least one tick). An underrun (period over,
// FIFO empty, more steps to come) is flagged; STEP stays high, and the period is loaded as
// it arrives, so that edge and the later ones are late by the delay and STEP falls half
// the late period after its arrival: whatever the wait, the line is low for the second
// half of every period.
//
// One counter and one period: `u` counts the clocks since the period was loaded, `per` is
// that period, so the edge is `u == per` and the fall `u == per / 2`: half a period is
// wiring, not a second counter. Every load (the go, an edge, a late arrival) is the same
// `u <= 1, per <= next`, and a wait needs no count, so it is exact however long.
// `per` is also the axis's period readback: the period being timed, 0 from the axis's
// start (`clear`) to its go.
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
    input  wire          clear,    // the axis is started (not running): its period reads 0
    output wire          pop,
    output reg           step,
    output reg           running,
    output reg           underrun,
    output wire [WP-1:0] period
);
    reg [WP-1:0] u;       // clocks since the period was loaded
    reg [WP-1:0] per;     // that period: it ends at the next edge
    reg          waiting; // an underrun: STEP high until the period arrives
    reg          last;    // the edge of the last step has been made
    localparam [WP-1:0] ONE = 1;
    wire edge_now = running && !waiting && !last && (u == per);
    wire start    = go && !running && !empty;
    wire late_in  = waiting && arrive;   // the missing period, loaded as it is pushed
    assign pop = !halt && (start || late_in || (edge_now && (!empty || arrive)));
    // the next period: the FIFO's head, or the one being pushed into an empty FIFO (`start`
    // needs a non-empty FIFO, so din there; a late one arrives while the FIFO is empty)
    wire [WP-1:0] nx   = empty ? ain : din;
    // STEP falls when half the period (at least 1) has passed since its load: u equals
    // per / 2 (u's top bit clear, its others per's upper bits: no shifter, no adder), or
    // at once for a period of 0 or 1 (u is 1 the clock after a load; with a period of 1
    // only the last pulse falls, every other clock is an edge)
    wire          tiny = (per[WP-1:1] == {(WP-1){1'b0}});
    wire          fall = tiny || ({1'b0, u[WP-2:0]} == {u[WP-1], per[WP-1:1]});
    assign period = per;
    initial begin
        per = {WP{1'b0}};
        step = 1'b0;
        running = 1'b0;
        underrun = 1'b0;
        waiting = 1'b0;
        last = 1'b0;
    end
    // every load is one set of u to 1, above its count: a synchronous set, no multiplexer
    // (an edge with no period to load restarts u too: the last pulse's fall counts from it)
    wire u_load = !halt && (start || (running && (edge_now || late_in)));
    wire u_inc  = !halt && running && !waiting;
    always @(posedge clk) begin
        if (u_load) u <= ONE;
        else if (u_inc) u <= u + ONE;
        if (clear) per <= {WP{1'b0}};
        else if (pop) per <= nx;   // a load takes the period it pops
    end
    always @(posedge clk) begin
        if (halt) begin
            step    <= 1'b0;
            running <= 1'b0;
            waiting <= 1'b0;
            last    <= 1'b0;
        end else if (start) begin
            running  <= 1'b1;
            underrun <= 1'b0;
            waiting  <= 1'b0;
            last     <= 1'b0;
        end else if (running) begin
            if (edge_now) begin
                step <= 1'b1;
                // no period in the FIFO, none arriving just in time
                if (empty && !arrive) begin
                    if (more) begin
                        // STEP stays high until the period arrives
                        underrun <= 1'b1;
                        waiting  <= 1'b1;
                    end else begin
                        // the last step: high for half of the period just ended (>= 1)
                        last <= 1'b1;
                    end
                end
            end else if (late_in) begin
                waiting <= 1'b0;
            end else if (waiting) begin
                if (!more) begin
                    waiting <= 1'b0;   // cannot happen: `more` falls with the last push
                    running <= 1'b0;
                end
            end else if (step && fall) begin
                step <= 1'b0;
                if (last) running <= 1'b0;
            end
        end
    end
endmodule
