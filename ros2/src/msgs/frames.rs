//! Time and frames: `rosgraph_msgs/msg/Clock` (sim time, so nodes with `use_sim_time` follow
//! lockstep), `tf2_msgs/msg/TFMessage` (the transforms RViz places things with) and
//! `geometry_msgs/msg/PoseArray` (an agent's neighbour estimates in its body frame).

use super::{pose, read_time, time, Header};
use crate::cdr::{CdrError, Reader, Writer};

/// `rosgraph_msgs/msg/Clock` at `t_s`.
pub fn clock(t_s: f64) -> Vec<u8> {
    let mut w = Writer::new();
    time(&mut w, t_s);
    w.finish()
}

/// Reads a `rosgraph_msgs/msg/Clock` as seconds.
pub fn read_clock(payload: &[u8]) -> Result<f64, CdrError> {
    read_time(&mut Reader::new(payload)?)
}

/// A planar `geometry_msgs/msg/TransformStamped`: `child` placed in `header.frame_id` at
/// (x, y) turned by yaw.
#[derive(Debug, Clone, PartialEq)]
pub struct Transform {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child: String,
    /// Translation x [m].
    pub x: f64,
    /// Translation y [m].
    pub y: f64,
    /// Rotation about z [rad].
    pub yaw: f64,
}

/// `tf2_msgs/msg/TFMessage`: a sequence of transforms (`geometry_msgs/msg/Transform` is a
/// Vector3 and a Quaternion, the same eight-byte fields as a Pose).
pub fn tf_message(transforms: &[Transform]) -> Vec<u8> {
    let mut w = Writer::new();
    w.count(transforms.len());
    for t in transforms {
        t.header.write(&mut w);
        w.string(&t.child);
        pose(&mut w, t.x, t.y, t.yaw);
    }
    w.finish()
}

/// `geometry_msgs/msg/PoseArray` of planar poses `(x, y, yaw)`.
pub fn pose_array(header: &Header, poses: &[(f64, f64, f64)]) -> Vec<u8> {
    let mut w = Writer::new();
    header.write(&mut w);
    w.count(poses.len());
    for &(x, y, yaw) in poses {
        pose(&mut w, x, y, yaw);
    }
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msgs::read_pose;

    #[test]
    fn a_clock_is_eight_bytes_of_time() {
        let b = clock(12.5);
        assert_eq!(b.len(), 12);
        assert_eq!(read_clock(&b), Ok(12.5));
    }

    #[test]
    fn transforms_and_pose_arrays_read_back() {
        let t = Transform { header: Header::new(1.0, "world"), child: "uav1/odom".into(), x: 1.0, y: 2.0, yaw: 0.5 };
        let b = tf_message(&[t.clone(), t.clone()]);
        let mut r = Reader::new(&b).expect("header");
        assert_eq!(r.count(1), Ok(2));
        assert_eq!(Header::read(&mut r), Ok(t.header.clone()));
        assert_eq!(r.string().as_deref(), Ok("uav1/odom"));
        let (x, y, yaw) = read_pose(&mut r).expect("pose");
        assert!((x, y) == (1.0, 2.0) && (yaw - 0.5).abs() < 1e-12);

        let b = pose_array(&Header::new(1.0, "uav1/base_link"), &[(3.0, 4.0, 0.0)]);
        let mut r = Reader::new(&b).expect("header");
        Header::read(&mut r).expect("header");
        assert_eq!(r.count(56), Ok(1));
        assert_eq!(read_pose(&mut r).map(|p| (p.0, p.1)), Ok((3.0, 4.0)));
    }
}
