//! The `swarm-node` command line: only the processes a run is made of (`hub`, `agent`, `router`)
//! and `credentials`, with the same arguments as `swarm hub | agent | router | credentials`. It
//! links no recorder, live view or figures: the binary for an agent host, a UAV's companion
//! computer or a container (docs/hosts-and-containers.md). It knows the built-in controllers
//! only; a program with controllers of its own is its own agent binary (docs/own-controller.md).

use clap::{Parser, Subcommand};
use std::process::ExitCode;
use crate::{auth, pieces, process, router};
use uav_agent::Controllers;

/// The hub, an agent or agent host, or a router of a Zenoh-networked UAV swarm.
#[derive(Parser, Debug)]
#[command(name = "swarm-node", version, about)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Start the physics hub (a Zenoh router).
    Hub(pieces::HubArgs),
    /// Start one UAV agent (`--id`) or an agent host (`--ids`) (a Zenoh client of the hub).
    Agent(pieces::AgentArgs),
    /// Start a bare Zenoh router that agents connect to and that connects to the hub.
    Router(router::RouterArgs),
    /// Make fresh users and passwords for a hub and pieces started by hand.
    Credentials(auth::CredentialsArgs),
}

/// Entry point of the `swarm-node` binary (and of the end-to-end tests' copy of it).
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    process::run(async move {
        match cli.cmd {
            Cmd::Hub(a) => pieces::hub(a).await,
            Cmd::Agent(a) => pieces::agent(a, Controllers::builtin()).await,
            Cmd::Router(a) => router::router(a).await,
            Cmd::Credentials(a) => auth::credentials(a),
        }
    })
}
