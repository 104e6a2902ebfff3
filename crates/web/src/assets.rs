//! The page, compiled into the binary: nothing is fetched from anywhere at build or run time.

/// `(path, content type, body)` of every static file.
pub const FILES: &[(&str, &str, &str)] = &[
    (
        "/",
        "text/html; charset=utf-8",
        include_str!("../assets/index.html"),
    ),
    (
        "/app.js",
        "text/javascript; charset=utf-8",
        include_str!("../assets/app.js"),
    ),
    (
        "/mount.js",
        "text/javascript; charset=utf-8",
        include_str!("../assets/mount.js"),
    ),
    (
        "/style.css",
        "text/css; charset=utf-8",
        include_str!("../assets/style.css"),
    ),
];

pub fn find(path: &str) -> Option<(&'static str, &'static str)> {
    let path = if path == "/index.html" { "/" } else { path };
    FILES.iter().find(|f| f.0 == path).map(|f| (f.1, f.2))
}
