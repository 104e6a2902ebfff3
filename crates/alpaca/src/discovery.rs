//! Alpaca discovery (API reference §4): a UDP datagram `alpacadiscovery1` sent to the
//! discovery port is answered with `{"AlpacaPort": <HTTP port>}` from the server's address.
//!
//! Served on the HTTP side's IPv4 address. On loopback a client's broadcast goes to
//! 127.255.255.255, which a socket bound to 127.0.0.1 does not receive, so a second
//! socket listens there; answers always leave from the HTTP address, so the client
//! learns where the devices are. Off loopback the socket listens on every interface.

use std::net::{IpAddr, Ipv4Addr, SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// The port Alpaca clients send discovery datagrams to.
pub const DEFAULT_PORT: u16 = 32227;
const REQUEST: &[u8] = b"alpacadiscovery1";
const LOOPBACK_BROADCAST: Ipv4Addr = Ipv4Addr::new(127, 255, 255, 255);

pub struct Discovery {
    addr: SocketAddr,
    quit: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl Discovery {
    /// Starts answering on `port` (0: any free port) for an HTTP server at `http`.
    pub fn start(http: SocketAddr, port: u16) -> std::io::Result<Discovery> {
        let ip = match http.ip() {
            IpAddr::V4(ip) if ip.is_loopback() => IpAddr::V4(ip),
            IpAddr::V6(ip) if ip.is_loopback() => IpAddr::V4(Ipv4Addr::LOCALHOST),
            _ => IpAddr::V4(Ipv4Addr::UNSPECIFIED),
        };
        let unicast = UdpSocket::bind((ip, port))?;
        let addr = unicast.local_addr()?;
        let mut listeners = vec![unicast.try_clone()?];
        if ip.is_loopback() {
            listeners.push(UdpSocket::bind((LOOPBACK_BROADCAST, addr.port()))?);
        }
        let answer = format!("{{\"AlpacaPort\":{}}}", http.port());
        let quit = Arc::new(AtomicBool::new(false));
        let mut threads = Vec::new();
        for sock in listeners {
            let (reply, quit, answer) = (unicast.try_clone()?, quit.clone(), answer.clone());
            // Woken now and then to notice `quit`.
            sock.set_read_timeout(Some(Duration::from_millis(200)))?;
            threads.push(
                std::thread::Builder::new()
                    .name("alpaca-discovery".into())
                    .spawn(move || serve(&sock, &reply, answer.as_bytes(), &quit))?,
            );
        }
        Ok(Discovery {
            addr,
            quit,
            threads,
        })
    }

    /// Where discovery datagrams are received.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }
}

fn serve(sock: &UdpSocket, reply: &UdpSocket, answer: &[u8], quit: &AtomicBool) {
    let mut buf = [0u8; 64];
    while !quit.load(Ordering::Relaxed) {
        let Ok((n, from)) = sock.recv_from(&mut buf) else {
            continue;
        };
        if buf[..n] == *REQUEST {
            let _ = reply.send_to(answer, from);
        }
    }
}

impl Drop for Discovery {
    fn drop(&mut self) {
        self.quit.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}
