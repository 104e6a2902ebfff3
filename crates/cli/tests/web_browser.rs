//! The operator page end to end: the real `multistep serve --http` process (and a second
//! board's `multistep serve`, shown on the same page through `--http-board`), driven by
//! Playwright (crates/web/e2e/run.mjs) in the system's headless Chromium. The scenarios
//! are in run.mjs; this test provides the service command and checks that all passed.
//!
//! Needs `apt-get install -y chromium chromium-driver`, Node.js ≥ 20 and
//! `npm ci --prefix crates/web/e2e`; without them it fails and says so.
//! `MULTISTEP_WEB_SCREENSHOT=docs/web-ui.png` also refreshes the committed screenshot.

use std::path::{Path, PathBuf};
use std::process::Command;

const CHROMIUM: &str = "/usr/bin/chromium";

fn e2e_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../web/e2e")
}

#[test]
fn operator_page_in_headless_chromium() {
    assert!(
        Path::new(CHROMIUM).exists(),
        "no browser at {CHROMIUM}: the web tests need `apt-get install -y chromium chromium-driver`"
    );
    let e2e = e2e_dir();
    let node = Command::new("node").arg("--version").output();
    assert!(
        node.is_ok_and(|o| o.status.success()),
        "node is not installed: the web tests need Node.js 20 or later"
    );
    assert!(
        e2e.join("node_modules/playwright-core").exists(),
        "playwright-core is not installed: run `npm ci --prefix crates/web/e2e`"
    );
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let screenshot = std::env::var_os("MULTISTEP_WEB_SCREENSHOT")
        .map(PathBuf::from)
        .unwrap_or_else(|| tmp.path().join("web-ui.png"));
    let config = e2e.join("board.toml");
    let service = [
        env!("CARGO_BIN_EXE_multistep"),
        "serve",
        "--data",
        data.to_str().unwrap(),
        "--listen",
        "127.0.0.1:0",
        "--board-config",
        config.to_str().unwrap(),
        "--http",
        "{http}",
        "--http-board",
        "{other}",
    ];
    // A second board with the line protocol only, shown on the same page.
    let other_data = tmp.path().join("other");
    let other_config = e2e.join("board-b.toml");
    let other = [
        env!("CARGO_BIN_EXE_multistep"),
        "serve",
        "--data",
        other_data.to_str().unwrap(),
        "--listen",
        "127.0.0.1:0",
        "--board-config",
        other_config.to_str().unwrap(),
    ];
    let out = Command::new("node")
        .arg("run.mjs")
        .current_dir(&e2e)
        .env("SERVICE_ARGV", serde_json::to_string(&service).unwrap())
        .env("OTHER_ARGV", serde_json::to_string(&other).unwrap())
        .env("SCREENSHOT", &screenshot)
        .env("CHROMIUM", CHROMIUM)
        .output()
        .expect("run node");
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}");
    eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "browser scenarios failed (see above)");
    assert!(
        stdout.contains("16 passed, 0 failed"),
        "not every scenario ran"
    );
    let png = std::fs::read(&screenshot).expect("screenshot written");
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 10_000,
        "screenshot is not a real PNG"
    );
}
