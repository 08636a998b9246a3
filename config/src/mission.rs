//! Where each UAV's goal is at a sim time: the `[[mission]]` timeline over `swarm.goal` (or
//! M23's goal per UAV), moving goals included. Kept apart from the checks because it is what a
//! running hub asks of the scenario every tick (an informed UAV's goal in its odometry).

use crate::{ControllerKind, Scenario, UavId};

impl Scenario {
    /// The goal UAV `id` flies to at sim time `t`: the latest `mission` change covering it, else
    /// `swarm.goal`.
    pub fn goal_of(&self, id: UavId, t: f64) -> [f64; 2] {
        self.goal_motion_of(id, t).0
    }

    /// UAV `id`'s goal before any mission: `swarm.goal`, or its own one of `controller.m23.goals`
    /// (seed 004 Table 7) when M23 flies.
    fn static_goal_of(&self, id: UavId) -> [f64; 2] {
        match self.controller.kind {
            ControllerKind::M23 => self.controller.m23.goal_of(id, self.swarm.goal),
            _ => self.swarm.goal,
        }
    }

    /// The goal of UAV `id` at sim time `t` and its velocity: a moving `mission` goal has moved
    /// by `velocity_mps · (t − at_s)`.
    pub fn goal_motion_of(&self, id: UavId, t: f64) -> ([f64; 2], [f64; 2]) {
        self.mission
            .iter()
            .filter(|m| m.at_s <= t + 1e-9 && m.uavs.contains(id))
            .max_by(|a, b| a.at_s.total_cmp(&b.at_s))
            .map_or((self.static_goal_of(id), [0.0, 0.0]), |m| {
                let [vx, vy] = m.velocity_mps;
                let dt = t - m.at_s;
                ([m.goal[0] + vx * dt, m.goal[1] + vy * dt], m.velocity_mps)
            })
    }
}
