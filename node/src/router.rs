//! `swarm router`: a bare Zenoh router, for spreading a swarm over several machines. Agents of one
//! machine (or site) connect to it as clients, and it connects to the hub's router, so their
//! traffic crosses one router-to-router link instead of one link per agent (what `zenohd` would
//! do, without installing it). It routes and holds nothing of the run itself: the hub stays the
//! only holder of ground truth, and the only place where access control is enforced.

use anyhow::{Context, Result};
use clap::Args;
use std::process::ExitCode;
use swarm_wire::session::{self, Role};

/// What `swarm router` prints on standard output once it listens: this prefix, then its locators.
pub const ROUTER_LISTENING_PREFIX: &str = "swarm-router listening:";

/// `swarm router`.
#[derive(Args, Debug, Clone)]
pub struct RouterArgs {
    /// Endpoints: `--listen` where agents connect to it, `--connect` the hub (or another router).
    #[command(flatten)]
    pub zenoh: swarm_args::ZenohArgs,
    /// The users who may connect to this router: a file of `user:password` lines. Needed when
    /// the router itself logs in to a secured hub (`--user`): Zenoh then asks every session it
    /// accepts for a login too; its agents log in as the host's user (`uavs1-250`), which the
    /// hub's rules already bound.
    #[arg(long)]
    pub users: Option<std::path::PathBuf>,
    /// Exit when standard input closes.
    #[arg(long, hide = true)]
    pub exit_with_stdin: bool,
}

/// Runs `swarm router` until Ctrl-C (or, with `--exit-with-stdin`, until standard input closes).
pub async fn router(a: RouterArgs) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.listen.is_empty(), "router needs --listen <endpoint> for its clients");
    anyhow::ensure!(
        a.zenoh.user.is_none() || a.users.is_some(),
        "a router that logs in to the hub (--user) must also check its own clients: give --users FILE, a dictionary of the users \
         its agents log in as (the host's own `user:password` line will do)"
    );
    let mut cfg = a.zenoh.session_cfg()?;
    if let Some(users) = &a.users {
        let names = crate::auth::users_of(users).with_context(|| format!("--users {}", users.display()))?;
        anyhow::ensure!(!names.is_empty(), "--users {}: no `user:password` line", users.display());
        cfg.push(format!("transport/auth/usrpwd/dictionary_file:{}", serde_json::to_string(&users.to_string_lossy())?));
    }
    let s = session::open(Role::Router, &a.zenoh.listen, &a.zenoh.connect, &cfg).await.context("router failed")?;
    println!("{ROUTER_LISTENING_PREFIX} {}", session::locators(&s).await.join(" "));
    tracing::info!(connect = ?a.zenoh.connect, "router up");
    crate::pieces::shutdown_signal(a.exit_with_stdin).await;
    let _ = s.close().await;
    Ok(ExitCode::SUCCESS)
}
