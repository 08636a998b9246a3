//! `swarm ros2` (and `swarm run --ros2`): a run as a ROS 2 graph, on DDS (what a stock ROS 2
//! install speaks) or on rmw_zenoh's keys over the hub's router, so ROS tools and nodes see the
//! UAVs, follow sim time, draw the world in RViz, fly external UAVs and drive the bodies of
//! agents that read their sensors from ROS topics.
//!
//! - `bridge`: the bridge itself: run keys in, ROS topics out, commands back
//!   ([`bridge::Bridge`]).
//! - `world`: the truth topics (`/tf_static`, `/world/markers`) from the hub's static world.
//!
//! Why a bridge and not the agents themselves: the run's own keys stay compact (postcard, one
//! key family per concern) and ROS's cost is paid only when someone asks for it. Formats and
//! transport: crate `swarm-ros2`. Topics, QoS and what was tested with which ROS 2 code:
//! docs/ros2.md.

mod bridge;
mod world;

pub use bridge::{Bridge, BridgeOptions};

use anyhow::Result;
use clap::Args;
use std::process::ExitCode;
use swarm_args::{RosArgs, UavIds, ZenohArgs};

/// `swarm ros2`.
#[derive(Args, Debug, Clone)]
pub struct Ros2Args {
    /// Run id of the running swarm.
    #[arg(long)]
    pub run: String,
    /// The ROS 2 graph: domain and middleware.
    #[command(flatten)]
    pub ros: RosArgs,
    /// Also publish the truth topics (`/tf_static`, `/world/markers`) on DDS, where anyone on
    /// the network may read them (rmw_zenoh's router gives them only to logins that may read
    /// truth).
    #[arg(long)]
    pub truth: bool,
    /// Drive the bodies of these UAVs (`3`, `1-4,7`), whose agents read their sensors from ROS
    /// topics (`swarm agent --sensors ros2`): their stamped commands become the hub's.
    #[arg(long, value_parser = swarm_args::parse_ids)]
    pub vehicles: Option<UavIds>,
    /// Where and how to connect (log in as `bridge`, or with `--vehicles 3` as `bridge-uavs3`,
    /// the one user that may command those UAVs' bodies).
    #[command(flatten)]
    pub zenoh: ZenohArgs,
}

/// Runs `swarm ros2` until the run's hub goes away or Ctrl-C.
pub async fn ros2(a: Ros2Args) -> Result<ExitCode> {
    anyhow::ensure!(!a.zenoh.connect.is_empty(), "swarm ros2 needs --connect <hub endpoint>");
    let opts = BridgeOptions {
        run: a.run.clone(),
        connect: a.zenoh.connect.clone(),
        cfg: a.zenoh.session_cfg()?,
        domain: a.ros.domain,
        dds: a.ros.dds,
        localhost_only: a.ros.localhost_only(),
        truth: a.truth,
        vehicles: a.vehicles.map(|v| v.0).unwrap_or_default(),
    };
    let bridge = Bridge::start(&opts).await?;
    tokio::select! {
        r = bridge.run() => r?,
        _ = tokio::signal::ctrl_c() => {}
    }
    Ok(ExitCode::SUCCESS)
}
