//! `natnet-serve`: the emulated lab's OptiTrack as its own process, serving
//! the bodies of a small TOML config (see `deploy/natnet-serve.toml`) by
//! NatNet until stdin closes or `--seconds` pass. Prints one line
//! `command_port=N data_port=M` on stdout once listening, for tests and
//! scripts that bind port 0.

use bycoms_natnet_server::{NatNetServer, ServerConfig};
use bycoms_runtime::seconds::Zero;
use clap::Parser;
use std::io::{BufRead, Write};
use std::net::{IpAddr, SocketAddr};

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
    let limit = bycoms_natnet_server::config::MAX_FILE_BYTES;
    let text = bycoms_runtime::capped::read_capped_file(&cli.config, limit)
        .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", cli.config.display()))?;
    let config: ServerConfig =
        toml::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", cli.config.display()))?;
    let server = NatNetServer::start(config, SocketAddr::new(cli.bind, cli.command_port))?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "command_port={} data_port={}", server.command_addr().port(), server.data_addr().port())?;
    out.flush()?;
    match cli.seconds {
        Some(s) => std::thread::sleep(
            bycoms_runtime::seconds::check_seconds("--seconds", s, Zero::Allowed)
                .map_err(anyhow::Error::msg)?,
        ),
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
