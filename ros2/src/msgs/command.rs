//! Commands and goals: `geometry_msgs/msg/Twist` (a velocity), its stamped form `TwistStamped`
//! (what Jazzy's navigation stack sends, and what an agent on ROS topics sends: the stamp names
//! the tick it answers), `AccelStamped` (an acceleration, for controllers that command one) and
//! `PoseStamped` (a goal).

use super::{pose, read_pose, Header};
use crate::cdr::{CdrError, Reader, Writer};

/// `geometry_msgs/msg/Twist` (and `Accel`, which has the same fields).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Twist {
    /// Linear x, y, z [m/s] (or [m/s²] as an `Accel`).
    pub linear: [f64; 3],
    /// Angular x, y, z [rad/s] (or [rad/s²]).
    pub angular: [f64; 3],
}

impl Twist {
    /// A planar command: `x, y` in the body frame and a yaw rate.
    pub fn planar(x: f64, y: f64, yaw_rate: f64) -> Twist {
        Twist { linear: [x, y, 0.0], angular: [0.0, 0.0, yaw_rate] }
    }

    /// Every component finite.
    pub fn is_finite(&self) -> bool {
        self.linear.iter().chain(&self.angular).all(|v| v.is_finite())
    }

    fn write(&self, w: &mut Writer) {
        for v in self.linear.iter().chain(&self.angular) {
            w.f64(*v);
        }
    }

    fn read(r: &mut Reader) -> Result<Twist, CdrError> {
        let mut v = [0.0; 6];
        for x in &mut v {
            *x = r.f64()?;
        }
        Ok(Twist { linear: [v[0], v[1], v[2]], angular: [v[3], v[4], v[5]] })
    }

    /// Encoded.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        self.write(&mut w);
        w.finish()
    }

    /// Decoded from a CDR payload (all of it: a longer payload is another message).
    pub fn decode(payload: &[u8]) -> Result<Twist, CdrError> {
        let mut r = Reader::new(payload)?;
        let t = Twist::read(&mut r)?;
        r.finish()?;
        Ok(t)
    }
}

/// `geometry_msgs/msg/TwistStamped` or `AccelStamped`: a header and a [`Twist`]'s fields.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Stamped {
    /// Stamp and frame.
    pub header: Header,
    /// The velocity (or acceleration).
    pub twist: Twist,
}

impl Stamped {
    /// Encoded.
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer::new();
        self.header.write(&mut w);
        self.twist.write(&mut w);
        w.finish()
    }

    /// Decoded from a CDR payload (all of it).
    pub fn decode(payload: &[u8]) -> Result<Stamped, CdrError> {
        let mut r = Reader::new(payload)?;
        let s = Stamped { header: Header::read(&mut r)?, twist: Twist::read(&mut r)? };
        r.finish()?;
        Ok(s)
    }
}

/// `geometry_msgs/msg/PoseStamped`, planar (a goal in a UAV's odometry frame).
pub fn pose_stamped(header: &Header, x: f64, y: f64, yaw: f64) -> Vec<u8> {
    let mut w = Writer::new();
    header.write(&mut w);
    pose(&mut w, x, y, yaw);
    w.finish()
}

/// Reads a `geometry_msgs/msg/PoseStamped`: its header and planar pose.
pub fn read_pose_stamped(payload: &[u8]) -> Result<(Header, (f64, f64, f64)), CdrError> {
    let mut r = Reader::new(payload)?;
    let p = (Header::read(&mut r)?, read_pose(&mut r)?);
    r.finish()?;
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_twist_round_trips_in_52_bytes() {
        let t = Twist::planar(0.5, -0.25, 0.1);
        let b = t.encode();
        assert_eq!(b.len(), 52);
        assert_eq!(&b[4..12], &0.5f64.to_le_bytes());
        assert_eq!(Twist::decode(&b), Ok(t));
        assert!(Twist::decode(&b[..40]).is_err());
    }

    #[test]
    fn a_stamped_twist_and_a_goal_round_trip() {
        let s = Stamped { header: Header::new(4.2, "uav3/base_link"), twist: Twist::planar(1.0, 0.0, -0.2) };
        assert_eq!(Stamped::decode(&s.encode()), Ok(s.clone()));
        assert!(Twist::decode(&s.encode()).is_err(), "a TwistStamped is not a Twist");
        assert!(Stamped::decode(&s.twist.encode()).is_err(), "nor a Twist a TwistStamped");
        let (h, (x, y, _)) = read_pose_stamped(&pose_stamped(&s.header, 30.0, -1.0, 0.0)).expect("goal");
        assert_eq!((h, x, y), (s.header, 30.0, -1.0));
    }
}
