//! Who may use a listening socket: loopback by default; another address only with an
//! explicit opt-in and an access token. The line protocol and the web page share the rule.

use std::net::{SocketAddr, ToSocketAddrs};

/// Shortest accepted token: long enough that guessing is not a plan.
pub const MIN_TOKEN_LEN: usize = 16;
/// Longest accepted token.
pub const MAX_TOKEN_LEN: usize = 256;

/// 16 to 256 printable ASCII characters without spaces.
pub fn valid_token(t: &str) -> bool {
    (MIN_TOKEN_LEN..=MAX_TOKEN_LEN).contains(&t.len()) && t.bytes().all(|b| b.is_ascii_graphic())
}

/// Compares without stopping at the first difference, so timing tells nothing.
pub fn same_token(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    a.len() == b.len() && a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// Does `addr` (HOST:PORT) resolve to loopback addresses only?
pub fn is_loopback_addr(addr: &str) -> std::io::Result<bool> {
    let addrs: Vec<SocketAddr> = addr.to_socket_addrs()?.collect();
    Ok(!addrs.is_empty() && addrs.iter().all(|a| a.ip().is_loopback()))
}

/// Why a listen address and token were refused.
#[derive(Debug, PartialEq, Eq)]
pub enum Refusal {
    /// Not a loopback address and no explicit opt-in.
    RemoteNotAllowed,
    /// Opted in but no token.
    TokenRequired,
    /// A token that is too short, too long or has spaces or control characters.
    BadToken,
    /// The address does not resolve.
    Unresolved(String),
}

/// The rule: a token, if given, must be valid; a non-loopback address needs both the
/// opt-in and a token. Returns whether the address is loopback.
pub fn check(addr: &str, allow_remote: bool, token: Option<&str>) -> Result<bool, Refusal> {
    let loopback = is_loopback_addr(addr).map_err(|e| Refusal::Unresolved(e.to_string()))?;
    if token.is_some_and(|t| !valid_token(t)) {
        return Err(Refusal::BadToken);
    }
    if !loopback {
        if !allow_remote {
            return Err(Refusal::RemoteNotAllowed);
        }
        if token.is_none() {
            return Err(Refusal::TokenRequired);
        }
    }
    Ok(loopback)
}

#[cfg(test)]
mod tests {
    use super::*;
    const TOKEN: &str = "0123456789abcdef";

    #[test]
    fn remote_needs_the_flag_and_a_token() {
        assert_eq!(
            check("0.0.0.0:0", false, None),
            Err(Refusal::RemoteNotAllowed)
        );
        assert_eq!(
            check("0.0.0.0:0", false, Some(TOKEN)),
            Err(Refusal::RemoteNotAllowed)
        );
        assert_eq!(check("0.0.0.0:0", true, None), Err(Refusal::TokenRequired));
        assert_eq!(
            check("0.0.0.0:0", true, Some("short")),
            Err(Refusal::BadToken)
        );
        assert_eq!(check("0.0.0.0:0", true, Some(TOKEN)), Ok(false));
        assert_eq!(check("127.0.0.1:0", false, None), Ok(true));
        assert_eq!(check("[::1]:0", false, None), Ok(true));
        assert!(same_token(TOKEN, TOKEN) && !same_token(TOKEN, "0123456789abcdeF"));
        assert!(!same_token(TOKEN, "0123456789abcde"));
    }
}
