//! `multistep serve`: one simulated controller board on TCP and optionally a serial line.

use anyhow::Context;
use clap::Args;
use multistep_controller::{service, BoardConfig, Controller};
use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Directory of the board's database (settings, presets, named positions, positions)
    #[arg(long, value_name = "DIR")]
    pub data: PathBuf,
    /// TCP address to listen on (port 0: any free port; the address is printed)
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7878")]
    pub listen: String,
    /// Also serve the protocol on this serial device (115200 8N1)
    #[arg(long, value_name = "DEVICE")]
    pub serial: Option<String>,
    /// Board configuration (TOML: board name, axes and their settings); default: axes X Y Z A
    #[arg(long, value_name = "FILE")]
    pub board_config: Option<PathBuf>,
    /// Simulated time runs this many times faster than the wall clock
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub time_scale: f64,
    #[command(flatten)]
    pub http: multistep_web::HttpArgs,
    #[command(flatten)]
    pub alpaca: multistep_alpaca::AlpacaArgs,
}

pub fn run(a: &ServeArgs) -> anyhow::Result<()> {
    let config = match &a.board_config {
        Some(p) => BoardConfig::load(p)?,
        None => BoardConfig::default(),
    };
    let ctl = Arc::new(Controller::open(&config, &a.data, a.time_scale)?);
    let listener = service::bind(&a.listen)?;
    let addr = listener.local_addr().context("listening address")?;
    let _web = a.http.start(vec![ctl.clone()])?;
    let _alpaca = a.alpaca.start(&config, ctl.clone())?;
    if let Some(dev) = &a.serial {
        let (ctl, dev) = (ctl.clone(), dev.clone());
        std::thread::spawn(move || {
            if let Err(e) = service::serve_serial(ctl, &dev) {
                eprintln!("error: {e}");
            }
        });
    }
    // The first line tells scripts (and tests) where the board is.
    let mut out = std::io::stdout();
    writeln!(out, "board {} listening on tcp://{addr}", config.board.name)?;
    out.flush()?;
    service::serve_tcp(ctl, listener)?;
    Ok(())
}
