//! The onboard stack of one UAV, run as its own process or with others in an agent host, and
//! talking to the swarm over Zenoh.
//!
//! A tour, in the order a tick flows through it:
//!
//! - `sensing`: the [`SensorFrame`] of one tick, checked and split from the hub's one message
//!   per UAV and tick.
//! - `perception`: the scan becomes obstacle circles (least-squares circle fit, seed 000 3.2),
//!   wall segments and points, in the body frame.
//! - `localization`: where the neighbours are relative to this UAV; one localizer per mode
//!   (`broadcast`, `icp` with its neighbour database, `uvdar`), chosen once, each with the
//!   [`Share`] it sends and what it does with those it receives. The ICP itself is public as
//!   [`icp`] for its benchmark.
//! - `control`: the [`Controller`] trait and the [`Controllers`] registry, and the built-in
//!   controllers K21, P17, A21 and M23, from a view of the neighbours and obstacles to a command.
//! - `planning`: the occupancy grid with A* (A21) and the seed 004 costmap (M23) that control
//!   plans on.
//! - `world_model`: what the stages hand one another about the surroundings, in the body frame:
//!   obstacle [`Circle`]s and wall [`Segment`]s from perception, neighbour [`Estimate`]s from
//!   localization, which control steers by.
//! - `geometry`: what every stage shares: the odometry pose, the one angle-wrap convention,
//!   small vector helpers.
//! - `agent`: [`Agent::step`], the pipeline of one tick with no IO.
//! - `admission`: which received shares count and when each is delivered: the neighbour windows,
//!   early shares, the netem link seam and its inbox, with no IO.
//! - `onboard`: [`Onboard`], an agent and its admission stepped by hand, with no IO: what the
//!   node decides per hub message, for a whole swarm in one process (`swarm floor`).
//! - `outbox`: which steps an agent host's one command message and one state message of a
//!   lockstep tick wait for, and when they are complete, with no IO.
//! - `net`: everything that touches Zenoh, and only it: one agent's node (sensor and radio
//!   subscriptions, listening to the shares of its radio set, liveliness; entry point [`run`]),
//!   the agent host ([`run_host`]), and the session's share feed (one subscription per sender
//!   its agents listen to).
//!
//! Dependencies run one way: net → outbox, net → admission → agent → control → planning → geometry, agent →
//! localization → sensing, agent → perception, onboard → admission; the stages reach one another's types only below
//! themselves, in `world_model` and `geometry`, which import nothing of the crate, never sideways;
//! nothing below points back up to the agent or the node. Architecture invariant: an
//! agent sees the world only through its own sensor frames and its neighbours' shares; it never
//! reads `truth/**`.

// No module-wide `allow(dead_code)`: a seed's item that only the tests use is `#[cfg(test)]` at
// the item, so the compiler reports whatever else falls out of use.
mod admission;
mod agent;
mod control;
mod geometry;
mod localization;
mod net;
mod onboard;
mod outbox;
mod perception;
mod planning;
mod sensing;
mod world_model;

pub use agent::{Agent, LinkReport, Perceived, StepOutput, StepReport};
pub use control::{Command, Controller, Controllers, MakeController, UnknownController, View};
pub use localization::icp;
pub use localization::{ObstacleSet, Share};
pub use net::{run, run_host, AgentError, AgentExit, AgentOptions, HostOptions, Sensors};
pub use onboard::{Onboard, OnboardError, Outgoing};
pub use sensing::{MalformedFrame, Needs, SensorFrame};
pub use world_model::{Body, Circle, Estimate, Segment};
