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

pub mod access;
mod api;
mod args;
mod assets;
pub mod boards;
mod events;
pub mod preview;
mod snapshot;

pub use access::{HttpOptions, WebError};
pub use args::HttpArgs;
pub use boards::BoardLink;

use multistep_controller::Controller;
use std::net::SocketAddr;
use std::sync::Arc;
use std::thread::JoinHandle;

/// The HTTP side of a running service.
pub struct WebServer {
    addr: SocketAddr,
    server: Arc<tiny_http::Server>,
    thread: Option<JoinHandle<()>>,
}

impl WebServer {
    /// The address actually bound (port 0 picks a free port).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Serves until the process ends.
    pub fn join(mut self) {
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for WebServer {
    fn drop(&mut self) {
        self.server.unblock();
    }
}

/// Serves the page for boards run by this process.
pub fn start(boards: Vec<Arc<Controller>>, opts: &HttpOptions) -> Result<WebServer, WebError> {
    start_links(boards.into_iter().map(BoardLink::Local).collect(), opts)
}

/// Checks `opts` (loopback unless remote access is allowed with a token), binds, and
/// serves `boards` on a background thread, one thread per request.
pub fn start_links(boards: Vec<BoardLink>, opts: &HttpOptions) -> Result<WebServer, WebError> {
    if boards.is_empty() {
        return Err(WebError::NoBoards);
    }
    let access = opts.check()?;
    let server = tiny_http::Server::http(&opts.addr).map_err(|e| WebError::Bind {
        addr: opts.addr.clone(),
        why: e.to_string(),
    })?;
    let addr = server.server_addr().to_ip().ok_or_else(|| WebError::Bind {
        addr: opts.addr.clone(),
        why: "not an IP address".into(),
    })?;
    let server = Arc::new(server);
    let ctx = Arc::new(api::Ctx::new(boards, access));
    let thread = {
        let server = server.clone();
        std::thread::Builder::new()
            .name("http".into())
            .spawn(move || {
                for req in server.incoming_requests() {
                    let ctx = ctx.clone();
                    let _ = std::thread::Builder::new()
                        .name("http-req".into())
                        .spawn(move || api::handle(req, &ctx));
                }
            })
            .map_err(|e| WebError::Bind {
                addr: opts.addr.clone(),
                why: e.to_string(),
            })?
    };
    Ok(WebServer {
        addr,
        server,
        thread: Some(thread),
    })
}
