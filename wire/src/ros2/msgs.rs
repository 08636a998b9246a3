//! The three ROS 2 messages a UAV maps onto: `sensor_msgs/msg/LaserScan` (its scan),
//! `nav_msgs/msg/Odometry` (its odometry) and `geometry_msgs/msg/Twist` (a command in), in
//! their Jazzy field order, CDR encoded ([`super::cdr`]).

use super::cdr::{CdrError, Reader, Writer};
use crate::{Odom, Scan};

/// `builtin_interfaces/msg/Time` from sim seconds.
fn stamp(w: &mut Writer, t_secs: f64, frame_id: &str) {
    let sec = t_secs.floor();
    let nanosec = ((t_secs - sec) * 1e9).round().min(999_999_999.0) as u32;
    // std_msgs/Header: stamp (int32 sec, uint32 nanosec), string frame_id.
    w.i32(sec as i32).u32(nanosec).string(frame_id);
}

/// A scan as `sensor_msgs/msg/LaserScan` in `frame_id` (the UAV's body frame): no hit is
/// `+inf`, as REP 117 asks; no intensities.
pub fn laser_scan(s: &Scan, frame_id: &str, scan_period_s: f32) -> Vec<u8> {
    let mut w = Writer::new();
    stamp(&mut w, s.t_secs, frame_id);
    let n = s.ranges_m.len().max(1) as f32;
    w.f32(s.angle_min)
        .f32(s.angle_min + s.angle_increment * (n - 1.0))
        .f32(s.angle_increment)
        .f32(0.0)
        .f32(scan_period_s)
        .f32(0.0)
        .f32(s.max_range_m)
        .f32_seq(&s.ranges_m)
        .f32_seq(&[]);
    w.finish()
}

/// Odometry as `nav_msgs/msg/Odometry`: pose and velocity in `frame_id` (the UAV's odometry
/// frame), the twist in `child_frame_id` (its body frame, as REP 105 asks), covariances 0.
pub fn odometry(o: &Odom, frame_id: &str, child_frame_id: &str) -> Vec<u8> {
    let mut w = Writer::new();
    stamp(&mut w, o.t_secs, frame_id);
    w.string(child_frame_id);
    // geometry_msgs/PoseWithCovariance: Point, Quaternion (yaw about z), float64[36].
    let (s, c) = (o.yaw / 2.0).sin_cos();
    for v in [o.x, o.y, 0.0, 0.0, 0.0, s, c] {
        w.f64(v);
    }
    for _ in 0..36 {
        w.f64(0.0);
    }
    // geometry_msgs/TwistWithCovariance: the velocity turned into the body frame.
    let (sy, cy) = o.yaw.sin_cos();
    let (bx, by) = (cy * o.vx + sy * o.vy, -sy * o.vx + cy * o.vy);
    for v in [bx, by, 0.0, 0.0, 0.0, 0.0] {
        w.f64(v);
    }
    for _ in 0..36 {
        w.f64(0.0);
    }
    w.finish()
}

/// `geometry_msgs/msg/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Twist {
    /// Linear velocity x, y, z [m/s].
    pub linear: [f64; 3],
    /// Angular velocity x, y, z [rad/s].
    pub angular: [f64; 3],
}

impl Twist {
    /// Encoded.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        for v in self.linear.iter().chain(&self.angular) {
            w.f64(*v);
        }
        w.finish()
    }

    /// Decoded from a CDR payload.
    pub fn decode(payload: &[u8]) -> Result<Twist, CdrError> {
        let mut r = Reader::new(payload)?;
        let mut v = [0.0; 6];
        for x in &mut v {
            *x = r.f64()?;
        }
        Ok(Twist { linear: [v[0], v[1], v[2]], angular: [v[3], v[4], v[5]] })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_twist_round_trips_in_52_bytes() {
        let t = Twist { linear: [0.5, -0.25, 0.0], angular: [0.0, 0.0, 0.1] };
        let b = t.encode();
        assert_eq!(b.len(), 52);
        assert_eq!(&b[4..12], &0.5f64.to_le_bytes());
        assert_eq!(Twist::decode(&b), Ok(t));
        assert!(Twist::decode(&b[..40]).is_err());
    }

    #[test]
    fn odometry_puts_the_pose_after_the_frames_on_an_8_byte_boundary() {
        let o = Odom { tick: 1, t_secs: 1.5, x: 2.0, y: 3.0, yaw: 0.0, vx: 1.0, vy: 0.0, goal: None, goal_vel: None };
        let b = odometry(&o, "odom", "base_link");
        // After the header: sec 0, nanosec 4, "odom" 8..17, "base_link" 20..34, pose x at 40.
        assert_eq!(&b[4..8], &1i32.to_le_bytes());
        assert_eq!(&b[8..12], &500_000_000u32.to_le_bytes());
        assert_eq!(&b[44..52], &2.0f64.to_le_bytes());
        assert_eq!(b.len(), 4 + 40 + 7 * 8 + 36 * 8 + 6 * 8 + 36 * 8);
    }
}
