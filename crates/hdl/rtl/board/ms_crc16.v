// ms_crc16: one byte of CRC-16/CCITT-FALSE (also called CRC-16/IBM-3740: polynomial
// 0x1021, initial value 0xFFFF, no reflection, no final xor), combinational. A frame
// followed by its CRC (high byte first) leaves the register at 0.
module ms_crc16 (
    input  wire [15:0] crc,
    input  wire [7:0]  data,
    output reg  [15:0] next
);
    integer i;
    always @(*) begin
        next = crc ^ {data, 8'h00};
        for (i = 0; i < 8; i = i + 1)
            next = next[15] ? ({next[14:0], 1'b0} ^ 16'h1021) : {next[14:0], 1'b0};
    end
endmodule
