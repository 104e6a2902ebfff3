//! The `--alpaca…` flags of `multistep serve` (`#[command(flatten)] alpaca: AlpacaArgs`).

use crate::config::AlpacaSection;
use crate::{start, AlpacaError, AlpacaOptions, AlpacaServer};
use multistep_controller::{BoardConfig, Controller};
use multistep_web::access::with_host;
use std::sync::Arc;

#[derive(clap::Args, Clone, Debug, Default)]
pub struct AlpacaArgs {
    /// Serve the board config's [alpaca] devices (Focuser, Rotator, FilterWheel,
    /// Telescope) as ASCOM Alpaca on HOST:PORT, or on 127.0.0.1 with just a PORT (loopback
    /// unless --alpaca-allow-remote; port 0 picks a free port)
    #[arg(long, value_name = "HOST:PORT")]
    pub alpaca: Option<String>,
    /// Allow --alpaca on a non-loopback address (needs --alpaca-token)
    #[arg(long, requires = "alpaca")]
    pub alpaca_allow_remote: bool,
    /// Access token every Alpaca request must carry (HTTP Basic password, e.g.
    /// http://alpaca:TOKEN@host:port, `Authorization: Bearer`, or `?token=`); falls back to
    /// the MULTISTEP_ALPACA_TOKEN environment variable
    #[arg(
        long,
        value_name = "TOKEN",
        env = "MULTISTEP_ALPACA_TOKEN",
        hide_env_values = true
    )]
    pub alpaca_token: Option<String>,
    /// UDP port that answers Alpaca discovery (0: any free port)
    #[arg(long, value_name = "PORT", default_value_t = crate::discovery::DEFAULT_PORT, requires = "alpaca")]
    pub alpaca_discovery_port: u16,
    /// Do not answer Alpaca discovery
    #[arg(long, requires = "alpaca", conflicts_with = "alpaca_discovery_port")]
    pub alpaca_no_discovery: bool,
    /// Most Alpaca HTTP connections at once (1 to 1024); one more is answered 503
    #[arg(long, value_name = "N", default_value_t = multistep_web::server::DEFAULT_MAX_CLIENTS, requires = "alpaca")]
    pub alpaca_max_clients: usize,
}

impl AlpacaArgs {
    fn options(&self) -> Option<AlpacaOptions> {
        Some(AlpacaOptions {
            addr: with_host(self.alpaca.as_ref()?),
            allow_remote: self.alpaca_allow_remote,
            token: self.alpaca_token.clone(),
            discovery_port: (!self.alpaca_no_discovery).then_some(self.alpaca_discovery_port),
            max_clients: self.alpaca_max_clients,
        })
    }

    /// Checks the config's [alpaca] section and the flags without binding anything, so a
    /// refused start changes nothing.
    pub fn check(&self, config: &BoardConfig) -> Result<(), AlpacaError> {
        let section = AlpacaSection::from_board(config)?;
        if let Some(opts) = self.options() {
            if section.is_empty() {
                return Err(AlpacaError::NoDevices);
            }
            opts.check()?;
        }
        Ok(())
    }

    /// Checks the config's [alpaca] section (always), starts the Alpaca side if --alpaca
    /// was given, and says where it listens on stderr.
    pub fn start(
        &self,
        config: &BoardConfig,
        ctl: Arc<Controller>,
    ) -> Result<Option<AlpacaServer>, AlpacaError> {
        let section = AlpacaSection::from_board(config)?;
        let Some(opts) = self.options() else {
            return Ok(None);
        };
        let server = start(ctl, &section, &opts)?;
        match server.discovery_addr() {
            Some(d) => eprintln!(
                "alpaca devices on http://{}/ (discovery on udp port {})",
                server.addr(),
                d.port()
            ),
            None => eprintln!("alpaca devices on http://{}/", server.addr()),
        }
        Ok(Some(server))
    }
}
