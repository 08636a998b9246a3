//! ROS 2 on both of its middlewares: the messages a run maps onto, encoded once, and one
//! interface ([`Graph`]) to publish and subscribe them as ROS 2 nodes either over DDS (what a
//! stock ROS 2 install speaks) or over rmw_zenoh's keys on the run's own Zenoh router.
//!
//! - [`cdr`]: little-endian CDR, as ROS 2 serializes.
//! - [`types`]: the message types with their DDS names and RIHS01 hashes.
//! - [`msgs`]: the messages (LaserScan, Odometry, Twist and its stamped forms, Clock, TF,
//!   PoseArray, MarkerArray, ParticipantEntitiesInfo), each written once.
//! - [`rmw_zenoh`]: rmw_zenoh's data keys, sample attachment and liveliness tokens.
//! - [`dds`]: a RustDDS participant carrying our payloads, and the `ros_discovery_info` that
//!   makes its nodes visible.
//! - [`graph`]: the interface both share: nodes, publishers, subscriptions, QoS.
//!
//! Who uses it: the bridge (`swarm ros2`, in crate `swarm`) that shows a run to ROS 2, and an
//! agent whose sensors and commands are ROS 2 topics (`uav-agent`'s `net::ros`).
//! Architecture invariant: formats and transport only; no behaviour of the swarm, no run keys.

pub mod cdr;
pub mod dds;
pub mod graph;
pub mod msgs;
pub mod rmw_zenoh;
pub mod types;

pub use graph::{Graph, Middleware, NodeRef, Publisher, SubscriptionGuard};

/// The QoS of a topic, the part ROS 2's conventions set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliable (or best effort).
    pub reliable: bool,
    /// Transient local: a late subscriber gets the last `depth` samples (or volatile).
    pub transient_local: bool,
    /// History depth (keep last).
    pub depth: u32,
}

impl Qos {
    /// A publisher's and subscription's default: reliable, volatile, keep last 10.
    pub const DEFAULT: Qos = Qos { reliable: true, transient_local: false, depth: 10 };
    /// Sensor data (`rclpy.qos.qos_profile_sensor_data`): best effort, volatile, keep last 5.
    pub const SENSOR: Qos = Qos { reliable: false, transient_local: false, depth: 5 };
    /// Latched (a map, `/tf_static`): reliable, transient local, keep last 1.
    pub const LATCHED: Qos = Qos { reliable: true, transient_local: true, depth: 1 };
    /// `/clock`: reliable, keep last 1 (a reliable writer serves best-effort readers too).
    pub const CLOCK: Qos = Qos { reliable: true, transient_local: false, depth: 1 };
    /// `/tf`: reliable, keep last 100 (tf2's listener's).
    pub const TF: Qos = Qos { reliable: true, transient_local: false, depth: 100 };

    /// A simulated UAV's scan and odometry: [`Qos::SENSOR`], but reliable in a lockstep run.
    /// There the hub waits for the command that answers every frame, so a frame lost on DDS
    /// (best effort drops a sample whenever a loaded machine's socket buffer overflows) left the
    /// hub to time out and the run to differ from the one before. A reliable writer still serves
    /// a best-effort reader (`qos_profile_sensor_data`), and a vehicle's own drivers (realtime)
    /// stay best effort, which a best-effort reader matches.
    pub const fn sensor(lockstep: bool) -> Qos {
        Qos { reliable: lockstep, ..Qos::SENSOR }
    }
}

/// Errors of the ROS 2 side.
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    /// DDS (RustDDS) refused something.
    #[error("DDS: {0}")]
    Dds(String),
    /// Zenoh refused something.
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// A payload was not the message it should be.
    #[error(transparent)]
    Cdr(#[from] cdr::CdrError),
}

impl Ros2Error {
    /// Wraps a Zenoh error.
    pub fn zenoh(e: impl std::fmt::Display) -> Ros2Error {
        Ros2Error::Zenoh(e.to_string())
    }
}
