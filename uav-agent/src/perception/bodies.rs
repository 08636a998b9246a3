//! The bodies close to the UAV inside a group that joins several: what K21's barrier keeps off
//! where seed 000's grouping has made one group of them.
//!
//! Why this exists: Algorithm 2 joins consecutive points less than `group_gap_m` (1 m) apart,
//! which keeps a trunk whole but makes one group of a crowd of UAVs (packed closer than about
//! 1.6 m) or of a UAV beside a trunk. That group's circle lies off every body in it, and may
//! even fit its points well, so a barrier on circle centres misses the bodies (forest-100-icp's
//! goal point: a UAV 0.72 m ahead inside a group whose circle sits 1.13 m off with a 0.69 m
//! radius, and UAVs touching). Such a group is told by a jump of [`BODY_GAP_M`] or more between
//! consecutive points (where one body's silhouette ends against another) and split there, and
//! each part is a body: the centre of its circle when that circle fits the part's points, else
//! the part's nearest point. A trunk or a wall seen alone is one part and gives nothing here, so
//! a forest without crowds flies as before.

use super::circles::{accepted_circle, rms_circle_residual};
use crate::world_model::Body;
use nalgebra::{Point2, Vector2};
use swarm_config::PerceptionParams;

/// Consecutive points of one body are this close: beams 0.48° apart meet a surface 1 m away
/// 0.01 m apart, plus the range noise (0.02 m by default) of each; two bodies, one behind the
/// other's silhouette, are farther apart in range than this.
pub const BODY_GAP_M: f64 = 0.2;

/// Whether `group` (points in beam order) joins several bodies.
pub fn is_joined(group: &[Point2<f64>]) -> bool {
    group.windows(2).any(|w| (w[1] - w[0]).norm_squared() >= BODY_GAP_M * BODY_GAP_M)
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
        .map(|part| body(part, params, max_rms_m))
        .collect()
}

/// `group` split where consecutive points are [`BODY_GAP_M`] or more apart.
fn parts(group: &[Point2<f64>]) -> impl Iterator<Item = &[Point2<f64>]> {
    let mut rest = group;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let end = rest
            .windows(2)
            .position(|w| (w[1] - w[0]).norm_squared() >= BODY_GAP_M * BODY_GAP_M)
            .map_or(rest.len(), |i| i + 1);
        let (part, tail) = rest.split_at(end);
        rest = tail;
        Some(part)
    })
}

/// The body one part shows.
fn body(part: &[Point2<f64>], params: &PerceptionParams, max_rms_m: f64) -> Body {
    match accepted_circle(part, params).filter(|c| rms_circle_residual(part, c) <= max_rms_m) {
        Some(c) => Body::Centre(c.center.coords),
        None => Body::Nearest(
            part.iter().map(|p| p.coords).min_by(|a, b| a.norm().total_cmp(&b.norm())).unwrap_or_else(Vector2::zeros),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::arc;
    use super::*;

    #[test]
    fn a_joined_group_splits_into_its_bodies() {
        use std::f64::consts::PI;
        // Two UAVs' facing arcs, 0.3 m apart at the seam, as one group.
        let mut group = arc(0.8, 0.4, 0.3, PI * 0.6, PI * 1.4, 40);
        group.extend(arc(0.8, -0.7, 0.3, PI * 0.6, PI * 1.4, 40));
        let p = PerceptionParams::default();
        assert!(is_joined(&group) && !is_joined(&group[..40]));
        let found = bodies(&[group.clone()], 1.0, &p, 0.06);
        assert_eq!(found.len(), 2, "{found:?}");
        for (b, truth) in found.iter().zip([Vector2::new(0.8, 0.4), Vector2::new(0.8, -0.7)]) {
            let Body::Centre(c) = b else { panic!("{b:?}") };
            assert!((c - truth).norm() < 1e-6, "{c} != {truth}");
        }
        // Only the parts with a point that close.
        assert_eq!(bodies(&[group], 0.6, &p, 0.06).len(), 1);
    }

    #[test]
    fn a_part_with_no_circle_is_its_nearest_point() {
        // Two points: too few for a circle.
        let group = vec![Point2::new(0.5, 0.1), Point2::new(0.45, 0.0)];
        let found = bodies(&[group], 1.0, &PerceptionParams::default(), 0.06);
        assert_eq!(found, vec![Body::Nearest(Vector2::new(0.45, 0.0))]);
        assert!(bodies(&[], 1.0, &PerceptionParams::default(), 0.06).is_empty());
    }
}
