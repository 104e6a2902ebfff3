// ms_pulse: one axis's pulse unit. On `go` it takes the first period from its FIFO; STEP
// rises when a period has elapsed (the edge tick) and stays high for half of the next period
// (50 % duty, seed 000). An underrun (period over, FIFO empty, more steps to come) is
// flagged and the edge waits for data.
module ms_pulse #(
    parameter WP = 24
) (
    input  wire          clk,
    input  wire          go,
    input  wire [WP-1:0] din,
    input  wire          empty,
    input  wire          more,      // the calculator still owes this axis periods
    output wire          pop,
    output reg           step,
    output reg           running,
    output reg           underrun
);
    reg [WP-1:0] cnt;    // ticks left in the current period
    reg [WP-1:0] hcnt;   // ticks left of STEP high
    reg [WP-1:0] half;   // half of the period in progress: the last pulse's high time
    reg          waiting;
    reg          last;   // the edge of the last step has been made
    wire edge_now = running && !waiting && !last && (cnt == {{(WP-1){1'b0}}, 1'b1});
    wire start    = go && !running && !empty;
    wire refill   = waiting && !empty;
    assign pop = start || refill || (edge_now && !empty);
    initial begin
        step = 1'b0;
        running = 1'b0;
        underrun = 1'b0;
        waiting = 1'b0;
        last = 1'b0;
    end
    always @(posedge clk) begin
        if (start) begin
            cnt      <= din;
            half     <= {1'b0, din[WP-1:1]};
            running  <= 1'b1;
            underrun <= 1'b0;
            waiting  <= 1'b0;
            last     <= 1'b0;
        end else if (running) begin
            if (edge_now) begin
                step <= 1'b1;
                if (!empty) begin
                    cnt  <= din;
                    hcnt <= {1'b0, din[WP-1:1]};
                    half <= {1'b0, din[WP-1:1]};
                end else begin
                    // no next edge known: high for half of the period just ended (>= 1)
                    hcnt <= (half == {WP{1'b0}}) ? {{(WP-1){1'b0}}, 1'b1} : half;
                    if (more) begin
                        underrun <= 1'b1;
                        waiting  <= 1'b1;
                    end else begin
                        last <= 1'b1;
                    end
                end
            end else begin
                if (!waiting && !last) cnt <= cnt - 1'b1;
                if (refill) begin
                    cnt     <= din;
                    half    <= {1'b0, din[WP-1:1]};
                    waiting <= 1'b0;
                end else if (waiting && !more) begin
                    waiting <= 1'b0;   // cannot happen: `more` falls with the last push
                    running <= 1'b0;
                end
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
