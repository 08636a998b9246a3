//! The bodies close to the UAV inside a group that joins several: what K21's barrier keeps off
//! where seed 000's grouping has made one group of them.
//!
//! Why this exists: Algorithm 2 joins consecutive points less than `group_gap_m` (1 m) apart,
//! which keeps a trunk whole but makes one group of a crowd of UAVs (packed closer than about
//! 1.6 m) or of a UAV beside a trunk. That group's circle lies off every body in it, and may
//! even fit its points well, so a barrier on circle centres misses the bodies (forest-100-icp's
//! goal point: a UAV whose centre was 0.72 m ahead inside a group whose circle sat 1.13 m off
//! with a 0.69 m radius, and UAVs touching). Such a group is told by a jump of [`BODY_GAP_M`] or
//! more between consecutive points (where one body's silhouette ends against another) and split
//! there, and each part is a body: its nearest point, and the centre of its circle when that
//! circle fits the part's points (K21's barrier takes the centre when it is within reach, else
//! the nearest point, since a few points can fit a circle far behind them). A trunk seen alone
//! is one part and gives nothing
//! here, so a forest without crowds flies as before; a wall seen at a glancing angle can split
//! where its points spread (0.2 m apart about 4.9 m along a wall 1 m away), and its near part is
//! then a body too, which only keeps the UAV off the wall.

use super::circles::{accepted_circle, rms_circle_residual};
use crate::world_model::Body;
use nalgebra::Point2;
use swarm_config::PerceptionParams;

/// Consecutive points of one body are this close: beams 0.48° apart meet a surface 1 m away
/// 0.01 m apart, plus the range noise (0.02 m by default) of each; two bodies, one behind the
/// other's silhouette, are farther apart in range than this.
pub const BODY_GAP_M: f64 = 0.2;

/// Whether `group` (points in beam order) joins several bodies.
pub fn is_joined(group: &[Point2<f64>]) -> bool {
    first_jump(group).is_some()
}

/// `group` as a ring that starts after its first jump: for a group that is the whole scan
/// (every beam returned, every step short), which starts at beam 0 and so would cut the body
/// that beam 0 (dead ahead) meets in two.
pub fn ring_from_a_jump(mut group: Vec<Point2<f64>>) -> Vec<Point2<f64>> {
    if let Some(i) = first_jump(&group) {
        group.rotate_left(i + 1);
    }
    group
}

/// The index of the first point followed by a jump of [`BODY_GAP_M`] or more.
fn first_jump(group: &[Point2<f64>]) -> Option<usize> {
    group.windows(2).position(|w| (w[1] - w[0]).norm_squared() >= BODY_GAP_M * BODY_GAP_M)
}

/// The bodies of `joined` (groups of several, points in beam order) that have a point closer
/// than `within_m`. A part's circle counts when `params` accepts it (points and radius) and its
/// RMS residual is at most `max_rms_m`.
pub fn bodies(joined: &[Vec<Point2<f64>>], within_m: f64, params: &PerceptionParams, max_rms_m: f64) -> Vec<Body> {
    let near = |p: &Point2<f64>| p.coords.norm() < within_m;
    joined
        .iter()
        .filter(|g| g.iter().any(near))
        .flat_map(|g| parts(g))
        .filter(|part| part.iter().any(near))
        .filter_map(|part| body(part, params, max_rms_m))
        .collect()
}

/// `group` split where consecutive points are [`BODY_GAP_M`] or more apart.
fn parts(group: &[Point2<f64>]) -> impl Iterator<Item = &[Point2<f64>]> {
    let mut rest = group;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let end = first_jump(rest).map_or(rest.len(), |i| i + 1);
        let (part, tail) = rest.split_at(end);
        rest = tail;
        Some(part)
    })
}

/// The body one part shows (`None` for a part with no finite point).
fn body(part: &[Point2<f64>], params: &PerceptionParams, max_rms_m: f64) -> Option<Body> {
    let nearest =
        part.iter().map(|p| p.coords).filter(|p| p.norm().is_finite()).min_by(|a, b| a.norm().total_cmp(&b.norm()))?;
    let centre =
        accepted_circle(part, params).filter(|c| rms_circle_residual(part, c) <= max_rms_m).map(|c| c.center.coords);
    Some(Body { nearest, centre })
}

#[cfg(test)]
mod tests {
    use super::super::tests::arc;
    use super::*;
    use nalgebra::Vector2;
    use std::f64::consts::PI;

    #[test]
    fn a_joined_group_splits_into_its_bodies() {
        // Two UAVs' facing arcs as one group, 0.53 m apart at the seam.
        let mut group = arc(0.8, 0.4, 0.3, PI * 0.6, PI * 1.4, 40);
        group.extend(arc(0.8, -0.7, 0.3, PI * 0.6, PI * 1.4, 40));
        assert!(is_joined(&group) && !is_joined(&group[..40]));
        let p = PerceptionParams::default();
        let found = bodies(&[group.clone()], 1.0, &p, 0.06);
        assert_eq!(found.len(), 2, "{found:?}");
        for (b, truth) in found.iter().zip([Vector2::new(0.8, 0.4), Vector2::new(0.8, -0.7)]) {
            let c = b.centre.expect("a circle fits");
            assert!((c - truth).norm() < 1e-6, "{c} != {truth}");
            // The nearest point: on the circle, towards the UAV, to the arc's sampling.
            assert!((b.nearest.norm() - (truth.norm() - 0.3)).abs() < 1e-3, "{b:?}");
        }
        // Only the parts with a point that close.
        assert_eq!(bodies(&[group], 0.6, &p, 0.06).len(), 1);
    }

    #[test]
    fn a_part_with_no_circle_is_its_nearest_point() {
        // A UAV's arc, then two points of something behind it: too few for a circle.
        let mut group = arc(0.8, 0.0, 0.3, PI * 0.7, PI * 1.3, 30);
        group.extend([Point2::new(1.5, 0.5), Point2::new(1.45, 0.52)]);
        let found = bodies(&[group], 2.0, &PerceptionParams::default(), 0.06);
        assert_eq!(found.len(), 2, "{found:?}");
        assert_eq!(found[1], Body { nearest: Vector2::new(1.45, 0.52), centre: None });
        assert!(bodies(&[], 1.0, &PerceptionParams::default(), 0.06).is_empty());
    }

    #[test]
    fn a_whole_ring_is_cut_at_a_jump_not_at_beam_zero() {
        // A ring that starts in the middle of the body dead ahead, as a scan's one group does when
        // every beam returns: cut at beam 0 it would be two fragments of that body.
        let ahead = arc(0.8, 0.0, 0.3, PI * 0.7, PI * 1.3, 30);
        let (left_half, right_half) = ahead.split_at(15);
        let mut ring: Vec<Point2<f64>> = right_half.to_vec();
        ring.extend(arc(0.0, 0.0, 1.2, 0.6, 2.0 * PI - 0.6, 60));
        ring.extend_from_slice(left_half);
        let p = PerceptionParams::default();
        let cut = bodies(&[ring.clone()], 0.7, &p, 0.06);
        assert_eq!(cut.len(), 2, "cut at beam 0: {cut:?}");
        let whole = bodies(&[ring_from_a_jump(ring)], 0.7, &p, 0.06);
        assert_eq!(whole.len(), 1, "{whole:?}");
        let c = whole[0].centre.expect("a circle fits");
        assert!((c - Vector2::new(0.8, 0.0)).norm() < 1e-6, "{c}");
    }
}
