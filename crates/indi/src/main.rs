//! `indi_multistep`: an INDI driver for the multistep controller's telescope mount,
//! focuser, rotator and filter wheel, run by indiserver with no arguments (see
//! docs/INDI.md).

mod device;
mod driver;
mod focuser;
mod link;
mod props;
mod rotator;
mod telescope;
mod wheel;
mod xml;

use driver::Driver;
use link::Link;
use multistep_controller::client::Endpoint;
use std::io::BufReader;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// How often the status of connected devices is read while the driver runs.
const POLL: Duration = Duration::from_millis(250);
/// How long to wait before asking an unreachable controller for its devices again.
const RETRY: Duration = Duration::from_secs(1);

fn main() {
    if let Err(e) = run() {
        eprintln!("indi_multistep: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let at = std::env::var("MULTISTEP_INDI_CONTROLLER").map_err(|_| {
        "MULTISTEP_INDI_CONTROLLER is not set (tcp://HOST:PORT of `multistep serve`)"
    })?;
    let endpoint: Endpoint = at
        .parse()
        .map_err(|e| format!("MULTISTEP_INDI_CONTROLLER: {e}"))?;
    let token = std::env::var("MULTISTEP_INDI_TOKEN")
        .ok()
        .filter(|t| !t.is_empty());
    let timeout = match std::env::var("MULTISTEP_INDI_TIMEOUT") {
        Err(_) => link::DEFAULT_TIMEOUT,
        Ok(t) => match t.trim().parse::<f64>() {
            Ok(s) if (0.1..=600.0).contains(&s) => Duration::from_secs_f64(s),
            _ => {
                return Err(format!(
                    "MULTISTEP_INDI_TIMEOUT: '{t}' is not a number of seconds from 0.1 to 600"
                ))
            }
        },
    };
    // The devices are the controller's: wait for it, saying why on stderr (indiserver's log).
    let driver = loop {
        let link = Link::new(endpoint.clone(), token.clone(), timeout);
        match Driver::discover(link, Box::new(std::io::stdout())) {
            Ok(d) => break d,
            Err(driver::DriverError::Link(e @ link::LinkError::Down { .. })) => {
                eprintln!("indi_multistep: {e}; trying again");
                std::thread::sleep(RETRY);
            }
            Err(e) => return Err(e.to_string()),
        }
    };
    let driver = Arc::new(Mutex::new(driver));
    {
        let driver = driver.clone();
        std::thread::Builder::new()
            .name("status-poll".into())
            .spawn(move || loop {
                std::thread::sleep(POLL);
                driver.lock().unwrap_or_else(|p| p.into_inner()).poll();
            })
            .map_err(|e| e.to_string())?;
    }
    let mut incoming = xml::Incoming::new(BufReader::new(std::io::stdin()));
    // indiserver closing our stdin ends the driver.
    while let Some(node) = incoming.next_node().map_err(|e| e.to_string())? {
        driver
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .handle(&node);
    }
    Ok(())
}
