//! Serving the line protocol: a TCP listener with one thread per client, and optionally a
//! serial line. Each line gets exactly one reply, whatever it contains.

use crate::controller::Controller;
use crate::error::CtlError;
use crate::protocol::{read_line, Line, Reply, MAX_LINE};
use std::io::{BufRead, BufReader, ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::Arc;
use std::time::Duration;

/// Answers lines from `input` on `output` until end of input or a write error.
pub fn serve_stream<R: Read, W: Write>(
    ctl: &Controller,
    input: R,
    mut output: W,
) -> std::io::Result<()> {
    let mut input = BufReader::with_capacity(MAX_LINE, input);
    serve_lines(ctl, &mut input, &mut output)
}

fn serve_lines(
    ctl: &Controller,
    input: &mut impl BufRead,
    output: &mut impl Write,
) -> std::io::Result<()> {
    loop {
        let reply = match read_line(input)? {
            Line::Eof => return Ok(()),
            Line::TooLong => Reply::err(CtlError::LineTooLong { max: MAX_LINE }),
            Line::Text(bytes) => ctl.execute_bytes(&bytes),
        };
        output.write_all(reply.to_text().as_bytes())?;
        output.flush()?;
    }
}

/// Accepts clients on `listener` forever, one thread each.
pub fn serve_tcp(ctl: Arc<Controller>, listener: TcpListener) -> std::io::Result<()> {
    for conn in listener.incoming() {
        let stream = match conn {
            Ok(s) => s,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => {
                eprintln!("accept: {e}");
                continue;
            }
        };
        let ctl = ctl.clone();
        std::thread::spawn(move || {
            let _ = stream.set_nodelay(true);
            if let Ok(read) = stream.try_clone() {
                let _ = serve_stream(&ctl, read, &stream);
            }
        });
    }
    Ok(())
}

/// A serial port read as a blocking stream: read timeouts are not the end of input.
struct Patient(Box<dyn serialport::SerialPort>);

impl Read for Patient {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        loop {
            match self.0.read(buf) {
                Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::WouldBlock => {
                    continue
                }
                // A pseudo-terminal whose other side is closed reads as an I/O error; wait
                // for it to be opened again, as a board waits on an unplugged cable.
                Err(e) if e.raw_os_error() == Some(5) => {
                    std::thread::sleep(Duration::from_millis(50))
                }
                other => return other,
            }
        }
    }
}

/// Serves the protocol on a serial device (115200 8N1) until it fails.
pub fn serve_serial(ctl: Arc<Controller>, device: &str) -> Result<(), CtlError> {
    let port = serialport::new(device, 115_200)
        .timeout(Duration::from_millis(200))
        .open()
        .map_err(|e| CtlError::Io(format!("cannot open serial device {device}: {e}")))?;
    let out = port.try_clone().map_err(|e| CtlError::Io(e.to_string()))?;
    let mut out = Patient(out);
    serve_stream(&ctl, Patient(port), WriteHalf(&mut out))
        .map_err(|e| CtlError::Io(format!("serial {device}: {e}")))
}

struct WriteHalf<'a>(&'a mut Patient);

impl Write for WriteHalf<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0 .0.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0 .0.flush()
    }
}

/// Binds the listener (port 0 picks a free port; the bound address is returned).
pub fn bind(addr: &str) -> Result<TcpListener, CtlError> {
    TcpListener::bind(addr).map_err(|e| CtlError::Io(format!("cannot listen on {addr}: {e}")))
}

/// Connects to a board over TCP (used by the host client and tests).
pub fn connect(addr: &str) -> std::io::Result<TcpStream> {
    let s = TcpStream::connect(addr)?;
    s.set_nodelay(true)?;
    Ok(s)
}
