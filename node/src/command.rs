//! The `swarm-node` command line: only the processes a run is made of (`hub`, `agent`, `router`)
//! and `credentials`, with the same arguments as `swarm hub | agent | router | credentials`. It
//! links no recorder, live view or figures: the binary for an agent host or a UAV's companion
//! computer (docs/hosts-and-containers.md). It knows the built-in controllers
//! only; a program with controllers of its own is its own agent binary (docs/own-controller.md).

use crate::{auth, pieces, process, router};
use clap::{Parser, Subcommand};
use std::process::ExitCode;
use uav_agent::Controllers;

/// The hub, an agent or agent host, or a router of a Zenoh-networked UAV swarm.
#[derive(Parser, Debug)]
#[command(name = "swarm-node", version, about)]
struct Cli {
    #[command(subcommand)]
    cmd: NodeCmd,
}

/// The commands of this crate, the same in `swarm-node` and in `swarm` (which flattens them into
/// its own command line).
#[derive(Subcommand, Debug)]
pub enum NodeCmd {
    /// Start the physics hub (a Zenoh router) by hand.
    Hub(pieces::HubArgs),
    /// Start one UAV agent (`--id`) or an agent host (`--ids`) by hand (a Zenoh client of the hub).
    Agent(pieces::AgentArgs),
    /// Start a bare Zenoh router that agents connect to and that connects to the hub.
    Router(router::RouterArgs),
    /// Make fresh users and passwords for a hub and pieces started by hand (docs/security.md).
    Credentials(auth::CredentialsArgs),
}

/// Runs one of this crate's commands; agents know `controllers`.
pub async fn dispatch(cmd: NodeCmd, controllers: Controllers) -> anyhow::Result<ExitCode> {
    match cmd {
        NodeCmd::Hub(a) => pieces::hub(a).await,
        NodeCmd::Agent(a) => pieces::agent(a, controllers).await,
        NodeCmd::Router(a) => router::router(a).await,
        NodeCmd::Credentials(a) => auth::credentials(a),
    }
}

/// Entry point of the `swarm-node` binary (and of the end-to-end tests' copy of it).
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    zenoh_threads(&cli.cmd);
    process::run_on(workers(&cli.cmd), dispatch(cli.cmd, Controllers::builtin()))
}

/// The runtime's worker threads for this process: an agent's `--workers`, else the default.
pub fn workers(cmd: &NodeCmd) -> usize {
    match cmd {
        NodeCmd::Agent(pieces::AgentArgs { workers: Some(n), .. }) => usize::from(*n),
        _ => process::DEFAULT_WORKERS,
    }
}

/// Zenoh's threads for this process, chosen before its first session opens: a process that runs
/// agents (one, or a host of many) hands Zenoh's reception, transmission, accept and network work
/// to its application runtime, one thread, unless `ZENOH_RUNTIME` says otherwise. Each handoff
/// between Zenoh's threads (the socket's readiness on one, the reading on another, the sending
/// on a third) is a wake-up and a context switch: forest-5 in lockstep, one process per agent,
/// made half as many context switches and ran faster, and open-1000's two hosts of 500 spent
/// 10 % less CPU (see docs/performance.md). An agent's own work and its puts run on the
/// process's runtime, never on Zenoh's thread (a put may block while the send queue is full,
/// waiting for that thread, which takes no lock of ours). The hub and routers keep
/// Zenoh's default threads: they route for the whole swarm, and the hub's blocking puts must not
/// wait on the thread that would send them.
pub fn zenoh_threads(cmd: &NodeCmd) {
    const ONE_THREAD: &str = "(rx: (handover: app), tx: (handover: app), acc: (handover: app), net: (handover: app))";
    if matches!(cmd, NodeCmd::Agent(_)) && std::env::var_os("ZENOH_RUNTIME").is_none() {
        // Before any thread of ours or Zenoh's exists (the runtime is built after this).
        std::env::set_var("ZENOH_RUNTIME", ONE_THREAD);
    }
}
