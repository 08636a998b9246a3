//! The ROS 2 messages a run maps onto, in their Jazzy field order, CDR encoded ([`crate::cdr`]),
//! one encoder (and, where something of ours reads the message, one decoder) for both
//! middlewares:
//!
//! - `sensor`: a UAV's scan as `sensor_msgs/msg/LaserScan` and its odometry as
//!   `nav_msgs/msg/Odometry`, both ways (the bridge writes them; an agent on ROS topics reads
//!   them).
//! - `command`: `geometry_msgs` Twist, TwistStamped and AccelStamped (a command, both ways) and
//!   PoseStamped (a goal).
//! - `frames`: `rosgraph_msgs/msg/Clock`, `tf2_msgs/msg/TFMessage`, `geometry_msgs/msg/PoseArray`.
//! - `markers`: `visualization_msgs/msg/MarkerArray` (the world for RViz).
//! - `graph`: `rmw_dds_common/msg/ParticipantEntitiesInfo` (which nodes a DDS participant holds).
//!
//! The shared pieces live here: `builtin_interfaces/msg/Time` from sim seconds and the
//! `std_msgs/msg/Header` around it, and planar poses as ROS's 3D ones (a yaw is a quaternion
//! about z).

pub mod command;
pub mod frames;
pub mod graph;
pub mod markers;
pub mod sensor;

use crate::cdr::{CdrError, Reader, Writer};

/// `builtin_interfaces/msg/Time` from seconds (sim time): whole seconds and nanoseconds.
pub fn time(w: &mut Writer, t_s: f64) {
    let t = t_s.max(0.0);
    let sec = t.floor();
    let nanosec = ((t - sec) * 1e9).round().min(999_999_999.0) as u32;
    w.i32(sec as i32).u32(nanosec);
}

/// Reads a `builtin_interfaces/msg/Time` as seconds.
pub fn read_time(r: &mut Reader) -> Result<f64, CdrError> {
    let sec = r.i32()?;
    let nanosec = r.u32()?;
    Ok(f64::from(sec) + f64::from(nanosec) * 1e-9)
}

/// A `std_msgs/msg/Header`: its stamp [s] and frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Header {
    /// The stamp [s] (sim time on our topics).
    pub stamp_s: f64,
    /// The frame id, e.g. `uav3/base_link`.
    pub frame_id: String,
}

impl Header {
    /// A header of `frame_id` stamped `stamp_s`.
    pub fn new(stamp_s: f64, frame_id: impl Into<String>) -> Header {
        Header { stamp_s, frame_id: frame_id.into() }
    }

    /// Writes it.
    pub fn write(&self, w: &mut Writer) {
        time(w, self.stamp_s);
        w.string(&self.frame_id);
    }

    /// Reads one.
    pub fn read(r: &mut Reader) -> Result<Header, CdrError> {
        Ok(Header { stamp_s: read_time(r)?, frame_id: r.string()? })
    }
}

/// A planar pose (x, y, yaw) as `geometry_msgs/msg/Pose`: Point (z = 0), then the quaternion
/// of the yaw about z.
pub fn pose(w: &mut Writer, x: f64, y: f64, yaw: f64) {
    pose_at(w, [x, y, 0.0], yaw);
}

/// A pose at `at` (x, y, z) turned by `yaw` about z, as `geometry_msgs/msg/Pose`.
pub fn pose_at(w: &mut Writer, at: [f64; 3], yaw: f64) {
    let (s, c) = (yaw / 2.0).sin_cos();
    for v in [at[0], at[1], at[2], 0.0, 0.0, s, c] {
        w.f64(v);
    }
}

/// Reads a `geometry_msgs/msg/Pose` as a planar pose: x, y and the yaw of its quaternion.
pub fn read_pose(r: &mut Reader) -> Result<(f64, f64, f64), CdrError> {
    let mut v = [0.0; 7];
    for x in &mut v {
        *x = r.f64()?;
    }
    let [x, y, _, qx, qy, qz, qw] = v;
    // The yaw of a quaternion (z of the ZYX Euler angles).
    let yaw = (2.0 * (qw * qz + qx * qy)).atan2(1.0 - 2.0 * (qy * qy + qz * qz));
    Ok((x, y, yaw))
}

/// Seconds as whole seconds and nanoseconds, rounded to the nanosecond: what a stamp carries.
/// Two stamps name the same tick when this gives the same pair.
pub fn stamp_ns(t_s: f64) -> i64 {
    (t_s.max(0.0) * 1e9).round() as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_header_and_a_pose_read_back() {
        let mut w = Writer::new();
        Header::new(12.3, "uav3/odom").write(&mut w);
        pose(&mut w, 1.5, -2.0, 2.5);
        let b = w.finish();
        let mut r = Reader::new(&b).expect("header");
        let h = Header::read(&mut r).expect("read");
        assert_eq!(h.frame_id, "uav3/odom");
        assert_eq!(stamp_ns(h.stamp_s), stamp_ns(12.3));
        let (x, y, yaw) = read_pose(&mut r).expect("pose");
        assert_eq!((x, y), (1.5, -2.0));
        assert!((yaw - 2.5).abs() < 1e-12, "{yaw}");
    }
}
