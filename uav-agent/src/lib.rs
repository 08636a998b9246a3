//! The onboard stack of one UAV, run as its own process and talking to the swarm over Zenoh.
//!
//! - [`perception`]: scan grouping and least-squares circle fit: the obstacle set (seed 000 3.2).
//! - [`localization`]: where the neighbours are, relative to this UAV (`broadcast` mode today).
//! - [`k21`]: the Boids-style K21 controller of seed 000 chapter 4.
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

pub use node::{run, AgentError, AgentExit, AgentOptions};
