// ms_uart_rx: UART receiver, 8 data bits, no parity, 1 stop bit (8N1), least significant
// bit first. DIV clocks per bit (CLK_HZ / BAUD rounded; the host's rate must be within
// about 3 % of CLK_HZ / DIV). Each bit is sampled once, at its middle; `rx` must already
// be synchronized. A byte whose stop bit is low is dropped and flagged (`frame_err`).
module ms_uart_rx #(
    parameter DIV = 16   // >= 4
) (
    input  wire       clk,
    input  wire       rst,
    input  wire       rx,
    output reg        valid,      // one clock: `data` holds a received byte
    output reg  [7:0] data,
    output reg        frame_err,  // one clock: a byte with a bad stop bit was dropped
    output reg        busy        // inside a character
);
    localparam integer DIV_M1 = DIV - 1;
    localparam integer HALF_M1 = DIV / 2 - 1;
    reg [15:0] cnt;   // clocks to the next sample
    reg [3:0]  bitn;  // 0 start bit, 1-8 data bits, 9 stop bit
    reg [7:0]  sh;
    initial begin
        busy = 1'b0;
        valid = 1'b0;
        frame_err = 1'b0;
    end
    always @(posedge clk) begin
        valid     <= 1'b0;
        frame_err <= 1'b0;
        if (rst) begin
            busy <= 1'b0;
        end else if (!busy) begin
            if (!rx) begin
                busy <= 1'b1;
                bitn <= 4'd0;
                cnt  <= HALF_M1[15:0];   // to the middle of the start bit
            end
        end else if (cnt != 16'd0) begin
            cnt <= cnt - 1'b1;
        end else begin
            cnt <= DIV_M1[15:0];
            if (bitn == 4'd0) begin
                if (rx) busy <= 1'b0;  // a glitch, not a start bit
                else bitn <= 4'd1;
            end else if (bitn != 4'd9) begin
                sh   <= {rx, sh[7:1]};
                bitn <= bitn + 1'b1;
            end else begin
                busy <= 1'b0;
                if (rx) begin
                    valid <= 1'b1;
                    data  <= sh;
                end else begin
                    frame_err <= 1'b1;
                end
            end
        end
    end
endmodule
