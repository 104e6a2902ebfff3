//! Routing of the Alpaca HTTP API: the device API under `/api/v1/{type}/{n}/{method}`,
//! the management API under `/management/…` and the setup pages.

use crate::devices::{Answer, Device};
use crate::errors::Fault;
use crate::params::Params;
use base64::Engine;
use multistep_controller::Controller;
use multistep_web::access::Access;
use multistep_web::server::{Request, Response};
use serde_json::{json, Map, Value};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;

pub struct Ctx {
    pub ctl: Arc<Controller>,
    pub devices: Vec<Device>,
    pub access: Access,
    pub board: String,
    server_tx: AtomicU32,
}

impl Ctx {
    pub fn new(ctl: Arc<Controller>, devices: Vec<Device>, access: Access, board: String) -> Ctx {
        Ctx {
            ctl,
            devices,
            access,
            board,
            server_tx: AtomicU32::new(0),
        }
    }

    /// ServerTransactionID: 1, 2, 3, … over every answered call.
    fn next_tx(&self) -> u32 {
        self.server_tx
            .fetch_add(1, Ordering::SeqCst)
            .wrapping_add(1)
    }
}

/// The token a request carries: `Authorization: Bearer T`, HTTP Basic with T as the
/// password (`http://user:T@host/` in a client's address), or `?token=T`.
fn request_token(req: &Request, query: &Params) -> Option<String> {
    // The scheme name is case-insensitive (RFC 9110 §11.1).
    let auth = req.header("Authorization").map(str::trim);
    let scheme = |name: &str| {
        auth.and_then(|a| a.split_once(' '))
            .filter(|(s, _)| s.eq_ignore_ascii_case(name))
            .map(|(_, rest)| rest.trim())
    };
    if let Some(t) = scheme("Bearer") {
        return Some(t.to_string());
    }
    if let Some(b) = scheme("Basic") {
        let raw = base64::engine::general_purpose::STANDARD.decode(b).ok()?;
        let pair = String::from_utf8(raw).ok()?;
        return pair.split_once(':').map(|(_, p)| p.to_string());
    }
    query.get("token").map(str::to_string)
}

pub fn handle(req: &Request, ctx: &Ctx) -> Response {
    let url = req.url();
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    let query = Params::parse(query.as_bytes());
    let token = request_token(req, &query);
    if !ctx.access.allows(req.header("Host"), token.as_deref()) {
        return Response::text(
            403,
            "forbidden: wrong or missing access token, or a Host that is not loopback",
        );
    }
    let put = match req.method() {
        "GET" => false,
        "PUT" => true,
        _ => return Response::text(405, "Alpaca takes GET and PUT only"),
    };
    // GET parameters are in the query string, PUT parameters in the form body (the server
    // has refused bodies over 16 KiB).
    let params = if put {
        Params::parse(req.body())
    } else {
        query
    };
    route(ctx, path, put, &params)
}

fn route(ctx: &Ctx, path: &str, put: bool, p: &Params) -> Response {
    let parts: Vec<&str> = path.trim_matches('/').split('/').collect();
    match parts.as_slice() {
        ["api", "v1", ty, n, method] => device_call(ctx, ty, n, method, put, p),
        ["management", "apiversions"] if !put => reply(ctx, p, Ok(Some(json!([1])))),
        ["management", "v1", "description"] if !put => reply(ctx, p, Ok(Some(description(ctx)))),
        ["management", "v1", "configureddevices"] if !put => {
            reply(ctx, p, Ok(Some(configured(ctx))))
        }
        ["setup"] | ["setup", "v1", _, _, "setup"] if !put => setup_page(ctx),
        ["management", ..] | ["setup", ..] if put => Response::text(405, "use GET"),
        _ => Response::text(404, &format!("no Alpaca endpoint at {path}")),
    }
}

fn device_call(ctx: &Ctx, ty: &str, n: &str, method: &str, put: bool, p: &Params) -> Response {
    let number: Option<usize> = n.parse().ok();
    let dev = ctx
        .devices
        .iter()
        .find(|d| d.ty.path().eq_ignore_ascii_case(ty) && Some(d.number) == number);
    let Some(dev) = dev else {
        return Response::text(400, &format!("no device {ty}/{n} on this server"));
    };
    let method = method.to_ascii_lowercase();
    reply(ctx, p, dev.call(&ctx.ctl, &method, put, p))
}

/// The Alpaca reply: HTTP 200 with the transaction numbers, the value and the error
/// number, or HTTP 400 with the reason for a malformed request.
fn reply(ctx: &Ctx, p: &Params, answer: Answer) -> Response {
    let mut m = Map::new();
    let (number, message) = match answer {
        Ok(Some(v)) => {
            m.insert("Value".into(), v);
            (0, String::new())
        }
        Ok(None) => (0, String::new()),
        Err(Fault::Device { number, message }) => (number, message),
        Err(Fault::BadRequest(why)) => return Response::text(400, &why),
    };
    m.insert(
        "ClientTransactionID".into(),
        json!(p.u32_or_zero("ClientTransactionID")),
    );
    m.insert("ServerTransactionID".into(), json!(ctx.next_tx()));
    m.insert("ErrorNumber".into(), json!(number));
    m.insert("ErrorMessage".into(), json!(message));
    Response::new(200, "application/json", Value::Object(m).to_string())
}

fn description(ctx: &Ctx) -> Value {
    json!({
        "ServerName": format!("multistep board {}", ctx.board),
        "Manufacturer": "multistep",
        "ManufacturerVersion": env!("CARGO_PKG_VERSION"),
        "Location": "",
    })
}

fn configured(ctx: &Ctx) -> Value {
    let list: Vec<Value> = ctx
        .devices
        .iter()
        .map(|d| {
            json!({
                "DeviceName": d.name,
                "DeviceType": d.ty.name(),
                "DeviceNumber": d.number,
                "UniqueID": d.unique_id,
            })
        })
        .collect();
    json!(list)
}

/// The setup pages Alpaca asks for; devices are set up in the board configuration.
fn setup_page(ctx: &Ctx) -> Response {
    let mut rows = String::new();
    for d in &ctx.devices {
        rows.push_str(&format!(
            "<li>{} {}: {} (axis {})</li>",
            d.ty.name(),
            d.number,
            escape(&d.name),
            escape(&d.axis)
        ));
    }
    let page = format!(
        "<!doctype html><meta charset=utf-8><title>multistep Alpaca</title>\
         <h1>multistep board {}</h1><ul>{rows}</ul>\
         <p>Devices are set up in the board configuration's [alpaca] section.</p>",
        escape(&ctx.board)
    );
    Response::new(200, "text/html; charset=utf-8", page)
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
