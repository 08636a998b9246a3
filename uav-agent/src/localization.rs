//! Relative localization, `broadcast` mode (SPEC section 5, seed 001 3.4): every agent sends its
//! GNSS-like world pose to its neighbours; the receiver subtracts its own, and expresses the
//! neighbour in its body frame. The newest pose of each sender is kept, extrapolated by its
//! velocity over its age, and dropped once older than `stale_after_s`.
//!
//! The `icp` mode of seed 000 will sit beside this one and produce the same [`Estimate`]s.

use nalgebra::{Rotation2, Vector2};
use std::collections::BTreeMap;
use swarm_wire::{Gnss, PoseShare};

/// One neighbour as this agent believes it to be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// Sender id where known (metrics only).
    pub id: Option<u32>,
    /// Relative position, body frame [m].
    pub pos_in_body: Vector2<f64>,
    /// Relative heading [rad].
    pub heading: f64,
    /// Age of the information [s].
    pub age_secs: f64,
}

/// Newest broadcast pose per neighbour.
#[derive(Debug, Default)]
pub struct BroadcastTable {
    poses: BTreeMap<u32, PoseShare>,
}

/// Wraps an angle to [−π, π).
pub(crate) fn wrap(a: f64) -> f64 {
    (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
}

impl BroadcastTable {
    /// Keeps `p` if it is newer than what we hold for its sender.
    pub fn update(&mut self, p: PoseShare) {
        let newer = self.poses.get(&p.from).is_none_or(|old| p.t_secs > old.t_secs);
        if newer {
            self.poses.insert(p.from, p);
        }
    }

    /// Estimates of every neighbour heard from within `stale_after_s`, in the body frame of `own`.
    pub fn estimates(&mut self, own: &Gnss, stale_after_s: f64) -> Vec<Estimate> {
        let now = own.t_secs;
        self.poses.retain(|_, p| now - p.t_secs <= stale_after_s + 1e-9);
        let body_from_world = Rotation2::new(-own.yaw);
        let own_pos = Vector2::new(own.x, own.y);
        self.poses
            .values()
            .map(|p| {
                let age = (now - p.t_secs).max(0.0);
                let pos_now = Vector2::new(p.x, p.y) + Vector2::new(p.vx, p.vy) * age;
                Estimate {
                    id: Some(p.from),
                    pos_in_body: body_from_world * (pos_now - own_pos),
                    heading: wrap(p.yaw - own.yaw),
                    age_secs: age,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gnss(t: f64, x: f64, y: f64, yaw: f64) -> Gnss {
        Gnss { tick: 0, t_secs: t, x, y, yaw, vx: 0.0, vy: 0.0 }
    }

    fn pose(from: u32, t: f64, x: f64, y: f64, yaw: f64, vx: f64) -> PoseShare {
        PoseShare { from, tick: 0, t_secs: t, x, y, yaw, vx, vy: 0.0 }
    }

    #[test]
    fn neighbour_is_expressed_in_the_body_frame() {
        let mut t = BroadcastTable::default();
        t.update(pose(2, 1.0, 1.0, 3.0, 0.5, 0.0));
        // Own pose (1, 1) facing +y: the neighbour 2 m ahead is at body (2, 0).
        let e = t.estimates(&gnss(1.0, 1.0, 1.0, std::f64::consts::FRAC_PI_2), 0.5);
        assert_eq!(e.len(), 1);
        assert!((e[0].pos_in_body - Vector2::new(2.0, 0.0)).norm() < 1e-12, "{:?}", e[0]);
        assert!((e[0].heading - (0.5 - std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
    }

    #[test]
    fn old_poses_are_extrapolated_then_dropped() {
        let mut t = BroadcastTable::default();
        t.update(pose(2, 1.0, 0.0, 0.0, 0.0, 1.0));
        let e = t.estimates(&gnss(1.2, -5.0, 0.0, 0.0), 0.5);
        assert!((e[0].pos_in_body.x - 5.2).abs() < 1e-12, "moved 0.2 m in 0.2 s");
        assert!((e[0].age_secs - 0.2).abs() < 1e-12);
        assert!(t.estimates(&gnss(1.6, 0.0, 0.0, 0.0), 0.5).is_empty(), "stale after 0.5 s");
    }

    #[test]
    fn older_pose_does_not_replace_newer() {
        let mut t = BroadcastTable::default();
        t.update(pose(2, 2.0, 5.0, 0.0, 0.0, 0.0));
        t.update(pose(2, 1.0, 9.0, 0.0, 0.0, 0.0));
        let e = t.estimates(&gnss(2.0, 0.0, 0.0, 0.0), 0.5);
        assert!((e[0].pos_in_body.x - 5.0).abs() < 1e-12);
    }
}
