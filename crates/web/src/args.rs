//! The `--http…` flags, shared by every command that serves a board
//! (`#[command(flatten)] http: HttpArgs`).

use crate::access::with_host;
use crate::boards::{BoardLink, Remote};
use crate::{start_links, HttpOptions, WebError, WebServer};
use multistep_controller::Controller;
use std::sync::Arc;

#[derive(clap::Args, Clone, Debug, Default)]
pub struct HttpArgs {
    /// Serve the operator web page and its API on HOST:PORT, or on 127.0.0.1 with just a
    /// PORT (loopback unless --http-allow-remote; port 0 picks a free port)
    #[arg(long, value_name = "HOST:PORT")]
    pub http: Option<String>,
    /// Allow --http on a non-loopback address (needs --http-token)
    #[arg(long, requires = "http")]
    pub http_allow_remote: bool,
    /// Access token every HTTP request must carry (`?token=` or `Authorization: Bearer`);
    /// falls back to the MULTISTEP_HTTP_TOKEN environment variable
    #[arg(
        long,
        value_name = "TOKEN",
        env = "MULTISTEP_HTTP_TOKEN",
        hide_env_values = true
    )]
    pub http_token: Option<String>,
    /// Also show another board on the page, reached over its line protocol at HOST:PORT
    /// (repeat for more boards)
    #[arg(long, value_name = "HOST:PORT", requires = "http")]
    pub http_board: Vec<String>,
    /// Most HTTP connections at once (1 to 1024); one more is answered 503. Event streams
    /// (one per open page) take at most half of them, and at most 32
    #[arg(long, value_name = "N", default_value_t = crate::server::DEFAULT_MAX_CLIENTS, requires = "http")]
    pub http_max_clients: usize,
}

impl HttpArgs {
    fn options(&self) -> Option<HttpOptions> {
        Some(HttpOptions {
            addr: with_host(self.http.as_ref()?),
            allow_remote: self.http_allow_remote,
            token: self.http_token.clone(),
            max_clients: self.http_max_clients,
        })
    }

    /// Checks the flags without binding anything, so a refused start changes nothing.
    pub fn check(&self) -> Result<(), WebError> {
        if let Some(opts) = self.options() {
            opts.check()?;
            opts.limits()?;
        }
        Ok(())
    }

    /// Starts the web side if `--http` was given, and says where it listens on stderr.
    pub fn start(&self, boards: Vec<Arc<Controller>>) -> Result<Option<WebServer>, WebError> {
        let Some(opts) = self.options() else {
            return Ok(None);
        };
        let links = boards
            .into_iter()
            .map(BoardLink::Local)
            .chain(
                self.http_board
                    .iter()
                    .map(|a| BoardLink::Remote(Remote::new(a))),
            )
            .collect();
        let server = start_links(links, &opts)?;
        eprintln!("web page on http://{}/", server.addr());
        Ok(Some(server))
    }
}
