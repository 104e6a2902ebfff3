//! # multistep-web
//!
//! The operator web page of a multistep controller (seed 002's host GUI): one
//! self-contained page embedded in the binary, plus a small JSON + server-sent-events API.
//! Every command goes through [`Controller::execute`] — the line protocol's dispatcher —
//! so the page can do exactly what a terminal can, with the same checks and messages.
//!
//! | route | what |
//! |---|---|
//! | `GET /` `/app.js` `/style.css` | the page |
//! | `GET /api/boards` | boards and their axes |
//! | `GET /api/status` | one snapshot of every axis of every board |
//! | `GET /api/events` | the same snapshot as SSE, 20 Hz while an axis moves, 4 Hz at rest |
//! | `POST /api/cmd` `{"board":0,"line":"move X 100"}` | runs one protocol line |
//! | `POST /api/preview` `{"board":0,"line":"move X 100"}` | plans a move without running it |
//!
//! Served by [`server`] (shared with the Alpaca devices): one thread per connection up to
//! `--http-max-clients`, event streams capped and shared fairly (`streams.rs`).

pub mod access;
mod api;
mod args;
mod assets;
pub mod boards;
mod events;
pub mod preview;
pub mod server;
mod snapshot;
mod streams;

pub use access::{HttpOptions, WebError};
pub use args::HttpArgs;
pub use boards::BoardLink;

use multistep_controller::Controller;
use std::net::SocketAddr;
use std::sync::Arc;

/// The HTTP side of a running service; stops accepting when dropped.
pub struct WebServer {
    server: server::Server,
}

impl WebServer {
    /// The address actually bound (port 0 picks a free port).
    pub fn addr(&self) -> SocketAddr {
        self.server.addr()
    }

    /// Serves until the process ends.
    pub fn join(self) {
        self.server.join()
    }
}

/// Serves the page for boards run by this process.
pub fn start(boards: Vec<Arc<Controller>>, opts: &HttpOptions) -> Result<WebServer, WebError> {
    start_links(boards.into_iter().map(BoardLink::Local).collect(), opts)
}

/// Checks `opts` (loopback unless remote access is allowed with a token, a connection cap
/// in range), binds, and serves `boards` on background threads, one per connection.
pub fn start_links(boards: Vec<BoardLink>, opts: &HttpOptions) -> Result<WebServer, WebError> {
    if boards.is_empty() {
        return Err(WebError::NoBoards);
    }
    let access = opts.check()?;
    let limits = opts.limits()?;
    // Event streams never take more than half the connections: the page and its commands
    // always find one.
    let ctx = Arc::new(api::Ctx::new(boards, access, opts.max_clients / 2));
    let handler: server::Handler = Arc::new(move |req| api::handle(&req, &ctx));
    let server =
        server::Server::start(&opts.addr, limits, "http", handler).map_err(|e| WebError::Bind {
            addr: opts.addr.clone(),
            why: e.to_string(),
        })?;
    Ok(WebServer { server })
}
