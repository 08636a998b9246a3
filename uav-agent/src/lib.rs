//! The onboard stack of one UAV, run as its own process and talking to the swarm over Zenoh.
//!
//! - [`perception`]: scan grouping, least-squares circle fit (the obstacle set, seed 000 3.2) and
//!   wall segments.
//! - [`localization`]: where the neighbours are, relative to this UAV (`broadcast` mode);
//!   [`icp`] and [`neighbours`]: the same by ICP on shared obstacle sets (`icp` mode).
//! - [`k21`]: the Boids-style K21 controller of seed 000 chapter 4.
//! - [`p17`]: the P17 controller of seed 001 chapter 3 (β-agents for cylinders and walls).
//! - [`a21`]: the A21 controller of seed 003 section III (proximal control, φ-limited navigation).
//! - [`grid`], [`costmap`]: an occupancy grid from the agent's scans with A* on it (A21), and the
//!   seed 004 costmap with inflation and a social layer.
//! - [`m23`]: the formation layer of seed 004 (topology goals, the leader's wait, the tracker).
//! - [`pilot`]: runs the scenario's controller step by step, with what it keeps between steps.
//! - [`vec2`]: the vector helpers the controllers share.
//! - [`agent`]: one control step wiring the three together, with no IO.
//! - [`node`]: the Zenoh side: sensor and radio subscriptions, neighbour subscriptions that follow
//!   the radio set, the netem link seam, liveliness.
//!
//! Entry point: [`run`]. Architecture invariant: an agent sees the world only through its own
//! sensor keys and its neighbours' shares; it never reads `truth/**`.

pub mod a21;
pub mod agent;
pub mod costmap;
pub mod grid;
pub mod icp;
pub mod k21;
pub mod m23;
pub mod localization;
pub mod neighbours;
pub mod node;
pub mod p17;
pub mod perception;
pub mod pilot;
pub mod vec2;

pub use node::{run, AgentError, AgentExit, AgentOptions};
