//! `natnet-serve`: the emulated lab's OptiTrack as its own process, serving
//! the bodies of a small TOML config (see `deploy/natnet-serve.toml`) by
//! NatNet until stdin closes or `--seconds` pass. Prints one line
//! `command_port=N data_port=M` on stdout once listening, for tests and
//! scripts that bind port 0.

use bycoms_sim::natnet_server::{NatNetServer, ServerConfig};
use clap::Parser;
use std::io::{BufRead, Write};
use std::net::{IpAddr, SocketAddr};
use std::time::Duration;

#[derive(Parser)]
#[command(name = "natnet-serve", version, about)]
struct Cli {
    #[command(flatten)]
    log: bycoms_runtime::logging::LogArgs,
    /// The server's TOML config (bodies, rate, faults).
    #[arg(long)]
    config: std::path::PathBuf,
    /// Address to bind the command channel on.
    #[arg(long, default_value = "127.0.0.1")]
    bind: IpAddr,
    /// Command port (Motive's is 1510; 0 picks a free one).
    #[arg(long, default_value_t = 0)]
    command_port: u16,
    /// Stop after this many seconds (default: when stdin closes).
    #[arg(long)]
    seconds: Option<f64>,
}

fn run(cli: &Cli) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&cli.config)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", cli.config.display()))?;
    let config: ServerConfig =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", cli.config.display()))?;
    let server = NatNetServer::start(config, SocketAddr::new(cli.bind, cli.command_port))?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "command_port={} data_port={}", server.command_addr().port(), server.data_addr().port())?;
    out.flush()?;
    match cli.seconds {
        Some(s) if s.is_finite() && s >= 0.0 => std::thread::sleep(Duration::from_secs_f64(s)),
        Some(s) => anyhow::bail!("--seconds must be finite and ≥ 0, got {s}"),
        None => for _ in std::io::stdin().lock().lines() {},
    }
    drop(server);
    Ok(())
}

fn main() {
    let cli = Cli::parse();
    bycoms_runtime::logging::init(cli.log.log_format);
    if let Err(e) = run(&cli) {
        tracing::error!("{}", bycoms_runtime::logging::error_text(e.as_ref()));
        std::process::exit(1);
    }
}
