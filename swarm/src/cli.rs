//! Argument parsing and dispatch. One [`ZenohArgs`] is flattened into every subcommand that talks
//! to Zenoh; doc comments are the help text.

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use swarm_config::Scenario;

/// Zenoh-networked UAV swarm: physics hub, one agent per UAV, recorder.
#[derive(Parser, Debug)]
#[command(name = "swarm", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub cmd: Cmd,
}

/// Endpoints and overrides shared by every piece that opens a Zenoh session.
#[derive(Args, Debug, Clone, Default)]
pub struct ZenohArgs {
    /// Endpoint to connect to, e.g. `tcp/10.0.0.5:7447` (repeatable).
    #[arg(long = "connect", short = 'e')]
    pub connect: Vec<String>,
    /// Endpoint to listen on, e.g. `tcp/0.0.0.0:7447` (repeatable; the hub only).
    #[arg(long = "listen", short = 'l')]
    pub listen: Vec<String>,
    /// Zenoh config override `KEY:JSON5`, e.g. `transport/link/tx/lease:3000` (repeatable).
    #[arg(long = "cfg")]
    pub cfg: Vec<String>,
}

/// Subcommands.
#[derive(Subcommand, Debug)]
pub enum Cmd {
    /// Run a scenario end to end: hub, one agent process per UAV, recorder; write the run folder.
    Run(RunArgs),
    /// Start the physics hub (a Zenoh router) by hand.
    Hub(HubArgs),
    /// Start one UAV agent by hand (a Zenoh client of the hub).
    Agent(AgentArgs),
    /// Record a run started by hand: write the run folder when the hub ends the run.
    Record(RecordArgs),
    /// Print every message on a key expression as JSON lines.
    Tap(crate::tap::TapArgs),
    /// Publish one message (as JSON, or raw hex) on a key.
    Put(crate::tap::PutArgs),
    /// Change the network faults of a running swarm (loss, delay, partition, isolate, heal).
    Netem(crate::netem_cli::NetemArgs),
    /// Fly one scenario with each controller and print the comparison (seed 000 section 6.5).
    Compare(crate::study::CompareArgs),
    /// Fly seed 004's formation topologies and print its Table 8 beside ours.
    Formations(crate::study::FormationsArgs),
    /// Sweep the broadcast-position error δa (seed 001 section 6): print and plot min distances.
    SweepError(crate::study::SweepArgs),
    /// List the built-in scenarios.
    Scenarios,
    /// Validate a scenario file and print what it resolves to.
    Check {
        /// Scenario file or built-in name.
        scenario: String,
    },
}

/// `swarm run`.
#[derive(Args, Debug, Clone)]
pub struct RunArgs {
    /// Scenario file or built-in name (default: forest-5).
    pub scenario: Option<String>,
    /// Run folder (default: runs/<run id>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Run id: every key is under swarm/<run id> (default: <scenario>-<time>-<pid>).
    #[arg(long)]
    pub run: Option<String>,
    /// Override the scenario's time mode (`lockstep` or `realtime`).
    #[arg(long)]
    pub time_mode: Option<String>,
    /// Override the scenario's master seed (forest, start area, sensor noise).
    #[arg(long)]
    pub seed: Option<u64>,
    /// An experiment file (`[[netem]]` and `[[failures]]` tables, sim times) added to the
    /// scenario's own timeline.
    #[arg(long)]
    pub experiment: Option<PathBuf>,
    /// Zenoh config override `KEY:JSON5` for every piece of the run (repeatable).
    #[arg(long)]
    pub cfg: Vec<String>,
    /// Do not draw a progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// `swarm hub`.
#[derive(Args, Debug, Clone)]
pub struct HubArgs {
    /// Scenario file or built-in name (default: forest-5).
    pub scenario: Option<String>,
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
    /// Exit when standard input closes (the launcher's way to take its children down with it).
    #[arg(long, hide = true)]
    pub exit_with_stdin: bool,
}

/// `swarm agent`.
#[derive(Args, Debug, Clone)]
pub struct AgentArgs {
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// UAV id (1-based).
    #[arg(long)]
    pub id: u32,
    /// Use this scenario file instead of fetching the scenario from the hub.
    #[arg(long)]
    pub scenario: Option<String>,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
    /// Exit when standard input closes.
    #[arg(long, hide = true)]
    pub exit_with_stdin: bool,
    /// Seconds to hover and wait when the hub's liveliness token goes away (its link may come
    /// back: the session reconnects by itself) before exiting.
    #[arg(long, default_value_t = 3.0)]
    pub hub_grace_s: f64,
}

/// `swarm record`.
#[derive(Args, Debug, Clone)]
pub struct RecordArgs {
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// Run folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Endpoints.
    #[command(flatten)]
    pub zenoh: ZenohArgs,
}

/// Writes `text` to standard output; a reader that went away (`swarm scenarios | head`) ends the
/// output quietly instead of a panic.
fn print_out(text: &str) -> Result<()> {
    use std::io::Write;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}

/// Entry point of the binary: parse, set up logging and the runtime, dispatch.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    init_tracing();
    let rt = match tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build() {
        Ok(rt) => rt,
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            return ExitCode::FAILURE;
        }
    };
    let code = match rt.block_on(dispatch(cli)) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    };
    // Do not wait for the blocking thread that may still be reading stdin.
    rt.shutdown_timeout(std::time::Duration::from_millis(200));
    code
}

fn init_tracing() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,zenoh=warn,zenoh_transport=warn"));
    use std::io::IsTerminal;
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .try_init();
}

/// Resolves when Ctrl-C arrives or, with `watch_stdin`, when standard input closes.
pub async fn shutdown_signal(watch_stdin: bool) {
    {
        let stdin_closed = async {
            if watch_stdin {
                use tokio::io::AsyncReadExt;
                let mut stdin = tokio::io::stdin();
                let mut buf = [0u8; 64];
                loop {
                    match stdin.read(&mut buf).await {
                        Ok(0) => break,
                        Ok(_) => {}
                        Err(e) => {
                            tracing::warn!("standard input failed ({e}); no longer watching it");
                            std::future::pending::<()>().await;
                        }
                    }
                }
                tracing::info!("standard input closed: shutting down");
            } else {
                std::future::pending::<()>().await;
            }
        };
        tokio::select! {
            r = tokio::signal::ctrl_c() => match r {
                Ok(()) => tracing::info!("interrupted: shutting down"),
                Err(e) => {
                    tracing::warn!("cannot listen for Ctrl-C ({e})");
                    std::future::pending::<()>().await;
                }
            },
            _ = stdin_closed => {},
        }
    }
}

async fn dispatch(cli: Cli) -> Result<ExitCode> {
    match cli.cmd {
        Cmd::Run(a) => crate::launch::run(a).await,
        Cmd::Hub(a) => hub(a).await,
        Cmd::Agent(a) => agent(a).await,
        Cmd::Record(a) => crate::launch::record_only(a).await,
        Cmd::Tap(a) => crate::tap::tap(a).await,
        Cmd::Put(a) => crate::tap::put(a).await,
        Cmd::Netem(a) => crate::netem_cli::netem(a).await,
        Cmd::Compare(a) => crate::study::compare(a).await,
        Cmd::SweepError(a) => crate::study::sweep_error(a).await,
        Cmd::Formations(a) => crate::study::formations(a).await,
        Cmd::Scenarios => {
            let width = swarm_config::BUILTIN.iter().map(|(n, _)| n.len()).max().unwrap_or(0);
            let mut list = String::new();
            for (name, text) in swarm_config::BUILTIN {
                let desc = Scenario::from_toml_str(text, name).map(|s| s.description).unwrap_or_default();
                list.push_str(&format!("{name:width$}  {desc}\n"));
            }
            print_out(&list)?;
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Check { scenario } => {
            let (sc, _) = Scenario::from_arg(&scenario)?;
            print_out(&format!("{}\n", serde_json::to_string_pretty(&sc)?))?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// The line the hub prints on stdout once it listens; the launcher reads it.
pub const LISTENING_PREFIX: &str = "swarm-hub listening:";

async fn hub(a: HubArgs) -> Result<ExitCode> {
    let name = a.scenario.as_deref().unwrap_or(swarm_config::DEFAULT_SCENARIO);
    let (sc, text) = Scenario::from_arg(name)?;
    let listen = if a.zenoh.listen.is_empty() { vec!["tcp/127.0.0.1:7447".to_string()] } else { a.zenoh.listen };
    let opts = physics_hub::HubOptions { run: a.run, listen, connect: a.zenoh.connect, zenoh_cfg: a.zenoh.cfg };
    let report = physics_hub::run(
        sc,
        text,
        opts,
        |locators| {
            println!("{LISTENING_PREFIX} {}", locators.join(" "));
        },
        shutdown_signal(a.exit_with_stdin),
    )
    .await
    .context("hub failed")?;
    tracing::info!(end = ?report.end, ticks = report.ticks, malformed_cmds = report.malformed, "hub done");
    Ok(ExitCode::SUCCESS)
}

async fn agent(a: AgentArgs) -> Result<ExitCode> {
    let scenario = match &a.scenario {
        Some(s) => Some(Scenario::from_arg(s)?.0),
        None => None,
    };
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "an agent needs --connect <hub endpoint>");
    let opts = uav_agent::AgentOptions {
        run: a.run,
        id: a.id,
        connect: a.zenoh.connect,
        zenoh_cfg: a.zenoh.cfg,
        scenario,
        hub_grace_s: a.hub_grace_s,
    };
    let exit = uav_agent::run(opts, shutdown_signal(a.exit_with_stdin)).await.context("agent failed")?;
    tracing::info!(?exit, "agent done");
    Ok(ExitCode::SUCCESS)
}
