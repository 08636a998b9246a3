//! `swarm hub` and `swarm agent`: the two kinds of process a run is made of, each a thin shell
//! around its library (`physics_hub::run`, `uav_agent::run`). `swarm run` starts them as its
//! children; a person can start them by hand, on one machine or several.

use anyhow::{Context, Result};
use clap::Args;
use std::process::ExitCode;
use swarm_args::{parse_ids, RosArgs, UavIds, ZenohArgs};
use swarm_config::Scenario;
use swarm_types::UavId;
use uav_agent::Controllers;

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
    /// The users who may connect: a file of `user:password` lines (`swarm credentials` makes
    /// one); each user's role, read from its name, sets what it may touch (docs/security.md).
    #[arg(long, required_unless_present = "insecure")]
    pub users: Option<std::path::PathBuf>,
    /// Let anyone connect and touch any key (no authentication, no access control).
    #[arg(long, conflicts_with = "users")]
    pub insecure: bool,
}

/// `swarm agent`.
#[derive(Args, Debug, Clone)]
pub struct AgentArgs {
    /// Run id.
    #[arg(long)]
    pub run: String,
    /// UAV id (1-based).
    #[arg(long, required_unless_present = "ids", conflicts_with = "ids")]
    pub id: Option<UavId>,
    /// Run many agents in this one process (an agent host), e.g. `1-250` or `1-4,7`; each keeps
    /// its own keys, subscriptions, netem link and liveliness token.
    #[arg(long, value_parser = parse_ids)]
    pub ids: Option<UavIds>,
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
    /// Where the agent's sensors come from and its commands go: the hub's keys, or ROS 2 topics
    /// (`/uav{id}/scan`, `/uav{id}/odom`, `/uav{id}/goal` in, `/uav{id}/cmd_vel` out; docs/ros2.md),
    /// as on a vehicle. Shares still cross the run's Zenoh keys.
    #[arg(long, value_enum, default_value_t = SensorSource::Hub, requires = "id")]
    pub sensors: SensorSource,
    /// The ROS 2 graph of `--sensors ros2`.
    #[command(flatten)]
    pub ros: RosArgs,
    /// With `--sensors ros2`: ask for the scan and odometry reliably. Such a subscription
    /// matches only a reliable writer, as `swarm ros2`'s are in a lockstep run, where a frame
    /// lost on DDS would leave the hub waiting for its command until the tick timeout and the
    /// run differing from the one before (`swarm run --ros2-agents` sets it in lockstep). The
    /// default, best effort (ROS's sensor-data QoS), matches every writer, a vehicle's drivers too.
    #[arg(long, requires = "sensors")]
    pub reliable_sensors: bool,
    /// Worker threads of this process's runtime, where its agents step (default 2). `swarm run`
    /// gives each agent process its share of the machine's cores: one worker when it starts as
    /// many agent processes as there are cores, or more (docs/performance.md, "One worker per
    /// agent host").
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..))]
    pub workers: Option<u16>,
}

/// Where an agent's sensors come from.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorSource {
    /// The hub's sensor frames.
    Hub,
    /// ROS 2 topics.
    Ros2,
}

impl AgentArgs {
    /// The agent library's sensors of these arguments.
    pub fn sensors(&self) -> uav_agent::Sensors {
        match self.sensors {
            SensorSource::Hub => uav_agent::Sensors::Hub,
            SensorSource::Ros2 => uav_agent::Sensors::Ros {
                dds: self.ros.dds,
                localhost_only: self.ros.localhost_only(),
                domain: self.ros.domain,
                reliable: self.reliable_sensors,
            },
        }
    }
}

/// Resolves when Ctrl-C arrives or, with `watch_stdin`, when standard input closes.
pub(crate) async fn shutdown_signal(watch_stdin: bool) {
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
    let listen =
        if a.zenoh.listen.is_empty() { vec!["tcp/127.0.0.1:7447".to_string()] } else { a.zenoh.listen.clone() };
    let mut zenoh_cfg = match &a.users {
        Some(dictionary) => crate::auth::router_cfg(&a.run, dictionary, &sc.controller.external)?,
        None => {
            warn_insecure();
            Vec::new()
        }
    };
    zenoh_cfg.extend(a.zenoh.session_cfg()?);
    let opts = physics_hub::HubOptions { run: a.run, listen, connect: a.zenoh.connect, zenoh_cfg };
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
    tracing::info!(end = ?report.end, ticks = report.ticks, malformed_cmds = report.malformed, ignored_cmds = report.ignored, "hub done");
    Ok(ExitCode::SUCCESS)
}

/// Says, loudly, that this hub lets anyone in.
fn warn_insecure() {
    for line in [
        "INSECURE: --insecure: no authentication and no access control on this hub.",
        "INSECURE: anyone who reaches its endpoint can read ground truth (truth/**) and command any UAV.",
        "INSECURE: start it with --users FILE (made by `swarm credentials`) for anything but a closed test.",
    ] {
        tracing::warn!("{line}");
    }
}

/// Runs `swarm agent`: one agent on its own session with `--id`, an agent host with `--ids`.
pub async fn agent(a: AgentArgs, controllers: Controllers) -> Result<ExitCode> {
    let scenario = match &a.scenario {
        Some(s) => Some(Scenario::from_arg(s)?.0),
        None => None,
    };
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "an agent needs --connect <hub endpoint>");
    let Some(id) = a.id else {
        return agent_host(a, scenario, controllers).await;
    };
    let opts = uav_agent::AgentOptions {
        sensors: a.sensors(),
        run: a.run,
        id,
        zenoh_cfg: a.zenoh.session_cfg()?,
        connect: a.zenoh.connect,
        scenario,
        hub_grace_s: a.hub_grace_s,
        controllers,
    };
    let exit = uav_agent::run(opts, shutdown_signal(a.exit_with_stdin)).await.context("agent failed")?;
    tracing::info!(?exit, "agent done");
    Ok(ExitCode::SUCCESS)
}

/// Runs `swarm agent --ids`: every agent in this process; each failed one is reported by id,
/// and the host fails if any did.
async fn agent_host(a: AgentArgs, scenario: Option<Scenario>, controllers: Controllers) -> Result<ExitCode> {
    let ids = a.ids.map(|i| i.0).unwrap_or_default();
    let n = ids.len();
    let opts = uav_agent::HostOptions {
        run: a.run,
        ids,
        zenoh_cfg: a.zenoh.session_cfg()?,
        connect: a.zenoh.connect,
        scenario,
        hub_grace_s: a.hub_grace_s,
        controllers,
    };
    let ends = uav_agent::run_host(opts, shutdown_signal(a.exit_with_stdin)).await.context("agent host failed")?;
    let mut failed = Vec::new();
    for (id, end) in ends {
        match end {
            Ok(exit) => tracing::info!(uav_id = %id, ?exit, "agent done"),
            Err(e) => failed.push(format!("UAV {id}: {e}")),
        }
    }
    anyhow::ensure!(
        failed.is_empty(),
        "{} of the {n} agents of this host failed:\n  {}",
        failed.len(),
        failed.join("\n  ")
    );
    Ok(ExitCode::SUCCESS)
}
