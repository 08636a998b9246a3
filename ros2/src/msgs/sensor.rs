//! A UAV's scan as `sensor_msgs/msg/LaserScan` and its odometry as `nav_msgs/msg/Odometry`,
//! both ways: the bridge writes them from the hub's sensor frames, an agent on ROS topics reads
//! them back (from our bridge, or from a vehicle's or another simulator's drivers).

use super::{pose, read_pose, Header};
use crate::cdr::{CdrError, Reader, Writer};
use swarm_wire::{Odom, Scan};

/// A scan as `sensor_msgs/msg/LaserScan` in `frame_id` (the UAV's body frame): no hit is
/// `+inf`, as REP 117 asks; no intensities.
pub fn laser_scan(s: &Scan, frame_id: &str, scan_period_s: f32) -> Vec<u8> {
    let mut w = Writer::new();
    Header::new(s.t_s, frame_id).write(&mut w);
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

/// A `sensor_msgs/msg/LaserScan` as read (the fields our stack uses).
#[derive(Debug, Clone, PartialEq)]
pub struct LaserScan {
    /// Stamp and frame.
    pub header: Header,
    /// Angle of the first beam [rad].
    pub angle_min: f32,
    /// Angle between beams [rad].
    pub angle_increment: f32,
    /// Shortest valid range [m].
    pub range_min: f32,
    /// Longest valid range [m].
    pub range_max: f32,
    /// The ranges [m].
    pub ranges: Vec<f32>,
}

impl LaserScan {
    /// Decoded from a CDR payload.
    pub fn decode(payload: &[u8]) -> Result<LaserScan, CdrError> {
        let mut r = Reader::new(payload)?;
        let header = Header::read(&mut r)?;
        let angle_min = r.f32()?;
        let _angle_max = r.f32()?;
        let angle_increment = r.f32()?;
        let _time_increment = r.f32()?;
        let _scan_time = r.f32()?;
        let range_min = r.f32()?;
        let range_max = r.f32()?;
        let ranges = r.f32_seq()?;
        let _intensities = r.f32_seq()?;
        r.finish()?;
        Ok(LaserScan { header, angle_min, angle_increment, range_min, range_max, ranges })
    }

    /// As our scan of `tick`: a range outside `[range_min, range_max]` (REP 117's no return,
    /// too close or too far, NaN) is no hit, `+inf`.
    pub fn into_scan(self, tick: u64) -> Scan {
        let (lo, hi) = (self.range_min, self.range_max);
        let ranges_m = self.ranges.into_iter().map(|r| if r >= lo && r <= hi { r } else { f32::INFINITY }).collect();
        Scan {
            tick,
            t_s: self.header.stamp_s,
            angle_min: self.angle_min,
            angle_increment: self.angle_increment,
            max_range_m: self.range_max,
            ranges_m,
        }
    }
}

/// Odometry as `nav_msgs/msg/Odometry`: pose and velocity in `frame_id` (the UAV's odometry
/// frame), the twist in `child_frame_id` (its body frame, as REP 105 asks), covariances 0.
pub fn odometry(o: &Odom, frame_id: &str, child_frame_id: &str) -> Vec<u8> {
    let mut w = Writer::new();
    Header::new(o.t_s, frame_id).write(&mut w);
    w.string(child_frame_id);
    // geometry_msgs/PoseWithCovariance: Pose, float64[36].
    pose(&mut w, o.x, o.y, o.yaw);
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

/// A `nav_msgs/msg/Odometry` as read, planar: the pose in the odometry frame, the velocity
/// turned back from the body frame into it.
#[derive(Debug, Clone, PartialEq)]
pub struct Odometry {
    /// Stamp and the odometry frame.
    pub header: Header,
    /// The body frame.
    pub child_frame_id: String,
    /// Position x [m].
    pub x: f64,
    /// Position y [m].
    pub y: f64,
    /// Heading [rad].
    pub yaw: f64,
    /// Velocity x in the odometry frame [m/s].
    pub vx: f64,
    /// Velocity y in the odometry frame [m/s].
    pub vy: f64,
}

impl Odometry {
    /// Decoded from a CDR payload.
    pub fn decode(payload: &[u8]) -> Result<Odometry, CdrError> {
        let mut r = Reader::new(payload)?;
        let header = Header::read(&mut r)?;
        let child_frame_id = r.string()?;
        let (x, y, yaw) = read_pose(&mut r)?;
        for _ in 0..36 {
            r.f64()?;
        }
        let (bx, by) = (r.f64()?, r.f64()?);
        for _ in 0..(4 + 36) {
            r.f64()?;
        }
        r.finish()?;
        let (sy, cy) = yaw.sin_cos();
        Ok(Odometry { header, child_frame_id, x, y, yaw, vx: cy * bx - sy * by, vy: sy * bx + cy * by })
    }

    /// As our odometry of `tick`, with the goal the UAV was given (if any).
    pub fn into_odom(self, tick: u64, goal: Option<[f64; 2]>) -> Odom {
        let Odometry { header, x, y, yaw, vx, vy, .. } = self;
        Odom { tick, t_s: header.stamp_s, x, y, yaw, vx, vy, goal, goal_vel: None }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odometry_puts_the_pose_after_the_frames_on_an_8_byte_boundary() {
        let o = Odom { tick: 1, t_s: 1.5, x: 2.0, y: 3.0, yaw: 0.0, vx: 1.0, vy: 0.0, goal: None, goal_vel: None };
        let b = odometry(&o, "odom", "base_link");
        // After the header: sec 0, nanosec 4, "odom" 8..17, "base_link" 20..34, pose x at 40.
        assert_eq!(&b[4..8], &1i32.to_le_bytes());
        assert_eq!(&b[8..12], &500_000_000u32.to_le_bytes());
        assert_eq!(&b[44..52], &2.0f64.to_le_bytes());
        assert_eq!(b.len(), 4 + 40 + 7 * 8 + 36 * 8 + 6 * 8 + 36 * 8);
    }

    #[test]
    fn odometry_and_scans_read_back_as_ours() {
        let o = Odom { tick: 7, t_s: 0.7, x: 2.0, y: -3.0, yaw: 1.0, vx: 0.3, vy: -0.4, goal: None, goal_vel: None };
        let back = Odometry::decode(&odometry(&o, "uav2/odom", "uav2/base_link")).expect("decode");
        assert_eq!(back.child_frame_id, "uav2/base_link");
        let back = back.into_odom(7, Some([30.0, 0.0]));
        assert!((back.vx - 0.3).abs() < 1e-12 && (back.vy + 0.4).abs() < 1e-12 && (back.yaw - 1.0).abs() < 1e-12);
        assert_eq!((back.x, back.y, back.goal), (2.0, -3.0, Some([30.0, 0.0])));

        let s = Scan {
            tick: 7,
            t_s: 0.7,
            angle_min: -3.1,
            angle_increment: 0.01,
            max_range_m: 12.0,
            ranges_m: vec![1.0, f32::INFINITY, 11.5],
        };
        let back = LaserScan::decode(&laser_scan(&s, "uav2/base_link", 0.1)).expect("decode").into_scan(7);
        assert!((back.t_s - 0.7).abs() < 1e-9, "a stamp is whole nanoseconds: {}", back.t_s);
        assert_eq!(Scan { t_s: 0.7, ..back }, s);
        assert!(LaserScan::decode(&laser_scan(&s, "f", 0.1)[..40]).is_err());
    }

    #[test]
    fn ranges_outside_the_valid_interval_are_no_hits() {
        let scan = LaserScan {
            header: Header::new(0.0, "b"),
            angle_min: 0.0,
            angle_increment: 0.1,
            range_min: 0.2,
            range_max: 10.0,
            ranges: vec![0.1, f32::NAN, 10.5, 5.0, f32::INFINITY],
        };
        let r = scan.into_scan(0).ranges_m;
        assert_eq!(r[3], 5.0);
        assert!([0, 1, 2, 4].iter().all(|&i| r[i] == f32::INFINITY), "{r:?}");
    }
}
