//! The physics hub: the simulated world of a swarm run, and the Zenoh router every agent
//! connects to.
//!
//! - [`world`]: trees and walls, and the two questions everything asks of them: clearance from a
//!   point and a ray's first hit (exact in `f64`, pruned by a parry2d BVH).
//! - [`forest`]: seeded generation of forests and start positions from the scenario.
//! - [`body`]: a UAV body tracking velocity or acceleration commands within limits.
//! - [`lidar`]: the 2D LIDAR scan against trees, walls and other UAVs, by rasterising the nearby
//!   obstacles onto the beams instead of one ray cast per beam.
//! - [`grid`]: a uniform grid over the UAV positions of a tick, so radio links, contacts, the
//!   UAVs a scan can hit and nearest distances cost about n · neighbours instead of n².
//! - [`radio`]: who can hear whom (range with hysteresis, optional distance-dependent loss).
//! - [`uvdar`]: onboard relative sensing for the `uvdar` localization mode: which neighbours a
//!   UAV's cameras see, with noisy range and bearing.
//! - [`sim`]: the pure simulation state and step: commands in, collisions, freezes and the end
//!   condition, ground truth out; its `sensors` submodule puts each UAV's sensors (radio,
//!   odometry, GNSS, UVDAR, scan) out, a large swarm's computed on worker threads in chunks.
//! - [`batch`]: which of a tick's sensor frames go to an agent host in one message, and when
//!   that message is complete.
//! - [`lateness`]: which commands arrived after their tick had closed, and how late (the
//!   realtime health of a run), carried to the recorder on `truth/step`.
//! - [`node`]: the Zenoh side: router session, lockstep/realtime loop, agents' liveliness, the
//!   scenario and world queryables, the netem timeline (the scenario's plus `swarm netem`'s).
//!
//! Entry point: [`run`]. Public surface: [`run`] and its options, report and error; [`world`] and
//! [`lidar`] for the LIDAR benchmark, [`sim`] for the hub tick benchmark; [`start_positions`], for
//! tools that place agents by where their UAVs start (`swarm mesh`), and [`start_in_obstacle`],
//! which `swarm check` and `swarm run` ask before starting anything; every other module is
//! private.
//!
//! Architecture invariant: the hub is the only holder of ground truth; it
//! hands each agent only that agent's own sensor data, and publishes truth on `truth/**` for the
//! recorder alone.

mod batch;
mod body;
mod forest;
mod grid;
mod lateness;
pub mod lidar;
mod node;
mod radio;
pub mod sim;
mod uvdar;
pub mod world;

pub use forest::{scenario_trees, start_in_obstacle, start_positions};
pub use node::{run, HubError, HubOptions, HubReport};
