//! A board with two axes served over HTTP only, for trying the page by hand:
//! `cargo run -p multistep-web --example web_demo -- 127.0.0.1:8080 /tmp/board-data`.

use multistep_controller::{BoardConfig, Controller};
use multistep_web::{start, HttpOptions};
use std::sync::Arc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let addr = args.next().unwrap_or_else(|| "127.0.0.1:8080".into());
    let data = args.next().unwrap_or_else(|| {
        std::env::temp_dir()
            .join("multistep-web-demo")
            .display()
            .to_string()
    });
    let config = BoardConfig::parse(include_str!("../e2e/board.toml"))?;
    let ctl = Arc::new(Controller::open(&config, std::path::Path::new(&data), 1.0)?);
    let web = start(
        vec![ctl],
        &HttpOptions {
            addr,
            allow_remote: false,
            token: None,
            max_clients: multistep_web::server::DEFAULT_MAX_CLIENTS,
        },
    )?;
    eprintln!("web page on http://{}/", web.addr());
    web.join();
    Ok(())
}
