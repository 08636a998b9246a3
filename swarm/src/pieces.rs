//! `swarm hub` and `swarm agent`: the two kinds of process a run is made of, each a thin shell
//! around its library (`physics_hub::run`, `uav_agent::run`). `swarm run` starts them as its
//! children; a person can start them by hand, on one machine or several.

use crate::args::ZenohArgs;
use anyhow::{Context, Result};
use clap::Args;
use std::process::ExitCode;
use swarm_config::Scenario;

/// The line the hub prints on stdout once it listens; the launcher reads it.
pub const LISTENING_PREFIX: &str = "swarm-hub listening:";

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

/// Resolves when Ctrl-C arrives or, with `watch_stdin`, when standard input closes.
async fn shutdown_signal(watch_stdin: bool) {
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

/// Runs `swarm hub`.
pub async fn hub(a: HubArgs) -> Result<ExitCode> {
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

/// Runs `swarm agent`.
pub async fn agent(a: AgentArgs) -> Result<ExitCode> {
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
