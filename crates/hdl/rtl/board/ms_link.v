// ms_link: the host link's framing. A request is 11 bytes:
//     0xA5, seq, cmd, addr[7:0], addr[15:8], data[7:0] .. data[31:24], crc[15:8], crc[7:0]
// cmd 0x01 reads the register at addr, 0x02 writes data to it; the CRC is CRC-16/CCITT-FALSE
// over the first 9 bytes (ms_crc16). A reply is 9 bytes:
//     0x5A, seq, status, data[7:0] .. data[31:24], crc[15:8], crc[7:0]
// with the request's seq, the status (0 ok; ms_regs has the codes) and the data read (0
// for a write). A bulk write (cmd 0x03) carries up to 255 bytes for one register:
//     0xA5, seq, 0x03, addr[7:0], addr[15:8], len, byte 0 .. byte len-1, crc[15:8], crc[7:0]
// each byte is handed out as it arrives (bulk_open at len, bulk_wr per byte), and the
// request (req_bulk) follows the CRC only if it checked; the reply is the usual one. Bytes before a 0xA5 are skipped; a frame with a gap of more than GAP clocks
// between bytes is dropped without a reply (so a host resynchronizes by pausing). A frame
// with a bad CRC or command gets a reply with that status and is not executed. Replies
// are shorter than requests, so a host may send requests back to back.
// Exactly once: the last executed frame (seq, command, its first six body bytes and its
// CRC) and its reply are kept; the same frame again is a host's retransmission after a
// reply it lost, answered from the kept reply and not executed again. A host's next
// request has another seq, so only a retransmission matches. Kept over a reset (a start
// executed before it is still answered as done); cleared at configuration.
module ms_link #(
    parameter GAP  = 1024,
    parameter BULK = 1      // 0: no replay units; a bulk frame is framed, then answered
                            // status 7 (no room) here, with no request
) (
    input  wire        clk,
    input  wire        rst,
    input  wire        rx_valid,
    input  wire [7:0]  rx_byte,
    output reg         req,        // one clock: execute {req_wr, req_addr, req_data}
    output reg         req_wr,
    output reg  [15:0] req_addr,
    output reg  [31:0] req_data,
    output reg         req_bulk,   // with req: a bulk write of bulk_len bytes to req_addr
    output reg         bulk_open,  // one clock: a bulk frame for bulk_addr, bulk_len bytes
    output reg  [15:0] bulk_addr,
    output reg  [7:0]  bulk_len,
    output reg         bulk_wr,    // one clock: its byte bulk_idx is bulk_byte
    output reg  [7:0]  bulk_idx,
    output reg  [7:0]  bulk_byte,
    input  wire [7:0]  rsp_status, // the clock after req
    input  wire [31:0] rsp_data,
    output wire        tx_start,
    output wire [7:0]  tx_byte,
    input  wire        tx_busy,
    output reg         bad_frame   // one clock: a frame failed its CRC or command check
);
    localparam [7:0] SYNC_REQ = 8'hA5, SYNC_RSP = 8'h5A;
    localparam [7:0] ST_CRC = 8'h01, ST_CMD = 8'h02, ST_FULL = 8'h07, CMD_BULK = 8'h03;

    // ---- receive ----
    reg  [8:0]  idx;      // bytes of the frame so far
    reg  [15:0] crc;
    reg  [7:0]  seq, cmd;
    reg  [15:0] gap;
    /* verilator lint_off UNUSED */
    reg  [63:0] body;     // addr and data bytes, shifted in (the low 16 bits unused)
    /* verilator lint_on UNUSED */
    wire [15:0] crc_rx;
    ms_crc16 u_crc_rx (.crc(idx == 9'd0 ? 16'hFFFF : crc), .data(rx_byte), .next(crc_rx));
    wire        bulk = (cmd == CMD_BULK);
    wire        bulk_req = bulk && (BULK != 0);   // a bulk frame that becomes a request
    // the frame's last byte: 11-byte requests, 8 + len for a bulk write
    wire [8:0]  last = bulk ? 9'd7 + {1'b0, bulk_len} : 9'd10;
    reg         exec;     // the clock after req: build the reply
    reg         reply;    // load a reply {seq, status, data}
    reg  [7:0]  r_seq;
    // the last executed frame's reply; a refused frame's reply (bad CRC or command, or a
    // bulk write without replay units) is r_bad with no data, so this one is kept
    reg  [7:0]  r_st;
    reg  [31:0] r_data;
    reg         r_refused;
    reg  [2:0]  r_bad;
    // the last executed frame
    reg         k_valid;
    reg  [7:0]  k_seq, k_cmd;
    reg  [47:0] k_body;
    reg  [15:0] k_crc;
    reg  [7:0]  crc_hi;   // the frame's CRC field, first byte
    wire [15:0] f_crc = {crc_hi, rx_byte};
    wire        again = k_valid && seq == k_seq && cmd == k_cmd && body[63:16] == k_body &&
                        f_crc == k_crc;
    initial begin
        idx = 9'd0;
        req = 1'b0;
        bulk_open = 1'b0;
        bulk_wr = 1'b0;
        req_bulk = 1'b0;
        cmd = 8'h00;
        bulk_len = 8'h00;
        exec = 1'b0;
        reply = 1'b0;
        bad_frame = 1'b0;
        k_valid = 1'b0;
        r_refused = 1'b0;
    end
    always @(posedge clk) begin
        req       <= 1'b0;
        exec      <= req;
        reply     <= 1'b0;
        bad_frame <= 1'b0;
        bulk_open <= 1'b0;
        bulk_wr   <= 1'b0;
        if (rst) begin
            idx <= 9'd0;
            gap <= 16'd0;
        end else if (rx_valid) begin
            gap <= 16'd0;
            crc <= crc_rx;
            if (idx == 9'd0) begin
                if (rx_byte == SYNC_REQ) idx <= 9'd1;
            end else begin
                idx <= (idx == last) ? 9'd0 : idx + 1'b1;
                if (idx == 9'd1) seq <= rx_byte;
                if (idx == 9'd2) cmd <= rx_byte;
                if (idx >= 9'd3 && idx <= 9'd8) body <= {rx_byte, body[63:8]};
                if (idx == 9'd3) bulk_addr[7:0] <= rx_byte;
                if (idx == 9'd4) bulk_addr[15:8] <= rx_byte;
                if (idx == last - 9'd1) crc_hi <= rx_byte;
                if (bulk && idx == 9'd5) begin
                    bulk_len  <= rx_byte;
                    bulk_open <= 1'b1;
                end
                if (bulk && idx >= 9'd6 && idx < 9'd6 + {1'b0, bulk_len}) begin
                    bulk_wr   <= 1'b1;
                    bulk_idx  <= idx[7:0] - 8'd6;
                    bulk_byte <= rx_byte;
                end
                if (idx == last) begin
                    r_seq <= seq;
                    if (crc_rx != 16'd0 || (cmd != 8'h01 && cmd != 8'h02 && !bulk)) begin
                        reply     <= 1'b1;
                        bad_frame <= 1'b1;
                        r_refused <= 1'b1;
                        r_bad     <= (crc_rx != 16'd0) ? ST_CRC[2:0] : ST_CMD[2:0];
                    end else if (bulk && BULK == 0) begin
                        reply     <= 1'b1;
                        r_refused <= 1'b1;
                        r_bad     <= ST_FULL[2:0];
                    end else if (again) begin
                        reply     <= 1'b1;
                        r_refused <= 1'b0;
                    end else begin
                        k_valid  <= 1'b0;
                        k_seq    <= seq;
                        k_cmd    <= cmd;
                        k_body   <= body[63:16];
                        k_crc    <= f_crc;
                        req      <= 1'b1;
                        req_wr   <= (cmd == 8'h02) || bulk_req;
                        req_bulk <= bulk_req;
                        req_addr <= bulk_req ? bulk_addr : body[31:16];
                        req_data <= bulk_req ? {24'd0, bulk_len} : body[63:32];
                    end
                end
            end
        end else if (idx != 9'd0) begin
            if (gap == GAP[15:0]) idx <= 9'd0;
            else gap <= gap + 1'b1;
        end
        if (exec) begin
            reply     <= 1'b1;
            r_refused <= 1'b0;
            r_st      <= rsp_status;
            r_data    <= rsp_data;
            k_valid   <= 1'b1;
        end
    end

    // ---- transmit: 7 bytes from the buffer, then the CRC ----
    reg  [55:0] tbuf;
    reg  [3:0]  tidx;     // bytes sent; 9 = idle
    reg  [15:0] tcrc;
    wire [15:0] crc_tx;
    initial tidx = 4'd9;
    assign tx_byte  = (tidx == 4'd7) ? tcrc[15:8] : (tidx == 4'd8) ? tcrc[7:0] : tbuf[7:0];
    assign tx_start = !rst && (tidx != 4'd9) && !tx_busy && !reply;
    ms_crc16 u_crc_tx (.crc(tidx == 4'd0 ? 16'hFFFF : tcrc), .data(tbuf[7:0]), .next(crc_tx));
    always @(posedge clk) begin
        if (rst) begin
            tidx <= 4'd9;
        end else if (reply) begin
            tbuf <= r_refused ? {32'd0, 5'd0, r_bad, r_seq, SYNC_RSP}
                              : {r_data, r_st, r_seq, SYNC_RSP};
            tidx <= 4'd0;
        end else if (tx_start) begin
            tidx <= tidx + 1'b1;
            if (tidx < 4'd7) begin
                tcrc <= crc_tx;
                tbuf <= {8'h00, tbuf[55:8]};
            end
        end
    end
endmodule
