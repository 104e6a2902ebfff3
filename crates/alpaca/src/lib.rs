//! # multistep-alpaca
//!
//! ASCOM Alpaca devices over the multistep [`Controller`]: the board configuration's
//! `[alpaca]` section makes axes a Focuser, a Rotator, a FilterWheel or a Telescope
//! mount, and astronomy software (N.I.N.A., SharpCap, alpyca, …) drives them over
//! Alpaca's HTTP/JSON API. Every move is a `Controller::move_axis` call, the one the line
//! protocol and the web page make.
//!
//! | route | what |
//! |---|---|
//! | `GET/PUT /api/v1/{focuser,rotator,filterwheel,telescope}/{n}/{method}` | the device API |
//! | `GET /management/apiversions`, `/management/v1/description`, `/management/v1/configureddevices` | the management API |
//! | `GET /setup`, `/setup/v1/{type}/{n}/setup` | setup pages |
//! | UDP `alpacadiscovery1` to the discovery port (32227) | discovery |

pub mod args;
pub mod config;
pub mod devices;
pub mod discovery;
pub mod errors;
mod http;
pub mod mapping;
pub mod params;

pub use args::AlpacaArgs;
pub use config::AlpacaSection;

use multistep_controller::service::Limits;
use multistep_controller::Controller;
use multistep_web::access::Access;
use multistep_web::{server, HttpOptions, WebError};
use std::net::SocketAddr;
use std::sync::Arc;

/// Where and how the Alpaca side listens.
#[derive(Clone, Debug)]
pub struct AlpacaOptions {
    /// `HOST:PORT`; `127.0.0.1:0` picks a free port.
    pub addr: String,
    /// Needed to bind anything but a loopback address (then `token` is required).
    pub allow_remote: bool,
    pub token: Option<String>,
    /// UDP port for discovery (0: any free port); `None`: no discovery.
    pub discovery_port: Option<u16>,
    /// Most HTTP connections at once (`multistep_web::server::MAX_CLIENTS_RANGE`); one
    /// more is answered 503.
    pub max_clients: usize,
}

#[derive(Debug, thiserror::Error)]
pub enum AlpacaError {
    #[error(transparent)]
    Config(#[from] config::ConfigError),
    #[error(
        "--alpaca needs devices: add an [alpaca] section to the board config (see docs/ALPACA.md)"
    )]
    NoDevices,
    #[error("{0} is not a loopback address; serving Alpaca to other machines needs --alpaca-allow-remote and --alpaca-token")]
    RemoteNotAllowed(String),
    #[error(
        "--alpaca-allow-remote needs an access token (--alpaca-token, at least {} characters)",
        multistep_web::access::MIN_TOKEN_LEN
    )]
    TokenRequired,
    #[error("cannot listen on {addr}: {why}")]
    Bind { addr: String, why: String },
    #[error("cannot answer Alpaca discovery on UDP port {port}: {why} (choose another with --alpaca-discovery-port)")]
    Discovery { port: u16, why: String },
    #[error("{0}")]
    Access(String),
    #[error("{0}")]
    Mount(String),
}

/// The Alpaca side of a running service; stops serving when dropped.
pub struct AlpacaServer {
    server: server::Server,
    discovery: Option<discovery::Discovery>,
}

impl AlpacaServer {
    /// The HTTP address actually bound.
    pub fn addr(&self) -> SocketAddr {
        self.server.addr()
    }
    /// Where discovery datagrams are received, if discovery runs.
    pub fn discovery_addr(&self) -> Option<SocketAddr> {
        self.discovery.as_ref().map(|d| d.addr())
    }
}

impl AlpacaOptions {
    /// The web page's rules for the address, the token and the connection cap, with the
    /// Alpaca flags' names.
    pub fn check(&self) -> Result<(Access, Limits), AlpacaError> {
        let web = HttpOptions {
            addr: self.addr.clone(),
            allow_remote: self.allow_remote,
            token: self.token.clone(),
            max_clients: self.max_clients,
        };
        let alpaca = |e| match e {
            WebError::RemoteNotAllowed(a) => AlpacaError::RemoteNotAllowed(a),
            WebError::TokenRequired => AlpacaError::TokenRequired,
            WebError::Bind { addr, why } => AlpacaError::Bind { addr, why },
            other => AlpacaError::Access(other.to_string().replace("--http", "--alpaca")),
        };
        Ok((web.check().map_err(alpaca)?, web.limits().map_err(alpaca)?))
    }
}

/// Checks `opts` (the web page's rule: loopback, or an explicit opt-in with a token),
/// binds, and serves the devices of `section` on background threads, one per connection
/// up to `opts.max_clients`.
pub fn start(
    ctl: Arc<Controller>,
    section: &AlpacaSection,
    opts: &AlpacaOptions,
) -> Result<AlpacaServer, AlpacaError> {
    if section.is_empty() {
        return Err(AlpacaError::NoDevices);
    }
    let (access, limits) = opts.check()?;
    let bind_err = |why: String| AlpacaError::Bind {
        addr: opts.addr.clone(),
        why,
    };
    let board = ctl.with_board(|b, _| b.name().to_string());
    let devices = devices::build(section, &board, &ctl).map_err(AlpacaError::Mount)?;
    let ctx = http::Ctx::new(ctl, devices, access, board);
    let handler: server::Handler = Arc::new(move |req| http::handle(&req, &ctx));
    let server = server::Server::start(&opts.addr, limits, "alpaca", handler)
        .map_err(|e| bind_err(e.to_string()))?;
    let addr = server.addr();
    let discovery =
        match opts.discovery_port {
            None => None,
            Some(port) => Some(discovery::Discovery::start(addr, port).map_err(|e| {
                AlpacaError::Discovery {
                    port,
                    why: e.to_string(),
                }
            })?),
        };
    Ok(AlpacaServer { server, discovery })
}
