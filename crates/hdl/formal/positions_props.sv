// ms_positions with its words in memories (MEM = 1; K = 3, so the scanner wraps before a
// power of two; 6-bit words): its formal block holds the definition (MEM = 0's counter
// and latch per axis) beside it and asserts that every word, delta and readback agrees
// with it at every clock, for any rises, directions, latches, writes, resets and
// requests. The environment is ms_regs's: a request (`rd`, reading back axis `ax`) never
// in two consecutive clocks nor in the clock after a write, and a position write, of one
// axis, only in the clock after a request.
module positions_props (
    input wire       clk,
    input wire       rst_in,
    input wire [2:0] cnt,
    input wire [2:0] up,
    input wire [2:0] latch,
    input wire [2:0] wr,
    input wire [5:0] din,
    input wire       rd,
    input wire [1:0] ax
);
    reg        rst = 1'b1;          // the first clock is a reset
    reg        wr_d = 1'b0, rd_d = 1'b0, rst_d = 1'b0;
    reg  [2:0] latched = 3'b000, cnt_d = 3'b000, latch_d = 3'b000;
    wire       r = rst || rst_in;
    wire [5:0] pos, hall;
    ms_positions #(.K(3), .LK(2), .MEM(1), .W(6)) dut (.clk(clk), .rst(r), .cnt(cnt), .up(up),
        .latch(latch), .wr(wr), .din(din), .rd(rd), .ax(ax), .rd_pos(pos), .rd_hall(hall));

    always @(*) begin
        assume(ax != 2'd3);
        assume((wr & (wr - 3'd1)) == 3'd0);
        if (wr != 3'b000) assume(rd_d);
        if (rd_d || wr_d) assume(!rd);
        // a latch in a clock with a rise of its axis holds the position before the rise
        cover(rd && latch_d[ax] && cnt_d[ax] && hall != pos);
        // a latch taken before a reset, read after it
        cover(rd && rst_d && !r && latched[ax] && hall != 6'd0 && pos == 6'd0);
    end
    always @(posedge clk) begin
        rst     <= 1'b0;
        wr_d    <= wr != 3'b000;
        rd_d    <= rd;
        latched <= latched | latch;
        cnt_d   <= cnt;
        latch_d <= latch;
        rst_d   <= r;
    end
endmodule
