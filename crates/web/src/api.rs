//! Routing: static files, the JSON endpoints and the event stream. Commands run through
//! the controller's protocol dispatcher; nothing here interprets a command itself.

use crate::access::Access;
use crate::boards::{error_json, BoardLink};
use crate::server::{Request, Response};
use crate::streams::Streams;
use crate::{assets, events, preview};
use multistep_controller::protocol::{self, Command};
use multistep_controller::{Controller, CtlError};
use serde::Deserialize;
use serde_json::{json, Value};
use std::sync::Arc;

pub struct Ctx {
    boards: Vec<BoardLink>,
    access: Access,
    streams: Arc<Streams>,
}

impl Ctx {
    /// `max_streams`: most event streams at once.
    pub fn new(boards: Vec<BoardLink>, access: Access, max_streams: usize) -> Ctx {
        Ctx {
            boards,
            access,
            streams: Streams::new(max_streams),
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

fn with_common(r: Response) -> Response {
    r.with_header("Cache-Control", "no-store")
        .with_header("X-Content-Type-Options", "nosniff")
        .with_header("X-Frame-Options", "DENY")
}

fn json_resp(status: u16, v: &Value) -> Response {
    with_common(Response::new(status, "application/json", v.to_string()))
}

fn fail(status: u16, msg: &str) -> Response {
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

pub fn handle(req: &Request, ctx: &Arc<Ctx>) -> Response {
    let (path, query) = split_url(req.url());
    let token = req
        .header("Authorization")
        .and_then(bearer_token)
        .map(str::to_string)
        .or_else(|| query_param(query, "token"));
    if !ctx.access.allows(req.header("Host"), token.as_deref()) {
        return fail(403, "forbidden: wrong or missing access token (add ?token=… to the address), or a Host that is not loopback");
    }
    match (req.method(), path) {
        ("GET", "/api/events") => stream_events(req, ctx),
        ("GET", "/api/boards") => json_resp(200, &boards(ctx)),
        ("GET", "/api/status") => json_resp(
            200,
            &serde_json::to_value(events::snapshot(&ctx.boards)).unwrap_or_default(),
        ),
        ("POST", "/api/cmd") => match read_line_request(req, ctx) {
            Ok((b, line)) => json_resp(200, &b.run(&line)),
            Err(r) => r,
        },
        ("POST", "/api/preview") => match read_line_request(req, ctx) {
            Ok((BoardLink::Local(c), line)) => json_resp(200, &preview_json(c, &line)),
            Ok((BoardLink::Remote(_), _)) => json_resp(
                200,
                &error_json(&CtlError::syntax(
                    "previews are planned by the board's own service: open its page",
                )),
            ),
            Err(r) => r,
        },
        ("GET", p) => match assets::find(p) {
            Some((ctype, body)) => with_common(Response::new(200, ctype, body).with_header(
                "Content-Security-Policy",
                "default-src 'self'; frame-ancestors 'none'",
            )),
            None => fail(404, "not found"),
        },
        _ => fail(405, "method not allowed"),
    }
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
fn read_line_request<'c>(req: &Request, ctx: &'c Ctx) -> Result<(&'c BoardLink, String), Response> {
    let is_json = req
        .header("Content-Type")
        .is_some_and(|v| v.trim_start().starts_with("application/json"));
    if !is_json {
        return Err(fail(415, "send the request as application/json"));
    }
    // The server has refused bodies over its limit (16 KiB).
    let body =
        std::str::from_utf8(req.body()).map_err(|_| fail(400, "request body is not UTF-8"))?;
    let r: LineRequest =
        serde_json::from_str(body).map_err(|e| fail(400, &format!("bad request: {e}")))?;
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
    let planned = c
        .preview(&targets, absolute, sync, &opts)
        .map(|p| (p, c.clock_hz()));
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

fn stream_events(req: &Request, ctx: &Arc<Ctx>) -> Response {
    let Some(slot) = ctx.streams.take(Some(req.peer().ip())) else {
        return fail(503, "too many open event streams");
    };
    let ctx = ctx.clone();
    Response::stream(
        "text/event-stream",
        Box::new(move |out| events::stream(&ctx.boards, &slot, out)),
    )
    .with_header("Cache-Control", "no-store")
    .with_header("X-Content-Type-Options", "nosniff")
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
