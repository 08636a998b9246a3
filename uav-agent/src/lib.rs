//! The onboard stack of one UAV, run as its own process or with others in an agent host, and
//! talking to the swarm over Zenoh.
//!
//! A tour, in the order a tick flows through it:
//!
//! - `sensing`: the [`SensorFrame`] of one tick, assembled from separate sensor messages by a
//!   pure [`FrameCollector`].
//! - `perception`: the scan becomes obstacle circles (least-squares circle fit, seed 000 3.2),
//!   wall segments and points, in the body frame.
//! - `localization`: where the neighbours are relative to this UAV; one localizer per mode
//!   (`broadcast`, `icp` with its neighbour database, `uvdar`), chosen once, each with the
//!   [`Share`] it sends and what it does with those it receives. The ICP itself is public as
//!   [`icp`] for its benchmark.
//! - `control`: the pilot and the controllers K21, P17, A21 and M23, from a view of the
//!   neighbours and obstacles to a command.
//! - `planning`: the occupancy grid with A* (A21) and the seed 004 costmap (M23) that control
//!   plans on.
//! - `geometry`: what every stage shares: the odometry pose, the one angle-wrap convention,
//!   small vector helpers.
//! - `agent`: [`Agent::step`], the pipeline of one tick with no IO.
//! - `node`: the Zenoh side: sensor and radio subscriptions, listening to the neighbours' shares
//!   as the radio set changes, the netem link seam, liveliness. Entry point: [`run`].
//! - `host`: many agents in one process on one shared Zenoh session, each with its own node
//!   ([`run_host`]).
//! - `shared`: what the agents of one session share: every UAV's share key declared once, and
//!   one subscription to them all that hands each share to the agents listening to its sender.
//!
//! Dependencies run one way: agent → control → planning → geometry, agent → localization →
//! geometry; nothing below points back up to the agent or the node. Architecture invariant: an
//! agent sees the world only through its own sensor keys and its neighbours' shares; it never
//! reads `truth/**`.

// The algorithm modules keep the whole of their seed's method, tested beside it, though one
// agent step uses only part of it: outside tests that part is dead code, on purpose.
mod agent;
mod control;
mod geometry;
mod host;
mod localization;
mod node;
mod shared;
#[cfg_attr(not(test), allow(dead_code))]
mod perception;
#[cfg_attr(not(test), allow(dead_code))]
mod planning;
mod sensing;

pub use agent::{Agent, LinkReport, StepOutput, StepReport};
pub use localization::icp;
pub use localization::Share;
pub use host::{run_host, HostOptions};
pub use node::{run, AgentError, AgentExit, AgentOptions};
pub use sensing::{FrameCollector, Needs, SensorFrame};
