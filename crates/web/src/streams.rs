//! Who holds the event streams. Each holds a connection and a thread, so they are capped
//! in total and per client, and fairly shared:
//!
//! - A client is an address, except that every loopback address (127.0.0.0/8, `::1`, and
//!   those as IPv4-mapped IPv6) is one client: this machine. Otherwise a local program
//!   could take every slot from 127.0.0.2, 127.0.0.3, … and the operator's page on
//!   127.0.0.1 would get none.
//! - A client at its quota that opens another stream closes its own oldest one: the page
//!   just opened is the one someone is looking at (a reload, a new tab), and the oldest is
//!   most likely a page left open or closed without a goodbye.
//! - With every slot taken, a client takes the oldest stream of the client that holds the
//!   most, if that one holds at least two more than the newcomer; otherwise 503. So a
//!   page that holds one stream keeps it while fewer clients than slots want one.

use std::net::IpAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// Most event streams at once, whatever the connection cap.
pub const MAX_STREAMS: usize = 32;
/// Most event streams of one client.
pub const MAX_STREAMS_PER_CLIENT: usize = 8;

/// One client's key: its address, loopback all as one.
fn client(peer: Option<IpAddr>) -> Option<IpAddr> {
    let ip = peer?;
    let v4 = match ip {
        IpAddr::V4(a) => Some(a),
        IpAddr::V6(a) => a.to_ipv4_mapped(),
    };
    let loopback = ip.is_loopback() || v4.is_some_and(|a| a.is_loopback());
    Some(if loopback {
        IpAddr::V4(std::net::Ipv4Addr::LOCALHOST)
    } else {
        v4.map_or(ip, IpAddr::V4)
    })
}

struct Held {
    client: Option<IpAddr>,
    id: u64,
    closed: Arc<AtomicBool>,
}

/// The open streams, oldest first.
pub struct Streams {
    max: usize,
    held: Mutex<(u64, Vec<Held>)>,
}

impl Streams {
    /// `max` streams at most (no more than `MAX_STREAMS`).
    pub fn new(max: usize) -> Arc<Streams> {
        Arc::new(Streams {
            max: max.min(MAX_STREAMS),
            held: Mutex::new((0, Vec::new())),
        })
    }

    /// A slot for a stream from `peer`, another stream closing for it if need be; `None`
    /// when every slot is fairly taken.
    pub fn take(self: &Arc<Self>, peer: Option<IpAddr>) -> Option<StreamSlot> {
        if self.max == 0 {
            return None;
        }
        let key = client(peer);
        let mut g = self.held.lock().unwrap_or_else(|p| p.into_inner());
        let (next, held) = &mut *g;
        let count = |k: Option<IpAddr>| held.iter().filter(|h| h.client == k).count();
        let mine = count(key);
        let victim = if mine >= MAX_STREAMS_PER_CLIENT {
            Some(key)
        } else if held.len() >= self.max {
            let most = held.iter().map(|h| h.client).max_by_key(|k| count(*k))?;
            if count(most) < mine + 2 {
                return None;
            }
            Some(most)
        } else {
            None
        };
        if let Some(v) = victim {
            if let Some(i) = held.iter().position(|h| h.client == v) {
                held.remove(i).closed.store(true, Ordering::SeqCst);
            }
        }
        *next += 1;
        let closed = Arc::new(AtomicBool::new(false));
        held.push(Held {
            client: key,
            id: *next,
            closed: closed.clone(),
        });
        Some(StreamSlot {
            streams: self.clone(),
            id: *next,
            closed,
        })
    }

    /// Streams held now.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.held.lock().unwrap_or_else(|p| p.into_inner()).1.len()
    }

    #[cfg(test)]
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One open stream's place; given back when dropped.
pub struct StreamSlot {
    streams: Arc<Streams>,
    id: u64,
    closed: Arc<AtomicBool>,
}

impl StreamSlot {
    /// Another stream took this one's place: end it.
    pub fn is_closed(&self) -> bool {
        self.closed.load(Ordering::SeqCst)
    }
}

impl Drop for StreamSlot {
    fn drop(&mut self) {
        let mut g = self.streams.held.lock().unwrap_or_else(|p| p.into_inner());
        g.1.retain(|h| h.id != self.id);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ip(s: &str) -> Option<IpAddr> {
        Some(s.parse().unwrap())
    }

    #[test]
    fn every_loopback_address_is_one_client() {
        for a in ["127.0.0.1", "127.9.8.7", "::1", "::ffff:127.0.0.2"] {
            assert_eq!(client(ip(a)), ip("127.0.0.1"), "{a}");
        }
        assert_eq!(client(ip("::ffff:10.0.0.1")), ip("10.0.0.1"));
        assert_eq!(client(ip("10.0.0.1")), ip("10.0.0.1"));
        assert_eq!(client(None), None);
    }

    #[test]
    fn a_client_over_its_quota_closes_its_own_oldest_stream() {
        let s = Streams::new(32);
        let held: Vec<_> = (2..=11)
            .flat_map(|n| (0..4).map(move |_| n))
            .map(|n| s.take(ip(&format!("127.0.0.{n}"))).unwrap())
            .collect();
        assert_eq!(s.len(), MAX_STREAMS_PER_CLIENT);
        let open = held.iter().filter(|h| !h.is_closed()).count();
        assert_eq!(open, MAX_STREAMS_PER_CLIENT);
        assert!(held[..32].iter().all(StreamSlot::is_closed));
        let page = s.take(ip("127.0.0.1")).unwrap();
        assert!(!page.is_closed() && held[32].is_closed());
        drop(held);
        assert_eq!(s.len(), 1);
        drop(page);
        assert!(s.is_empty());
    }

    #[test]
    fn with_every_slot_taken_a_newcomer_takes_from_the_client_with_most() {
        let s = Streams::new(8);
        let a: Vec<_> = (0..8).map(|_| s.take(ip("10.0.0.7")).unwrap()).collect();
        let b = s.take(ip("10.0.0.8")).expect("a newcomer gets a slot");
        assert!(a[0].is_closed() && !a[1].is_closed());
        let c: Vec<_> = (0..3).map(|_| s.take(ip("10.0.0.9")).unwrap()).collect();
        // 10.0.0.7 and 10.0.0.9 hold 4 and 3 now, 10.0.0.8 holds 1; none gives way.
        assert_eq!(s.len(), 8);
        assert!(s.take(ip("10.0.0.9")).is_none());
        assert!(!b.is_closed(), "a page that holds one stream keeps it");
        drop((a, c));
        assert_eq!(s.len(), 1);
        assert!(Streams::new(0).take(ip("10.0.0.1")).is_none());
    }
}
