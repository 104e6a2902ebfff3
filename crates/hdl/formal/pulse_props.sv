// ms_pulse, its periods always in the FIFO in time (no underrun: the underrun path is
// co-simulated in tests/pulse.rs) and at least 2 ticks long: every STEP rise comes exactly
// the loaded period after the previous one (the first one the first period after the go),
// so none comes while the period is still counting; STEP stays high for half of the
// interval to the next edge (50 % duty, seed 000), the last pulse for half of the
// interval before it (at least 1); the clock after `halt` STEP is low; the unit pops only
// a word that is there (FIFO not empty, or the word being pushed).
// MUTATE expects every interval one tick longer: the check must then fail.
module pulse_props #(
    parameter WP = 3
) (
    input wire          clk,
    input wire          go,
    input wire [WP-1:0] din,
    input wire          empty,
    input wire          more,
    input wire          arrive,
    input wire [WP-1:0] ain,
    input wire          halt
);
    wire pop, step, running, underrun;
    ms_pulse #(.WP(WP)) dut (
        .clk(clk), .go(go), .din(din), .empty(empty), .more(more), .arrive(arrive),
        .ain(ain), .halt(halt), .clear(1'b0), .pop(pop), .step(step), .running(running),
        .underrun(underrun), .period());

`ifdef MUTATE
    localparam [WP:0] SLIP = 1;
`else
    localparam [WP:0] SLIP = 0;
`endif
    reg          init = 1'b1;
    reg          step_d = 1'b0;  // STEP one clock ago
    reg          halt_d = 1'b0;
    reg          valid = 1'b0;   // a move started since the last halt: the trackers hold
    reg [WP-1:0] ld;             // the period taken by the last pop
    reg          ld_pop = 1'b0;  // the last clock popped
    reg [WP:0]   age;            // clocks since the last rise (or the go)
    reg [WP-1:0] cur;            // the interval that ends at the next rise
    reg [WP-1:0] prev;           // the interval that ended at the last rise
    reg          tail = 1'b0;    // the pulse in progress is the last
    reg [WP:0]   hi;             // clocks STEP has been high
    wire rise = step && !step_d;
    wire fall = !step && step_d;
    wire [WP-1:0] half_last = (prev[WP-1:1] == 0) ? 1 : {1'b0, prev[WP-1:1]};

    always @(*) begin
        // the environment: no underrun, periods of >= 2 ticks,
        // and the go only from reset (the unit starts from its initial state)
        assume(!arrive);
        assume(!more || !empty);
        assume(din >= 2);
        if (init) assume(!go);
        assert(!pop || !empty || arrive);
        assert(!underrun);
        if (halt_d) assert(!step);
        if (valid && rise) assert(age == {1'b0, cur} + SLIP);
        if (valid && fall && !tail) assert(hi == {2'b0, cur[WP-1:1]});
        if (valid && fall && tail) assert(hi == {1'b0, half_last});
        // every checked case is reached (yosys-smtbmc -c)
        cover(valid && rise && tail == 1'b0 && age > 2);
        cover(valid && fall && !tail && cur[WP-1:1] > 1);
        cover(valid && fall && tail);
        cover(halt_d && step_d);
    end

    always @(posedge clk) begin
        init   <= 1'b0;
        step_d <= step;
        halt_d <= halt;
        ld_pop <= pop;
        if (pop) ld <= din;
        hi  <= step ? hi + 1'b1 : 0;
        age <= age + 1'b1;
        if (halt) begin
            valid <= 1'b0;
        end else if (pop && !running) begin
            valid <= 1'b1;
            cur   <= din;
            age   <= 0;
            tail  <= 1'b0;
        end else if (rise) begin
            age  <= 1;
            prev <= cur;
            // a rise with no pop is the last edge
            if (ld_pop) cur <= ld;
            else tail <= 1'b1;
        end
    end
endmodule
