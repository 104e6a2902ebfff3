// ms_uart_tx: UART transmitter, 8N1, DIV clocks per bit. `start` is taken when `busy` is
// low; `busy` is high from the next clock until the stop bit has been sent.
module ms_uart_tx #(
    parameter DIV = 16
) (
    input  wire       clk,
    input  wire       rst,
    input  wire       start,
    input  wire [7:0] data,
    output reg        tx,
    output wire       busy
);
    reg [8:0]  sh;    // data bits still to send, then the stop bit
    reg [3:0]  left;  // bit times left, the current one included
    localparam integer DIV_M1 = DIV - 1;
    reg [15:0] cnt;
    initial begin
        tx = 1'b1;
        left = 4'd0;
    end
    assign busy = (left != 4'd0);
    always @(posedge clk) begin
        if (rst) begin
            tx   <= 1'b1;
            left <= 4'd0;
        end else if (left == 4'd0) begin
            if (start) begin
                tx   <= 1'b0;   // start bit
                sh   <= {1'b1, data};
                left <= 4'd10;
                cnt  <= DIV_M1[15:0];
            end
        end else if (cnt != 16'd0) begin
            cnt <= cnt - 1'b1;
        end else begin
            cnt  <= DIV_M1[15:0];
            left <= left - 1'b1;
            if (left != 4'd1) begin
                tx <= sh[0];
                sh <= {1'b1, sh[8:1]};
            end
        end
    end
endmodule
