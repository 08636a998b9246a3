//! The agent's model of what is around it, in its body frame, as one stage hands it to the next:
//! obstacles as perception finds them in the scan ([`Circle`] for a trunk, [`Segment`] for a
//! wall face, [`Body`] for one of several it grouped together) and neighbours as localization places
//! them ([`Estimate`]).
//!
//! Why a module of its own: these types are what the stages share. Perception makes the
//! obstacles; localization matches its own circles (the reference set of the ICP) and makes the
//! estimates; control steers by all three, and so does a user's controller, through
//! [`crate::View`]. A type two stages share lives below both, so no stage reaches sideways into
//! another for it: perception, localization and control import it from here, and this module
//! imports nothing of the crate. Plain data; the algorithms that make and use it stay in their
//! stages.

use nalgebra::{Point2, Vector2};
use swarm_types::UavId;

/// One body close to the UAV inside a group of scan points that joins several, body frame: what
/// K21's barrier keeps off.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// The body's nearest point.
    pub nearest: Vector2<f64>,
    /// The centre of the circle that fits the body's points, if one does.
    pub centre: Option<Vector2<f64>>,
}

/// A circular obstacle (a trunk cut by the plane of flight), body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre [m], body frame.
    pub center: Point2<f64>,
    /// Radius [m].
    pub radius: f64,
}

impl Circle {
    /// Its point nearest the UAV (the origin of the body frame); the UAV itself when inside it.
    pub fn nearest_point(&self) -> Vector2<f64> {
        let (centre, d) = (self.center.coords, self.center.coords.norm());
        if d > self.radius {
            centre * ((d - self.radius) / d)
        } else {
            Vector2::zeros()
        }
    }
}

/// A straight piece of wall: the face the scan sees, body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// End point [m], body frame: the end of the lower beam indices (first in scan order).
    pub a: Point2<f64>,
    /// Other end point [m], body frame.
    pub b: Point2<f64>,
}

impl Segment {
    /// Length |b − a| [m].
    pub fn length(&self) -> f64 {
        (self.b - self.a).norm()
    }
}

/// One neighbour as this agent believes it to be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Sender id where known (metrics only).
    pub id: Option<UavId>,
    /// Relative position, body frame [m].
    pub pos_in_body: Vector2<f64>,
    /// Relative heading [rad].
    pub heading: f64,
    /// Age of the information [s].
    pub age_s: f64,
}
