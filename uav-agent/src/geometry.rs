//! The geometry every stage shares, kept below all of them so no stage reaches sideways into
//! another for it: the odometry-frame pose [`Pose2`] (the ground floor's `Pose<Odom>`) and its
//! frame change in nalgebra points ([`OdomPose`]), the one angle-wrap
//! convention ([`wrap_angle`], the ground floor's, to (−π, π]), and the small 2D vector helpers
//! (what counts as zero, how non-finite values are kept out of a command, scatter sums).

use nalgebra::{Point2, Vector2};
use swarm_types::frame::{Body, Odom, Point, Pose};

/// A pose in the odometry frame: where the LIDAR is and where it looks (the ground floor's
/// frame-tagged pose).
pub type Pose2 = Pose<Odom>;

/// The odometry-frame pose in the stages' nalgebra points.
pub trait OdomPose {
    /// The position as a point of the odometry frame.
    fn point(&self) -> Point2<f64>;
    /// A body-frame point expressed in the odometry frame: `odom_from_body · p`.
    fn odom_from_body(&self, p: &Point2<f64>) -> Point2<f64>;
}

impl OdomPose for Pose2 {
    fn point(&self) -> Point2<f64> {
        Point2::new(self.x, self.y)
    }

    fn odom_from_body(&self, p: &Point2<f64>) -> Point2<f64> {
        let q = self.from_body(Point::<Body>::new(p.x, p.y));
        Point2::new(q.x, q.y)
    }
}

/// The one angle wrap of the whole swarm, to (−π, π] (the ground floor's: the hub wraps the true
/// headings with the same function).
pub use swarm_types::wrap_angle;

/// Lengths below this are treated as zero (directions undefined) [m].
pub const EPS: f64 = 1e-9;

/// Whether both components are finite.
pub fn is_finite(v: &Vector2<f64>) -> bool {
    v.x.is_finite() && v.y.is_finite()
}

/// `v`, or zero when a component is not finite (a command never carries NaN).
pub fn finite_or_zero(v: Vector2<f64>) -> Vector2<f64> {
    if is_finite(&v) {
        v
    } else {
        Vector2::zeros()
    }
}

/// The scatter sums Σ dx², Σ dx·dy, Σ dy² of the points about `centre` (unnormalised).
pub fn scatter(points: impl Iterator<Item = nalgebra::Point2<f64>>, centre: Vector2<f64>) -> (f64, f64, f64) {
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in points {
        let d = p.coords - centre;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    (sxx, sxy, syy)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_vectors_become_zero() {
        assert_eq!(finite_or_zero(Vector2::new(1.0, -2.0)), Vector2::new(1.0, -2.0));
        assert_eq!(finite_or_zero(Vector2::new(f64::NAN, 1.0)), Vector2::zeros());
        assert!(!is_finite(&Vector2::new(1.0, f64::INFINITY)));
        let pts = [nalgebra::Point2::new(0.0, 0.0), nalgebra::Point2::new(2.0, 2.0)];
        assert_eq!(scatter(pts.into_iter(), Vector2::new(1.0, 1.0)), (2.0, 2.0, 2.0));
    }

    #[test]
    fn angles_wrap_to_minus_pi_exclusive_pi_inclusive() {
        use std::f64::consts::PI;
        assert_eq!(wrap_angle(PI), PI);
        assert_eq!(wrap_angle(-PI), PI);
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((wrap_angle(-5.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert_eq!(wrap_angle(0.25), 0.25);
    }

    #[test]
    fn odom_from_body_turns_then_shifts() {
        let pose = Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2);
        let p = pose.odom_from_body(&Point2::new(1.0, 0.0));
        assert!((p - Point2::new(1.0, 3.0)).norm() < 1e-12, "{p:?}");
    }
}
