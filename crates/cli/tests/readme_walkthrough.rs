//! The README's serve/ctl block, pasted into a shell as it stands: `serve` goes to the
//! background and `ctl` follows at once, before the board listens.

use std::process::Command;

const README: &str = include_str!("../../../README.md");

/// The README's ```sh block that starts a board.
fn serve_block() -> String {
    let mut blocks = README
        .split("```sh\n")
        .skip(1)
        .map(|b| b.split("\n```").next().unwrap());
    blocks
        .find(|b| b.contains("multistep serve --data ./board-a"))
        .expect("README has the serve/ctl block")
        .to_string()
}

#[test]
fn the_readme_serve_ctl_block_pastes_safely() {
    let block = serve_block();
    assert!(block.contains("127.0.0.1:7878"), "{block}");
    // A free port instead of 7878, so parallel runs do not collide.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let block = block.replace("127.0.0.1:7878", &format!("127.0.0.1:{port}"));
    let dir = std::env::temp_dir().join(format!("multistep-readme-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).unwrap();
    let bin_dir = std::path::Path::new(env!("CARGO_BIN_EXE_multistep"))
        .parent()
        .unwrap();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    // Each line as typed; the background board is stopped however the block ends.
    let script = format!("set -e\ntrap 'kill $(jobs -p) 2>/dev/null' EXIT\n{block}\n");
    let out = Command::new("bash")
        .args(["-c", &script])
        .current_dir(&dir)
        .env("PATH", path)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let x = stdout
        .lines()
        .find(|l| l.starts_with("a:X "))
        .unwrap_or_else(|| panic!("{stdout}"));
    let cols: Vec<&str> = x.split_whitespace().collect();
    // motor 0, homed, then moved 3200 microsteps: idle at 3200, homed and trusted
    assert_eq!(cols[1..6], ["0", "3200", "idle", "yes", "yes"], "{stdout}");
    assert!(dir.join("board-a").is_dir());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn ctl_waits_for_a_board_that_is_still_starting() {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let addr = format!("127.0.0.1:{port}");
    let bin = env!("CARGO_BIN_EXE_multistep");
    // ctl first; the board comes up a second later, well inside ctl's patience.
    let ctl = Command::new(bin)
        .args([
            "ctl",
            "--board",
            &format!("a=tcp://{addr}"),
            "status",
            "--json",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_secs(1));
    let data = std::env::temp_dir().join(format!("multistep-late-board-{}", std::process::id()));
    let mut serve = Command::new(bin)
        .args(["serve", "--listen", &addr, "--data"])
        .arg(&data)
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let out = ctl.wait_with_output().unwrap();
    serve.kill().ok();
    serve.wait().ok();
    std::fs::remove_dir_all(&data).ok();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v.as_array().map(Vec::len), Some(4), "{v}");
}
