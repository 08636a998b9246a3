//! Obstacle extraction from one LIDAR scan (seed 000, section 3.2): trunks as circles, walls as
//! straight segments.
//!
//! Why this module exists: K21 assumes a forest whose trunks cut the plane of flight in circles.
//! The ≈750 raw scan points are reduced to ≈20 circle centres, which are (a) the agent's local
//! obstacle map fed to collision avoidance (seed 000 section 4.4), (b) the point set matched by
//! ICP for relative localization and (c) what an agent shares with its neighbours ("only lower
//! tens of coordinates", seed 000 section 3.2). The pipeline is Algorithm 2 (group consecutive
//! points by depth jump), a drop of groups with fewer than 3 points, and the linear least-squares
//! circle fit of eq. 3.13–3.15.
//!
//! Everything here is a pure function of its arguments, in the body (rotational) frame of the
//! scanning UAV (seed 000 section 2.4), in `f64`.
//!
//! The parts, in the order a scan goes through them:
//! - [`scan`]: each beam's point and the groups of consecutive points (Algorithm 2), shared by
//!   both extractors;
//! - [`circles`]: the circle fit of eq. 3.13–3.15 and the trunk pipeline ([`extract_obstacles`](circles::extract_obstacles));
//! - [`walls`]: the split-and-merge segment extractor for what is not a trunk
//!   ([`segments_in_group`](walls::segments_in_group), [`SegmentParams`]);
//! - here, [`extract`]: each group to a circle or to segments, the rule that joins the two;
//! - [`bodies`]: the bodies inside a group that joins several, for K21's barrier.
//!
//! `walls` and `circles` both read `scan`'s groups and know nothing of each other; `extract`
//! alone decides between them.

pub mod bodies;
mod circles;
mod scan;
#[cfg(test)]
pub(crate) mod tests;
mod walls;

pub use walls::SegmentParams;

use circles::{accepted_circle, rms_circle_residual};
use nalgebra::Point2;
use scan::{beam_points, group_beams};
use swarm_config::PerceptionParams;
use swarm_wire::Scan;
use walls::segments_in_group;

use crate::world_model::{Circle, Segment};

/// What one scan shows: trunks as circles, walls as segments (see [`extract`]), and every point
/// the scan returned.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Extracted {
    /// Circular obstacles: those of [`extract_obstacles`](circles::extract_obstacles) minus any whose group is a wall.
    pub circles: Vec<Circle>,
    /// Straight wall faces, from the groups that are not trunks (see [`extract`]).
    pub segments: Vec<Segment>,
    /// Each beam's point, body frame (`None`: no return); kept as the scan gave them, since
    /// only the map-building controllers want them (see [`Extracted::points`]).
    pub(crate) beams: Vec<Option<Point2<f64>>>,
    /// The groups that hold several bodies, points in beam order: those with consecutive points
    /// [`BODY_GAP_M`](bodies::BODY_GAP_M) or more apart ([`bodies`](bodies::bodies) splits them).
    pub(crate) joined: Vec<Vec<Point2<f64>>>,
}

impl Extracted {
    /// Every returned point, body frame, in beam order.
    pub fn points(&self) -> impl Iterator<Item = &Point2<f64>> {
        self.beams.iter().flatten()
    }
}

/// Circles and wall segments of one scan, body frame, both lists in group order. Each group of
/// [`group_scan`](scan::group_scan) becomes the circle [`extract_obstacles`](circles::extract_obstacles) makes of it when that pipeline
/// accepts it and the points' RMS distance from it is at most `params.circle_max_rms_m`;
/// otherwise it is offered to [`segments_in_group`](walls::segments_in_group), and if that finds no segment the group gives
/// what [`extract_obstacles`](circles::extract_obstacles) gives (its circle, if accepted). So `circles` differs from
/// `extract_obstacles(scan, perception)` only by circles whose groups yielded segments.
pub fn extract(scan: &Scan, perception: &PerceptionParams, params: &SegmentParams) -> Extracted {
    let mut out = Extracted::default();
    let beams = beam_points(scan);
    for group in group_beams(&beams, f64::from(scan.angle_increment), perception.group_gap_m) {
        if bodies::is_joined(&group) {
            // The whole scan as one group starts at beam 0, inside the body dead ahead.
            let whole_scan = group.len() == beams.len();
            out.joined.push(if whole_scan { bodies::ring_from_a_jump(group.clone()) } else { group.clone() });
        }
        let circle = accepted_circle(&group, perception);
        if let Some(c) = circle.filter(|c| rms_circle_residual(&group, c) <= params.circle_max_rms_m) {
            out.circles.push(c);
            continue;
        }
        let segments = segments_in_group(&group, params);
        if segments.is_empty() {
            // Nothing straight: the group is whatever extract_obstacles makes of it.
            out.circles.extend(circle);
        } else {
            out.segments.extend(segments);
        }
    }
    out.beams = beams;
    out
}
