//! Routing of the Alpaca HTTP API: the device API under `/api/v1/{type}/{n}/{method}`,
//! the management API under `/management/…` and the setup pages.

use crate::devices::{Answer, Device};
use crate::errors::Fault;
use crate::params::Params;
use base64::Engine;
use multistep_controller::Controller;
use multistep_web::access::Access;
use serde_json::{json, Map, Value};
use std::io::Read;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Arc;
use tiny_http::{Header, Method, Request, Response};

/// Largest form body accepted.
const MAX_BODY: u64 = 16 * 1024;

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

type Resp = Response<std::io::Cursor<Vec<u8>>>;

fn header(k: &str, v: &str) -> Header {
    Header::from_bytes(k.as_bytes(), v.as_bytes()).expect("static header")
}

fn text(status: u16, msg: &str) -> Resp {
    Response::from_string(msg)
        .with_status_code(status)
        .with_header(header("Content-Type", "text/plain; charset=utf-8"))
}

fn header_value<'r>(req: &'r Request, name: &str) -> Option<&'r str> {
    req.headers()
        .iter()
        .find(|h| h.field.as_str().as_str().eq_ignore_ascii_case(name))
        .map(|h| h.value.as_str())
}

/// The token a request carries: `Authorization: Bearer T`, HTTP Basic with T as the
/// password (`http://user:T@host/` in a client's address), or `?token=T`.
fn request_token(req: &Request, query: &Params) -> Option<String> {
    // The scheme name is case-insensitive (RFC 9110 §11.1).
    let auth = header_value(req, "Authorization").map(str::trim);
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

pub fn handle(mut req: Request, ctx: &Ctx) {
    let url = req.url().to_string();
    let (path, query) = url.split_once('?').unwrap_or((&url, ""));
    let query = Params::parse(query.as_bytes());
    let token = request_token(&req, &query);
    if !ctx
        .access
        .allows(header_value(&req, "Host"), token.as_deref())
    {
        let _ = req.respond(text(
            403,
            "forbidden: wrong or missing access token, or a Host that is not loopback",
        ));
        return;
    }
    let put = match req.method() {
        Method::Get => false,
        Method::Put => true,
        _ => {
            let _ = req.respond(text(405, "Alpaca takes GET and PUT only"));
            return;
        }
    };
    // GET parameters are in the query string, PUT parameters in the form body.
    let params = if put {
        let mut body = Vec::new();
        let read = req.as_reader().take(MAX_BODY + 1).read_to_end(&mut body);
        if read.is_err() || body.len() as u64 > MAX_BODY {
            let _ = req.respond(text(400, "request body unreadable or too long"));
            return;
        }
        Params::parse(&body)
    } else {
        query
    };
    let resp = route(ctx, path, put, &params);
    let _ = req.respond(resp);
}

fn route(ctx: &Ctx, path: &str, put: bool, p: &Params) -> Resp {
    let parts: Vec<&str> = path.trim_matches('/').split('/').collect();
    match parts.as_slice() {
        ["api", "v1", ty, n, method] => device_call(ctx, ty, n, method, put, p),
        ["management", "apiversions"] if !put => reply(ctx, p, Ok(Some(json!([1])))),
        ["management", "v1", "description"] if !put => reply(ctx, p, Ok(Some(description(ctx)))),
        ["management", "v1", "configureddevices"] if !put => {
            reply(ctx, p, Ok(Some(configured(ctx))))
        }
        ["setup"] | ["setup", "v1", _, _, "setup"] if !put => setup_page(ctx),
        ["management", ..] | ["setup", ..] if put => text(405, "use GET"),
        _ => text(404, &format!("no Alpaca endpoint at {path}")),
    }
}

fn device_call(ctx: &Ctx, ty: &str, n: &str, method: &str, put: bool, p: &Params) -> Resp {
    let number: Option<usize> = n.parse().ok();
    let dev = ctx
        .devices
        .iter()
        .find(|d| d.ty.path().eq_ignore_ascii_case(ty) && Some(d.number) == number);
    let Some(dev) = dev else {
        return text(400, &format!("no device {ty}/{n} on this server"));
    };
    let method = method.to_ascii_lowercase();
    reply(ctx, p, dev.call(&ctx.ctl, &method, put, p))
}

/// The Alpaca reply: HTTP 200 with the transaction numbers, the value and the error
/// number, or HTTP 400 with the reason for a malformed request.
fn reply(ctx: &Ctx, p: &Params, answer: Answer) -> Resp {
    let mut m = Map::new();
    let (number, message) = match answer {
        Ok(Some(v)) => {
            m.insert("Value".into(), v);
            (0, String::new())
        }
        Ok(None) => (0, String::new()),
        Err(Fault::Device { number, message }) => (number, message),
        Err(Fault::BadRequest(why)) => return text(400, &why),
    };
    m.insert(
        "ClientTransactionID".into(),
        json!(p.u32_or_zero("ClientTransactionID")),
    );
    m.insert("ServerTransactionID".into(), json!(ctx.next_tx()));
    m.insert("ErrorNumber".into(), json!(number));
    m.insert("ErrorMessage".into(), json!(message));
    Response::from_string(Value::Object(m).to_string())
        .with_header(header("Content-Type", "application/json"))
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
fn setup_page(ctx: &Ctx) -> Resp {
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
    Response::from_string(page).with_header(header("Content-Type", "text/html; charset=utf-8"))
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
