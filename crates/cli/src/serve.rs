//! `multistep serve`: one controller board (simulated, or the FPGA board on a serial link)
//! on TCP and optionally a serial line.

use anyhow::{anyhow, bail, Context};
use clap::Args;
use multistep_controller::backend::{FpgaBackend, LinkSpec};
use multistep_controller::store::Store;
use multistep_controller::CtlError;
use multistep_controller::{controller, service, BoardConfig, Controller};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Directory of the board's database (settings, presets, named positions, positions)
    #[arg(long, value_name = "DIR")]
    pub data: PathBuf,
    /// TCP address to listen on (port 0: any free port; the address is printed)
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:7878")]
    pub listen: String,
    /// Also serve the protocol on this serial device (115200 8N1)
    #[arg(long, value_name = "DEVICE")]
    pub serial: Option<String>,
    /// Board configuration (TOML: board name, axes and their settings); default: axes X Y Z A
    #[arg(long, value_name = "FILE")]
    pub board_config: Option<PathBuf>,
    /// Drive the FPGA board on this link (serial:DEVICE[@BAUD][,timeout=SECONDS], baud
    /// 3000000 and reply timeout 0.5 s unless given) instead of the simulated board;
    /// overrides the config's board.link
    #[arg(long, value_name = "LINK")]
    pub board_link: Option<String>,
    /// Simulated time runs this many times faster than the wall clock, 0.001 to 10000
    /// (below 1: slower); 1 with a board link
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub time_scale: f64,
    /// The simulated board's crystal error in ppm, -1000 to 1000 (negative: slow): its
    /// ticks run that much off host time; the host fits it from readings of the board's
    /// counter and keeps tracking to host time (not with a board link)
    #[arg(long, value_name = "PPM", allow_hyphen_values = true)]
    pub ppm: Option<f64>,
    #[command(flatten)]
    pub http: multistep_web::HttpArgs,
    #[command(flatten)]
    pub alpaca: multistep_alpaca::AlpacaArgs,
    #[command(flatten)]
    pub line: LineArgs,
}

/// Who may connect to the line protocol over TCP, how many at once, and for how long.
#[derive(Args, Debug)]
pub struct LineArgs {
    /// Allow --listen on a non-loopback address (needs --listen-token)
    #[arg(long)]
    pub listen_allow_remote: bool,
    /// Access token TCP clients must send first (`auth TOKEN`), 16 to 256 characters;
    /// falls back to the MULTISTEP_LISTEN_TOKEN environment variable
    #[arg(
        long,
        value_name = "TOKEN",
        env = "MULTISTEP_LISTEN_TOKEN",
        hide_env_values = true
    )]
    pub listen_token: Option<String>,
    /// Most TCP clients at once (1 to 1024); one more gets one error line and is closed
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub max_clients: usize,
    /// Close a TCP client that sends no complete line for this many seconds (1 to 86400)
    #[arg(long, value_name = "S", default_value_t = 600)]
    pub idle_timeout: u64,
    /// Close a TCP client whose line is not complete this many seconds after it began; on
    /// the serial line, drop a line that pauses this long (1 to 3600)
    #[arg(long, value_name = "S", default_value_t = 10)]
    pub line_timeout: u64,
    /// If the database is damaged, move it aside (the new name is printed) and start a new,
    /// empty board instead of refusing to start
    #[arg(long)]
    pub reset_damaged_data: bool,
}

pub fn run(a: &ServeArgs) -> anyhow::Result<()> {
    let config = match &a.board_config {
        Some(p) => load_board_config(p)?,
        None => BoardConfig::default(),
    };
    // Before the database is touched: a refused start changes nothing.
    controller::check_time_scale(a.time_scale)?;
    let l = &a.line;
    service::check_listen(&a.listen, l.listen_allow_remote, l.listen_token.as_deref())?;
    let limits = service::Limits::new(l.max_clients, l.idle_timeout, l.line_timeout)?;
    a.http.check()?;
    a.alpaca.check(&config)?;
    if let Some(dev) = &a.serial {
        // A missing device is a mistake to stop on, not a warning behind a running board.
        std::fs::metadata(dev).with_context(|| format!("serial device {dev}"))?;
    }
    let link = match a.board_link.as_ref().or(config.board.link.as_ref()) {
        Some(l) => Some(LinkSpec::parse(l)?),
        None => None,
    };
    if link.is_some() && a.time_scale != 1.0 {
        bail!("--time-scale: a board on a link runs in real time (1)");
    }
    if let Some(p) = a.ppm {
        if link.is_some() {
            bail!("--ppm: only a simulated board takes a crystal error; a board on a link has its own");
        }
        multistep_controller::clock_rate::check_ppm(p).context("--ppm")?;
    }
    let store = open_store(&a.data, l.reset_damaged_data)?;
    let ctl = match &link {
        None => match a.ppm {
            Some(p) => Controller::open_sim(&config, store, a.time_scale, p)?,
            None => Controller::open_store(&config, store, a.time_scale)?,
        },
        Some(spec) => {
            // the session this data directory's host kept: the board may still run it
            let before = store.link_session()?;
            let pins = FpgaBackend::connect_resuming(spec, config.axes.len(), before)
                .with_context(|| format!("board link {spec}"))?;
            Controller::open_backend(&config, store, a.time_scale, Box::new(pins))?
        }
    };
    let ctl = Arc::new(ctl);
    // One mount per telescope, shared by the line protocol's `mount` and the Alpaca side.
    let section = multistep_alpaca::AlpacaSection::from_board(&config)?;
    ctl.attach_mounts(&section.telescope).context("telescope")?;
    let listener = service::bind(&a.listen)?;
    let addr = listener.local_addr().context("listening address")?;
    let _web = a.http.start(vec![ctl.clone()])?;
    let _alpaca = a.alpaca.start(&config, ctl.clone())?;
    // opened before the announcement below, so a byte sent after it is never dropped
    if let Some(dev) = &a.serial {
        let port = service::open_serial(dev)?;
        let (ctl, dev) = (ctl.clone(), dev.clone());
        std::thread::spawn(move || {
            service::serve_serial_port(ctl, &dev, port, limits.line_timeout)
        });
    }
    // The first line tells scripts (and tests) where the board is.
    let mut out = std::io::stdout();
    writeln!(out, "board {} listening on tcp://{addr}", config.board.name)?;
    out.flush()?;
    let opts = service::TcpOptions {
        limits,
        token: l.listen_token.clone(),
    };
    service::serve_tcp_with(ctl, listener, opts)?;
    Ok(())
}

/// The board config; every error names the file, on one line.
fn load_board_config(path: &Path) -> anyhow::Result<BoardConfig> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read board config {}", path.display()))?;
    BoardConfig::parse(&text).map_err(|e| {
        let msg = match e {
            CtlError::Setting(m) => m.strip_prefix("board config: ").unwrap_or(&m).to_string(),
            e => e.to_string(),
        };
        anyhow!("board config {}: {}", path.display(), without_snippet(&msg))
    })
}

/// A TOML error's message without its source snippet (`1 | text`, `  |   ^`).
fn without_snippet(msg: &str) -> String {
    let snippet = |l: &str| {
        let l = l.trim_start_matches(|c: char| c.is_ascii_digit() || c == ' ');
        l.is_empty() || l.starts_with('|')
    };
    let kept: Vec<&str> = msg.lines().filter(|l| !snippet(l)).map(str::trim).collect();
    kept.join(": ")
}

/// Opens the board's database in its `--data` directory (moving a damaged one aside when
/// `reset_damaged` is set); storage errors name the directory.
fn open_store(data: &Path, reset_damaged: bool) -> anyhow::Result<Store> {
    if data.exists() && !data.is_dir() {
        bail!("--data {}: not a directory", data.display());
    }
    std::fs::create_dir_all(data)
        .with_context(|| format!("--data {}: cannot create the directory", data.display()))?;
    let (store, aside) = Store::open_or_reset(data, reset_damaged).map_err(|e| match e {
        CtlError::Store(msg) if msg.contains("in use by another process") => anyhow!(
            "--data {}: {msg} (is another `multistep serve` using it?)",
            data.display()
        ),
        CtlError::Store(msg) => anyhow!("--data {}: board database: {msg}", data.display()),
        e => e.into(),
    })?;
    if let Some(p) = aside {
        eprintln!(
            "warning: the damaged database was moved to {}; starting a new board",
            p.display()
        );
    }
    Ok(store)
}
