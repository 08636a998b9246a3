//! The agent on the network: everything of this crate that touches Zenoh, and nothing else.
//! The stages it feeds ([`crate::agent`], [`crate::admission`], [`crate::sensing`]) are pure; a
//! tidy test keeps `zenoh` out of every module outside this folder.
//!
//! - `node`: one agent's node: its sensor-frame subscription (each frame checked by
//!   [`crate::sensing`] before the step), listening to the shares of its radio set, liveliness, the hub watch, its writers. Entry
//!   point: [`run`].
//! - `host`: many agents in one process on one shared Zenoh session, each with its own node
//!   ([`run_host`]).
//! - `external`: the link of an agent whose controller runs outside our processes: the tick's
//!   view out as JSON, the command back, bounded by the tick's wait.
//! - `ros`: the sensors and commands of an agent on ROS 2 topics (DDS or rmw_zenoh) instead of
//!   the hub's keys ([`Sensors`]), the way the same stack runs on a vehicle.
//! - `frames`: an agent host's one message a tick each way: the sensor frames, handed to each
//!   agent's channel, and in lockstep its agents' commands and states, put when
//!   [`crate::outbox`] says a tick is complete.
//! - `feed`: what the agents of one session share: one subscription per sender any of them
//!   listens to (the union of their radio sets), each share decoded once and posted to the
//!   listeners' mailboxes, and the session's traffic counts.
//!
//! Arrows: `host` → `node`, and both → `feed`; `node` → `external`, `ros` and `frames`, `feed` →
//! `frames`; `feed`, `frames`, `external` and `ros` know neither, `node` not `host`.

mod external;
mod feed;
mod frames;
mod host;
mod node;
mod ros;

pub use host::{run_host, HostOptions};
pub use node::{run, AgentExit, AgentOptions};
pub use ros::Sensors;

use swarm_config::ScenarioError;
use swarm_types::UavId;
use swarm_wire::WireError;

/// Errors of an agent.
#[derive(Debug, thiserror::Error)]
pub enum AgentError {
    /// Zenoh or encoding trouble.
    #[error(transparent)]
    Wire(#[from] WireError),
    /// The scenario the hub served (or the one given) is invalid.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// No hub answered in time.
    #[error("no hub for run `{0}` answered within {1} s")]
    NoHub(String, u64),
    /// The UAV id is not in the scenario.
    #[error("UAV id {0} is not in this scenario (ids 1..={1})")]
    BadId(UavId, u32),
    /// The hub's ticks went backwards: another hub run took over the keys.
    #[error("tick went back from {0} to {1}: the hub restarted; start the agent again for the new run")]
    TickWentBack(u64, u64),
    /// The scenario names a controller this program does not know.
    #[error(transparent)]
    UnknownController(#[from] crate::control::UnknownController),
    /// The UAV is flown by an external controller, which did not come.
    #[error("UAV {0} waits for its external controller (alive/ext/{0}), which did not come within {1} s")]
    NoExternalController(UavId, u64),
    /// ROS 2 (DDS or rmw_zenoh) refused something.
    #[error("ROS 2: {0}")]
    Ros2(String),
    /// An agent on ROS topics gets a scan and odometry only.
    #[error("UAV {0}: an agent on ROS 2 topics gets its scan and odometry only, so its localization must be `icp`")]
    RosNeedsIcp(UavId),
    /// An agent's task of an agent host panicked.
    #[error("the agent's task panicked: {0}")]
    Panicked(String),
}
