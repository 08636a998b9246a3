//! The `broadcast` localization mode (SPEC section 5, seed 001 3.4): every agent sends its
//! GNSS-like world pose to its neighbours; the receiver subtracts its own, and expresses the
//! neighbour in its body frame. The newest pose of each sender is kept, extrapolated by its
//! velocity over its age, and dropped once older than `stale_after_s`. Without its own fix this
//! tick an agent can place nobody, and shares nothing.

use super::Share;
use crate::geometry::wrap_angle;
use crate::sensing::SensorFrame;
use crate::world_model::Estimate;
use nalgebra::{Rotation2, Vector2};
use std::collections::BTreeMap;
use swarm_types::UavId;
use swarm_wire::{Gnss, PoseShare};

/// The `broadcast` localizer: the table of poses heard, and what it shares.
#[derive(Debug)]
pub(crate) struct Broadcast {
    id: UavId,
    stale_after_s: f64,
    table: BroadcastTable,
}

impl Broadcast {
    /// The localizer of UAV `id`, forgetting poses older than `stale_after_s`.
    pub(crate) fn new(id: UavId, stale_after_s: f64) -> Broadcast {
        Broadcast { id, stale_after_s, table: BroadcastTable::default() }
    }

    /// Keeps a neighbour's pose (our own echo and obstacle sets are ignored).
    pub(crate) fn receive(&mut self, share: &Share) {
        match share {
            Share::Pose(p) if p.from != self.id => self.table.update(*p),
            _ => {}
        }
    }

    /// The neighbours, placed relative to this tick's own fix.
    pub(crate) fn estimates(&mut self, frame: &SensorFrame) -> Vec<Estimate> {
        match &frame.gnss {
            Some(g) => self.table.estimates(g, self.stale_after_s),
            // Without its own fix a broadcast agent cannot place anyone: fly on obstacles alone.
            None => Vec::new(),
        }
    }

    /// This tick's own fix, as a pose share.
    pub(crate) fn share(&self, frame: &SensorFrame) -> Option<Share> {
        frame.gnss.as_ref().map(|g| Share::Pose(pose_share(self.id, g)))
    }
}

/// What UAV `from` tells its neighbours of its fix `g`: the same pose, signed.
pub(crate) fn pose_share(from: UavId, g: &Gnss) -> PoseShare {
    PoseShare {
        from,
        tick: g.tick,
        t_s: g.t_s,
        x: g.x,
        y: g.y,
        yaw: g.yaw,
        vx: g.vx,
        vy: g.vy,
        hops: swarm_wire::NO_PATH,
        arrival: swarm_wire::NO_PATH,
    }
}

/// Newest broadcast pose per neighbour.
#[derive(Debug, Default)]
struct BroadcastTable {
    poses: BTreeMap<UavId, PoseShare>,
}

impl BroadcastTable {
    /// Keeps `p` if it is newer than what we hold for its sender.
    fn update(&mut self, p: PoseShare) {
        let newer = self.poses.get(&p.from).is_none_or(|old| p.t_s > old.t_s);
        if newer {
            self.poses.insert(p.from, p);
        }
    }

    /// Estimates of every neighbour heard from within `stale_after_s`, in the body frame of `own`.
    fn estimates(&mut self, own: &Gnss, stale_after_s: f64) -> Vec<Estimate> {
        let now = own.t_s;
        self.poses.retain(|_, p| now - p.t_s <= stale_after_s + 1e-9);
        let body_from_world = Rotation2::new(-own.yaw);
        let own_pos = Vector2::new(own.x, own.y);
        self.poses
            .values()
            .map(|p| {
                let age = (now - p.t_s).max(0.0);
                let pos_now = Vector2::new(p.x, p.y) + Vector2::new(p.vx, p.vy) * age;
                Estimate {
                    id: Some(p.from),
                    pos_in_body: body_from_world * (pos_now - own_pos),
                    heading: wrap_angle(p.yaw - own.yaw),
                    age_s: age,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gnss(t: f64, x: f64, y: f64, yaw: f64) -> Gnss {
        Gnss { tick: 0, t_s: t, x, y, yaw, vx: 0.0, vy: 0.0 }
    }

    fn pose(from: UavId, t: f64, x: f64, y: f64, yaw: f64, vx: f64) -> PoseShare {
        PoseShare { from, tick: 0, t_s: t, x, y, yaw, vx, vy: 0.0, hops: 0, arrival: 0 }
    }

    #[test]
    fn neighbour_is_expressed_in_the_body_frame() {
        let mut t = BroadcastTable::default();
        t.update(pose(UavId::new(2), 1.0, 1.0, 3.0, 0.5, 0.0));
        // Own pose (1, 1) facing +y: the neighbour 2 m ahead is at body (2, 0).
        let e = t.estimates(&gnss(1.0, 1.0, 1.0, std::f64::consts::FRAC_PI_2), 0.5);
        assert_eq!(e.len(), 1);
        assert!((e[0].pos_in_body - Vector2::new(2.0, 0.0)).norm() < 1e-12, "{:?}", e[0]);
        assert!((e[0].heading - (0.5 - std::f64::consts::FRAC_PI_2)).abs() < 1e-12);
    }

    #[test]
    fn old_poses_are_extrapolated_then_dropped() {
        let mut t = BroadcastTable::default();
        t.update(pose(UavId::new(2), 1.0, 0.0, 0.0, 0.0, 1.0));
        let e = t.estimates(&gnss(1.2, -5.0, 0.0, 0.0), 0.5);
        assert!((e[0].pos_in_body.x - 5.2).abs() < 1e-12, "moved 0.2 m in 0.2 s");
        assert!((e[0].age_s - 0.2).abs() < 1e-12);
        assert!(t.estimates(&gnss(1.6, 0.0, 0.0, 0.0), 0.5).is_empty(), "stale after 0.5 s");
    }

    #[test]
    fn the_share_is_the_fix_signed_by_its_sender() {
        let g = Gnss { tick: 3, t_s: 0.3, x: 1.0, y: 2.0, yaw: 0.5, vx: 0.1, vy: -0.1 };
        let p = pose_share(UavId::new(4), &g);
        assert_eq!(
            p,
            PoseShare {
                from: UavId::new(4),
                tick: 3,
                t_s: 0.3,
                x: 1.0,
                y: 2.0,
                yaw: 0.5,
                vx: 0.1,
                vy: -0.1,
                hops: swarm_wire::NO_PATH,
                arrival: swarm_wire::NO_PATH
            }
        );
    }

    #[test]
    fn older_pose_does_not_replace_newer() {
        let mut t = BroadcastTable::default();
        t.update(pose(UavId::new(2), 2.0, 5.0, 0.0, 0.0, 0.0));
        t.update(pose(UavId::new(2), 1.0, 9.0, 0.0, 0.0, 0.0));
        let e = t.estimates(&gnss(2.0, 0.0, 0.0, 0.0), 0.5);
        assert!((e[0].pos_in_body.x - 5.0).abs() < 1e-12);
    }
}
