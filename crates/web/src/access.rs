//! Who may use the page: loopback by default; another address only with an explicit
//! opt-in and an access token, which every request must then carry.

use multistep_controller::service::Limits;
use std::net::{SocketAddr, ToSocketAddrs};

/// Where and how the HTTP side listens.
#[derive(Clone, Debug)]
pub struct HttpOptions {
    /// `HOST:PORT`; `127.0.0.1:0` picks a free port.
    pub addr: String,
    /// Needed to bind anything but a loopback address.
    pub allow_remote: bool,
    /// Access token; required with `allow_remote`, optional on loopback.
    pub token: Option<String>,
    /// Most connections at once (`server::MAX_CLIENTS_RANGE`); one more is answered 503.
    pub max_clients: usize,
}

pub use multistep_controller::access::MIN_TOKEN_LEN;
use multistep_controller::access::{same_token, valid_token};

#[derive(Debug, thiserror::Error)]
pub enum WebError {
    #[error("cannot listen on {addr}: {why}")]
    Bind { addr: String, why: String },
    #[error("{0} is not a loopback address; serving the page to other machines needs --http-allow-remote and --http-token")]
    RemoteNotAllowed(String),
    #[error("--http-allow-remote needs an access token (--http-token, at least {MIN_TOKEN_LEN} characters)")]
    TokenRequired,
    #[error(
        "the access token must be {MIN_TOKEN_LEN} to 256 printable ASCII characters without spaces"
    )]
    BadToken,
    #[error("no board to serve")]
    NoBoards,
    #[error("{0}")]
    MaxClients(String),
}

/// What every request is checked against.
#[derive(Clone, Debug)]
pub struct Access {
    pub token: Option<String>,
    /// Bound to loopback only: then requests must also name a loopback host (DNS rebinding).
    pub loopback: bool,
}

impl HttpOptions {
    /// The connection limits, `max_clients` checked against its range.
    pub fn limits(&self) -> Result<Limits, WebError> {
        crate::server::limits(self.max_clients)
            .map_err(|why| WebError::MaxClients(format!("--http-max-clients {why}")))
    }

    pub fn check(&self) -> Result<Access, WebError> {
        let addrs: Vec<SocketAddr> = self
            .addr
            .to_socket_addrs()
            .map_err(|e| WebError::Bind {
                addr: self.addr.clone(),
                why: e.to_string(),
            })?
            .collect();
        let loopback = !addrs.is_empty() && addrs.iter().all(|a| a.ip().is_loopback());
        if self.token.as_deref().is_some_and(|t| !valid_token(t)) {
            return Err(WebError::BadToken);
        }
        if !loopback {
            if !self.allow_remote {
                return Err(WebError::RemoteNotAllowed(self.addr.clone()));
            }
            if self.token.is_none() {
                return Err(WebError::TokenRequired);
            }
        }
        Ok(Access {
            token: self.token.clone(),
            loopback,
        })
    }
}

impl Access {
    /// `token`: from the `Authorization: Bearer` header or the `token` query parameter.
    pub fn allows(&self, host: Option<&str>, token: Option<&str>) -> bool {
        if self.loopback && !host.is_some_and(is_loopback_host) {
            return false;
        }
        match (&self.token, token) {
            (None, _) => true,
            (Some(want), Some(got)) => same_token(want, got),
            (Some(_), None) => false,
        }
    }
}

/// `localhost`, `127.x.y.z` or `[::1]`, with or without a port.
fn is_loopback_host(host: &str) -> bool {
    let name = if let Some(rest) = host.strip_prefix('[') {
        rest.split(']').next().unwrap_or("")
    } else {
        host.rsplit_once(':').map_or(host, |(h, _)| h)
    };
    name.eq_ignore_ascii_case("localhost")
        || name
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// `8080` and `:8080` mean `127.0.0.1:8080`: loopback unless a host is named (every
/// listening flag of the service reads its address this way).
pub fn with_host(addr: &str) -> String {
    let port = addr.strip_prefix(':').unwrap_or(addr);
    if port.parse::<u16>().is_ok() {
        format!("127.0.0.1:{port}")
    } else {
        addr.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bare_port_is_loopback() {
        assert_eq!(with_host("8080"), "127.0.0.1:8080");
        assert_eq!(with_host(":0"), "127.0.0.1:0");
        assert_eq!(with_host("0.0.0.0:8080"), "0.0.0.0:8080");
        assert_eq!(with_host("[::1]:80"), "[::1]:80");
        assert_eq!(with_host("localhost:80"), "localhost:80");
    }

    fn opts(addr: &str, allow_remote: bool, token: Option<&str>) -> HttpOptions {
        HttpOptions {
            addr: addr.into(),
            allow_remote,
            token: token.map(String::from),
            max_clients: 64,
        }
    }
    const TOKEN: &str = "0123456789abcdef";

    #[test]
    fn remote_needs_the_flag_and_a_token() {
        assert!(matches!(
            opts("0.0.0.0:0", false, None).check(),
            Err(WebError::RemoteNotAllowed(_))
        ));
        assert!(matches!(
            opts("0.0.0.0:0", false, Some(TOKEN)).check(),
            Err(WebError::RemoteNotAllowed(_))
        ));
        assert!(matches!(
            opts("0.0.0.0:0", true, None).check(),
            Err(WebError::TokenRequired)
        ));
        assert!(matches!(
            opts("0.0.0.0:0", true, Some("short")).check(),
            Err(WebError::BadToken)
        ));
        assert!(matches!(
            opts("0.0.0.0:0", true, Some("has a space 123456")).check(),
            Err(WebError::BadToken)
        ));
        let a = opts("0.0.0.0:0", true, Some(TOKEN)).check().unwrap();
        assert!(!a.loopback);
        let a = opts("127.0.0.1:0", false, None).check().unwrap();
        assert!(a.loopback && a.token.is_none());
        assert!(opts("[::1]:0", false, None).check().unwrap().loopback);
    }

    #[test]
    fn every_request_is_checked() {
        let remote = Access {
            token: Some(TOKEN.into()),
            loopback: false,
        };
        assert!(remote.allows(Some("10.0.0.5:8080"), Some(TOKEN)));
        assert!(!remote.allows(Some("10.0.0.5:8080"), None));
        assert!(!remote.allows(Some("10.0.0.5:8080"), Some("0123456789abcdeF")));
        assert!(!remote.allows(Some("10.0.0.5:8080"), Some("0123456789abcde")));
        let local = Access {
            token: None,
            loopback: true,
        };
        assert!(local.allows(Some("127.0.0.1:8080"), None));
        assert!(local.allows(Some("localhost:1"), None));
        assert!(local.allows(Some("[::1]:1"), None));
        // A page served from another name resolving to 127.0.0.1 (DNS rebinding) is refused.
        assert!(!local.allows(Some("evil.example:8080"), None));
        assert!(!local.allows(None, None));
    }
}
