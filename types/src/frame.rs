//! 2D poses and points tagged with the frame they are expressed in, and the one angle wrap.
//!
//! The swarm moves between three frames: the world (the hub's truth, GNSS-like fixes), a UAV's
//! body (its scan, its commands, its neighbours' estimates) and its odometry frame (its start
//! pose: odometry, the maps it builds). A
//! value carries its frame as a type parameter, so a body-frame point cannot be handed where a
//! world-frame one is wanted; the tag costs nothing on the wire (it is not serialized).

use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};
use std::fmt::Debug;
use std::marker::PhantomData;

/// A frame a pose or point is expressed in.
pub trait Frame: Copy + Debug + Default + PartialEq {}

/// The world frame: the hub's truth and the GNSS-like fix.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct World;

/// A UAV's body frame: x forward, y left; its scan and commands.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Body;

/// A UAV's odometry frame: its start pose.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Odom;

impl Frame for World {}
impl Frame for Body {}
impl Frame for Odom {}

/// A position and heading in frame `F`: x, y [m], yaw [rad].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose<F: Frame> {
    /// Position x [m].
    pub x: f64,
    /// Position y [m].
    pub y: f64,
    /// Heading [rad].
    pub yaw: f64,
    #[serde(skip)]
    frame: PhantomData<F>,
}

/// A point in frame `F`: x, y [m].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point<F: Frame> {
    /// x [m].
    pub x: f64,
    /// y [m].
    pub y: f64,
    #[serde(skip)]
    frame: PhantomData<F>,
}

impl<F: Frame> Point<F> {
    /// The point (x, y) of frame `F`.
    pub const fn new(x: f64, y: f64) -> Self {
        Point { x, y, frame: PhantomData }
    }
}

impl<F: Frame> Pose<F> {
    /// The pose (x, y, yaw) of frame `F`.
    pub const fn new(x: f64, y: f64, yaw: f64) -> Self {
        Pose { x, y, yaw, frame: PhantomData }
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.yaw.is_finite()
    }

    /// The position.
    pub fn position(&self) -> Point<F> {
        Point::new(self.x, self.y)
    }

    /// A point of the body this pose places, expressed in `F`: `F_from_body · p`.
    pub fn from_body(&self, p: Point<Body>) -> Point<F> {
        let (s, c) = self.yaw.sin_cos();
        Point::new(self.x + c * p.x - s * p.y, self.y + s * p.x + c * p.y)
    }
}

/// Wraps an angle to (−π, π] [rad], the interval `atan2` returns: the one convention of the
/// whole swarm (the hub's true headings, the onboard stack's estimates and commands).
#[inline]
pub fn wrap_angle(a: f64) -> f64 {
    let w = a.rem_euclid(TAU);
    if w > PI {
        w - TAU
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    proptest::proptest! {
        #[test]
        fn wrap_lands_in_the_half_open_interval(a in -1e6..1e6f64) {
            let w = wrap_angle(a);
            proptest::prop_assert!(w > -PI && w <= PI, "{a} -> {w}");
            proptest::prop_assert!(((w - a) / TAU - ((w - a) / TAU).round()).abs() < 1e-6);
        }

        #[test]
        fn from_body_turns_then_shifts_keeping_distances(x in -50.0..50.0f64, y in -50.0..50.0f64, yaw in -4.0..4.0f64, px in -20.0..20.0f64, py in -20.0..20.0f64) {
            let pose = Pose::<World>::new(x, y, yaw);
            let q = pose.from_body(Point::new(px, py));
            let (d_body, d_world) = (px.hypot(py), (q.x - x).hypot(q.y - y));
            proptest::prop_assert!((d_body - d_world).abs() < 1e-9, "{d_body} vs {d_world}");
            let ahead = pose.from_body(Point::new(1.0, 0.0));
            proptest::prop_assert!((ahead.x - x - yaw.cos()).abs() < 1e-12 && (ahead.y - y - yaw.sin()).abs() < 1e-12);
        }
    }

    #[test]
    fn the_frame_is_not_on_the_wire() {
        let p = Pose::<Odom>::new(1.0, -2.0, 0.5);
        assert_eq!(
            postcard::to_stdvec(&p).expect("encodes"),
            postcard::to_stdvec(&(1.0f64, -2.0f64, 0.5f64)).expect("encodes")
        );
        assert_eq!(serde_json::to_string(&p).expect("encodes"), r#"{"x":1.0,"y":-2.0,"yaw":0.5}"#);
        assert_eq!(wrap_angle(-PI), PI);
        assert_eq!(wrap_angle(PI), PI);
    }
}
