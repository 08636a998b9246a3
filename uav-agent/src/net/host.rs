//! An agent host: many agents in one process, so a large swarm does not pay one process (and
//! one Zenoh session, about 15 MB resident) per UAV.
//!
//! Each agent keeps everything it has alone: its [`node`] state, sensor subscriptions, netem
//! link, writers and `alive/uav/{id}` token, so the hub, netem, the recorder and tools see
//! exactly the keys of one process per UAV, and the host takes their sensor frames in one
//! message a tick as well ([`super::frames`]). The agents of a host share one Zenoh session and its
//! share feed ([`super::feed`]): one subscription per sender any of them listens to, so the host
//! receives the shares of the union of its agents' radio sets, each once. A share published by
//! one agent reaches another of the same host through Zenoh's local routing (never through
//! memory of this crate), after the neighbour window checks as for any share, so lockstep
//! results do not depend on how agents are spread over processes. Each agent is its own task;
//! one that fails is reported with its id and the others fly on.

use super::feed::SessionShared;
use super::node::{self, AgentExit, Flight};
use super::ros::Sensors;
use super::AgentError;
use crate::control::Controllers;
use std::future::Future;
use std::sync::Arc;
use swarm_config::Scenario;
use swarm_types::UavId;
use swarm_wire::session::{self, Role};
use swarm_wire::Keys;
use tokio::sync::watch;
use tracing::{error, info_span, Instrument};

/// Which UAVs, which run, which hub.
#[derive(Debug, Clone, Default)]
pub struct HostOptions {
    /// Run id.
    pub run: String,
    /// UAV ids, 1-based.
    pub ids: Vec<UavId>,
    /// Hub endpoints, e.g. `tcp/10.0.0.5:7447`.
    pub connect: Vec<String>,
    /// `KEY:JSON5` Zenoh config overrides.
    pub zenoh_cfg: Vec<String>,
    /// Use this scenario instead of fetching it from the hub.
    pub scenario: Option<Scenario>,
    /// See [`AgentOptions::hub_grace_s`](crate::AgentOptions::hub_grace_s).
    pub hub_grace_s: f64,
    /// See [`AgentOptions::controllers`](crate::AgentOptions::controllers).
    pub controllers: Controllers,
}

/// Runs the agents `opts.ids` in this process on one Zenoh session until each has ended (hub
/// gone, error) or `shutdown` resolves; returns how each ended, by id, in the order given.
/// Only a failure shared by all (no session, no scenario) is an `Err`.
pub async fn run_host(
    opts: HostOptions,
    shutdown: impl Future<Output = ()>,
) -> Result<Vec<(UavId, Result<AgentExit, AgentError>)>, AgentError> {
    let keys = Keys::new(&opts.run)?;
    let s = session::open(Role::Client, &[], &opts.connect, &opts.zenoh_cfg).await?;
    let result = async {
        let sc = match opts.scenario.clone() {
            Some(sc) => sc,
            None => node::fetch_scenario(&s, &keys, &opts.run).await?,
        };
        // Made once, before any agent runs (see `feed`).
        let shared = SessionShared::open(&s, &keys, &sc, &opts.ids, true).await?;
        Ok(fly_all(&s, &keys, shared, &opts, sc, shutdown).await)
    }
    .await;
    let _ = s.close().await;
    result
}

/// Starts one task per agent and waits for all of them; `shutdown` reaches every agent.
async fn fly_all(
    s: &zenoh::Session,
    keys: &Keys,
    shared: Arc<SessionShared>,
    opts: &HostOptions,
    sc: Scenario,
    shutdown: impl Future<Output = ()>,
) -> Vec<(UavId, Result<AgentExit, AgentError>)> {
    let (stop_tx, stop_rx) = watch::channel(false);
    let mut tasks = Vec::with_capacity(opts.ids.len());
    for &id in &opts.ids {
        let mut stop = stop_rx.clone();
        let stopped = async move {
            let _ = stop.wait_for(|v| *v).await;
        };
        let span = info_span!("agent", uav_id = %id, run = %opts.run);
        let flight = Flight {
            sc: sc.clone(),
            hub_grace_s: opts.hub_grace_s,
            controllers: opts.controllers.clone(),
            sensors: Sensors::Hub,
        };
        let fly = node::fly(s.clone(), keys.clone(), shared.clone(), id, flight, stopped);
        let reported = async move {
            let r = fly.await;
            if let Err(e) = &r {
                error!("agent failed: {e}");
            }
            r
        };
        tasks.push((id, tokio::spawn(reported.instrument(span))));
    }
    let all = async {
        let mut out = Vec::with_capacity(tasks.len());
        for (id, t) in tasks {
            let r = t.await.unwrap_or_else(|e| Err(AgentError::Panicked(e.to_string())));
            out.push((id, r));
        }
        out
    };
    tokio::pin!(all);
    tokio::select! {
        out = &mut all => return out,
        _ = shutdown => {}
    }
    let _ = stop_tx.send(true);
    all.await
}
