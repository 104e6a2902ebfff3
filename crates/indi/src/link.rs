//! The driver's one connection to the controller's line protocol, opened again after the
//! controller went away.

use multistep_controller::client::{Client, ClientError, Endpoint};
use multistep_controller::AxisStatus;

/// Why a request got no answer it could use.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The controller answered `error:CODE MESSAGE`.
    #[error("controller: error:{code} {message}")]
    Refused { code: u16, message: String },
    /// No connection (refused, closed, reset).
    #[error("controller unreachable at {at}: {why}")]
    Down { at: String, why: String },
}

pub struct Link {
    endpoint: Endpoint,
    token: Option<String>,
    client: Option<Client>,
}

impl Link {
    pub fn new(endpoint: Endpoint, token: Option<String>) -> Link {
        Link {
            endpoint,
            token,
            client: None,
        }
    }

    fn down(&self, why: impl ToString) -> LinkError {
        LinkError::Down {
            at: match &self.endpoint {
                Endpoint::Tcp(a) => format!("tcp://{a}"),
                Endpoint::Serial(d) => format!("serial:{d}"),
            },
            why: why.to_string(),
        }
    }

    /// Sends one line, connecting first if there is no connection; a connection that fails
    /// is dropped, to be opened again by the next request.
    pub fn request(&mut self, line: &str) -> Result<Vec<String>, LinkError> {
        if self.client.is_none() {
            let mut c = Client::connect(&self.endpoint).map_err(|e| self.down(e))?;
            if let Some(t) = &self.token {
                c.authenticate(t).map_err(|e| self.down(e))?;
            }
            self.client = Some(c);
        }
        let Some(c) = self.client.as_mut() else {
            return Err(self.down("not connected"));
        };
        match c.request(line) {
            Ok(data) => Ok(data),
            Err(ClientError::Refused(r)) => Err(LinkError::Refused {
                code: r.code,
                message: r.message,
            }),
            Err(e) => {
                self.client = None;
                Err(self.down(e))
            }
        }
    }

    /// `status json`, parsed.
    pub fn status(&mut self) -> Result<Vec<AxisStatus>, LinkError> {
        let data = self.request("status json")?;
        let line = data.first().map(String::as_str).unwrap_or("[]");
        serde_json::from_str(line).map_err(|e| self.down(format!("bad status json: {e}")))
    }

    /// One setting of an axis (`get AXIS KEY`), `None` when unset.
    pub fn setting(&mut self, axis: &str, key: &str) -> Result<Option<f64>, LinkError> {
        let data = self.request(&format!("get {axis} {key}"))?;
        let v = data
            .first()
            .and_then(|l| l.split_once('='))
            .map(|(_, v)| v.trim().to_string())
            .unwrap_or_default();
        Ok(v.parse::<f64>().ok())
    }
}
