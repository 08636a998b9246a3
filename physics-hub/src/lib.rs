//! The physics hub: the simulated world of a swarm run, and the Zenoh router every agent
//! connects to.
//!
//! - [`world`]: trees and walls with an acceleration structure (parry2d BVH) for ray casts and
//!   clearance queries.
//! - [`forest`]: seeded generation of forests and start positions from the scenario.
//! - [`body`]: a UAV body tracking velocity or acceleration commands within limits.
//! - [`lidar`]: the 2D LIDAR, ray casting against trees, walls and other UAVs.
//! - [`radio`]: who can hear whom (range with hysteresis).
//! - [`uvdar`]: seed 003's onboard relative sensing (range and bearing of the neighbours in view).
//! - [`sim`]: the pure simulation state and step: sensors out, commands in, ground truth out.
//! - [`node`]: the Zenoh side: router session, lockstep/realtime loop, liveliness.
//!
//! Entry point: [`run`]. Architecture invariant: the hub is the only holder of ground truth; it
//! hands each agent only that agent's own sensor data, and publishes truth on `truth/**` for the
//! recorder alone.

pub mod body;
pub mod forest;
pub mod lidar;
pub mod node;
pub mod radio;
pub mod sim;
pub mod uvdar;
pub mod world;

pub use node::{run, HubError, HubOptions, HubReport};
