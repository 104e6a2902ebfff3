//! Routing: static files, the JSON endpoints and the event stream. Commands run through
//! the controller's protocol dispatcher; nothing here interprets a command itself.

use crate::access::Access;
use crate::boards::{error_json, BoardLink};
use crate::{assets, events, preview};
use multistep_controller::protocol::{self, Command};
use multistep_controller::{Controller, CtlError};
use serde::Deserialize;
use serde_json::{json, Value};
use std::collections::HashMap;
use std::io::Read;
use std::net::IpAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use tiny_http::{Header, Method, Request, Response};

/// Largest request body accepted (a protocol line is at most 4 KiB).
const MAX_BODY: u64 = 16 * 1024;
/// Most event streams open at once (each holds a thread).
const MAX_STREAMS: usize = 32;
/// Most event streams from one client address: one client cannot take every slot, so the
/// operator's page finds one free.
const MAX_STREAMS_PER_CLIENT: usize = 4;

pub struct Ctx {
    boards: Vec<BoardLink>,
    access: Access,
    streams: AtomicUsize,
    per_client: Mutex<HashMap<IpAddr, usize>>,
}

impl Ctx {
    pub fn new(boards: Vec<BoardLink>, access: Access) -> Ctx {
        Ctx {
            boards,
            access,
            streams: AtomicUsize::new(0),
            per_client: Mutex::new(HashMap::new()),
        }
    }
}

/// What the page posts to `/api/cmd` and `/api/preview`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LineRequest {
    #[serde(default)]
    board: usize,
    line: String,
}

type Resp = Response<std::io::Cursor<Vec<u8>>>;

fn header(k: &str, v: &str) -> Header {
    Header::from_bytes(k.as_bytes(), v.as_bytes()).expect("static header")
}

fn with_common(r: Resp) -> Resp {
    r.with_header(header("Cache-Control", "no-store"))
        .with_header(header("X-Content-Type-Options", "nosniff"))
        .with_header(header("X-Frame-Options", "DENY"))
}

fn json_resp(status: u16, v: &Value) -> Resp {
    with_common(
        Response::from_string(v.to_string())
            .with_status_code(status)
            .with_header(header("Content-Type", "application/json")),
    )
}

fn fail(status: u16, msg: &str) -> Resp {
    json_resp(
        status,
        &json!({ "ok": false, "error": { "code": 0, "message": msg } }),
    )
}

fn split_url(url: &str) -> (&str, &str) {
    url.split_once('?').unwrap_or((url, ""))
}

fn query_param(query: &str, key: &str) -> Option<String> {
    query.split('&').find_map(|kv| {
        let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
        (k == key).then(|| percent_decode(v))
    })
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        match b[i] {
            b'%' if i + 2 < b.len() => match (hex(b[i + 1]), hex(b[i + 2])) {
                (Some(h), Some(l)) => {
                    out.push((h * 16 + l) as u8);
                    i += 2;
                }
                _ => out.push(b'%'),
            },
            b'+' => out.push(b' '),
            c => out.push(c),
        }
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// `Bearer TOKEN`, the scheme in any case (RFC 7235: schemes are case-insensitive).
fn bearer_token(v: &str) -> Option<&str> {
    let (scheme, token) = v.trim().split_once(' ')?;
    scheme.eq_ignore_ascii_case("bearer").then(|| token.trim())
}

fn header_value<'r>(req: &'r Request, name: &str) -> Option<&'r str> {
    req.headers()
        .iter()
        .find(|h| h.field.as_str().as_str().eq_ignore_ascii_case(name))
        .map(|h| h.value.as_str())
}

pub fn handle(mut req: Request, ctx: &Ctx) {
    let (path, query) = split_url(req.url());
    let (path, query) = (path.to_string(), query.to_string());
    let token = header_value(&req, "Authorization")
        .and_then(bearer_token)
        .map(str::to_string)
        .or_else(|| query_param(&query, "token"));
    if !ctx
        .access
        .allows(header_value(&req, "Host"), token.as_deref())
    {
        let _ = req.respond(fail(403, "forbidden: wrong or missing access token (add ?token=… to the address), or a Host that is not loopback"));
        return;
    }
    let resp = match (req.method(), path.as_str()) {
        (Method::Get, "/api/events") => return stream_events(req, ctx),
        (Method::Get, "/api/boards") => json_resp(200, &boards(ctx)),
        (Method::Get, "/api/status") => json_resp(
            200,
            &serde_json::to_value(events::snapshot(&ctx.boards)).unwrap_or_default(),
        ),
        (Method::Post, "/api/cmd") => match read_line_request(&mut req, ctx) {
            Ok((b, line)) => json_resp(200, &b.run(&line)),
            Err(r) => r,
        },
        (Method::Post, "/api/preview") => match read_line_request(&mut req, ctx) {
            Ok((BoardLink::Local(c), line)) => json_resp(200, &preview_json(c, &line)),
            Ok((BoardLink::Remote(_), _)) => json_resp(
                200,
                &error_json(&CtlError::syntax(
                    "previews are planned by the board's own service: open its page",
                )),
            ),
            Err(r) => r,
        },
        (Method::Get, p) => match assets::find(p) {
            Some((ctype, body)) => with_common(
                Response::from_string(body)
                    .with_header(header("Content-Type", ctype))
                    .with_header(header(
                        "Content-Security-Policy",
                        "default-src 'self'; frame-ancestors 'none'",
                    )),
            ),
            None => fail(404, "not found"),
        },
        _ => fail(405, "method not allowed"),
    };
    let _ = req.respond(resp);
}

fn boards(ctx: &Ctx) -> Value {
    let list: Vec<Value> = ctx
        .boards
        .iter()
        .enumerate()
        .map(|(k, b)| b.describe(k))
        .collect();
    json!({ "boards": list, "version": env!("CARGO_PKG_VERSION") })
}

/// The body of a POST: JSON only, so a foreign page cannot post a plain form to
/// 127.0.0.1 without the browser's CORS preflight stopping it.
fn read_line_request<'c>(req: &mut Request, ctx: &'c Ctx) -> Result<(&'c BoardLink, String), Resp> {
    let is_json = header_value(req, "Content-Type")
        .is_some_and(|v| v.trim_start().starts_with("application/json"));
    if !is_json {
        return Err(fail(415, "send the request as application/json"));
    }
    let mut body = String::new();
    let n = req.as_reader().take(MAX_BODY + 1).read_to_string(&mut body);
    if n.is_err() || body.len() as u64 > MAX_BODY {
        return Err(fail(400, "request body is not UTF-8 or too long"));
    }
    let r: LineRequest =
        serde_json::from_str(&body).map_err(|e| fail(400, &format!("bad request: {e}")))?;
    if r.line.contains(['\n', '\r']) {
        return Err(fail(400, "one protocol line per request"));
    }
    let c = ctx
        .boards
        .get(r.board)
        .ok_or_else(|| fail(404, &format!("no board {}", r.board)))?;
    Ok((c, r.line))
}

/// Plans a `move`, `moveto` or `group` line exactly as running it would, without running it.
fn preview_json(c: &Controller, line: &str) -> Value {
    let err = |e: CtlError| error_json(&e);
    let cmd = match protocol::parse(line) {
        Ok(c) => c,
        Err(e) => return err(e),
    };
    let (targets, absolute, sync, opts) = match cmd {
        Command::Move { axis, by, opts } => (vec![(axis, by)], false, false, opts),
        Command::MoveTo { axis, to, opts } => (vec![(axis, to)], true, false, opts),
        Command::Group {
            absolute,
            targets,
            sync,
            opts,
        } => (targets, absolute, sync, opts),
        _ => {
            return err(CtlError::syntax(
                "preview works for move, moveto and group lines",
            ))
        }
    };
    let planned = c.with_board(|b, _| {
        b.preview(&targets, absolute, sync, &opts)
            .map(|p| (p, b.clock_hz()))
    });
    match planned {
        Err(e) => err(e),
        Ok((axes, clock)) => {
            let axes: Result<Vec<_>, _> = axes
                .iter()
                .map(|p| preview::axis_preview(p, clock))
                .collect();
            match axes {
                Ok(a) => json!({ "ok": true, "axes": a }),
                Err(e) => err(e.into()),
            }
        }
    }
}

fn stream_events(req: Request, ctx: &Ctx) {
    let peer = req.remote_addr().map(|a| a.ip());
    let Some(_slot) = StreamSlot::take(ctx, peer) else {
        let _ = req.respond(fail(503, "too many open event streams"));
        return;
    };
    let mut out = req.into_writer();
    let _ = events::stream(&ctx.boards, &mut *out);
}

/// One open event stream, counted in total and per client address until dropped.
struct StreamSlot<'c> {
    ctx: &'c Ctx,
    peer: Option<IpAddr>,
}

impl<'c> StreamSlot<'c> {
    fn take(ctx: &'c Ctx, peer: Option<IpAddr>) -> Option<StreamSlot<'c>> {
        let mut per = ctx.per_client.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(ip) = peer {
            let n = per.entry(ip).or_insert(0);
            if *n >= MAX_STREAMS_PER_CLIENT {
                return None;
            }
            *n += 1;
        }
        if ctx.streams.fetch_add(1, Ordering::SeqCst) >= MAX_STREAMS {
            ctx.streams.fetch_sub(1, Ordering::SeqCst);
            if let Some(ip) = peer {
                release(&mut per, ip);
            }
            return None;
        }
        Some(StreamSlot { ctx, peer })
    }
}

fn release(per: &mut HashMap<IpAddr, usize>, ip: IpAddr) {
    if let Some(n) = per.get_mut(&ip) {
        *n -= 1;
        if *n == 0 {
            per.remove(&ip);
        }
    }
}

impl Drop for StreamSlot<'_> {
    fn drop(&mut self) {
        self.ctx.streams.fetch_sub(1, Ordering::SeqCst);
        if let Some(ip) = self.peer {
            let mut per = self
                .ctx
                .per_client
                .lock()
                .unwrap_or_else(|p| p.into_inner());
            release(&mut per, ip);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bearer_scheme_is_case_insensitive() {
        assert_eq!(bearer_token("Bearer abc"), Some("abc"));
        assert_eq!(bearer_token("bearer abc"), Some("abc"));
        assert_eq!(bearer_token("BEARER  abc "), Some("abc"));
        assert_eq!(bearer_token("Basic abc"), None);
        assert_eq!(bearer_token("Bearerabc"), None);
    }

    #[test]
    fn one_client_cannot_take_every_event_stream() {
        let ctx = Ctx::new(
            Vec::new(),
            Access {
                token: None,
                loopback: true,
            },
        );
        let greedy: IpAddr = "10.0.0.7".parse().unwrap();
        let operator: IpAddr = "10.0.0.8".parse().unwrap();
        let held: Vec<_> = (0..40)
            .filter_map(|_| StreamSlot::take(&ctx, Some(greedy)))
            .collect();
        assert_eq!(held.len(), MAX_STREAMS_PER_CLIENT);
        let page = StreamSlot::take(&ctx, Some(operator));
        assert!(page.is_some(), "the operator's page still gets a stream");
        drop(held);
        drop(page);
        assert_eq!(ctx.streams.load(Ordering::SeqCst), 0);
        assert!(ctx.per_client.lock().unwrap().is_empty());
    }

    #[test]
    fn query_parameters_are_decoded() {
        assert_eq!(
            query_param("a=1&token=x%2By%21z", "token").as_deref(),
            Some("x+y!z")
        );
        assert_eq!(query_param("token=a+b", "token").as_deref(), Some("a b"));
        assert_eq!(
            query_param("token=%zz%4", "token").as_deref(),
            Some("%zz%4")
        );
        assert_eq!(query_param("x=1", "token"), None);
    }
}
