//! The simulation state and its step, free of any IO: the hub's Zenoh loop calls
//! [`Sim::sensors_each`] for the live UAVs, collects commands, then [`Sim::step`]. Pure and
//! seeded, so a lockstep run with the same commands repeats exactly.
//!
//! This module is the step: commands in, integration, collisions, freezes and the end condition,
//! ground truth out. What goes out to the agents (each UAV's sensor frame, and the worker threads
//! that compute a large swarm's) is the `sensors` submodule's, so the threads stay apart from
//! the physics.
//!
//! Scale: every pairwise question (radio links, contacts, the UAVs a scan can hit, the nearest
//! other UAV) goes through one [`Grid`] of the positions rebuilt each tick.

mod sensors;

use crate::body::{Body, Limits};
use crate::forest::{scenario_trees, start_positions};
use crate::grid::Grid;
use crate::radio::Radio;
use crate::world::World;
use nalgebra::Vector2;
use sensors::UavRngs;
use swarm_config::{GoalRule, OnCollision, Scenario};
use swarm_types::{frame, Pose, SimTime, UavId};
use swarm_wire::{Clock, Cmd, CollisionEvent, EndReason, HubTiming, TruthBody, TruthStep, TruthWorld};

/// One tick's ground truth as the simulation knows it: every part of `truth/step` but the hub's
/// wall-clock timing of the tick, which only the node measures ([`Stepped::with_timing`] joins
/// the two into the message).
#[derive(Debug, Clone, PartialEq)]
pub struct Stepped {
    /// Tick just integrated.
    pub tick: u64,
    /// Sim time at the end of the tick [s].
    pub t_s: f64,
    /// Every body.
    pub bodies: Vec<TruthBody>,
    /// Collisions that began this tick.
    pub collisions: Vec<CollisionEvent>,
    /// Sim time the goal rule was first met, if it was.
    pub goal_reached_at: Option<f64>,
    /// Why the run ends here, on its last step.
    pub ended: Option<EndReason>,
    /// Wall seconds since tick 0.
    pub wall_s: f64,
}

impl Stepped {
    /// The `truth/step` message: this tick's truth and what it cost the hub.
    pub fn with_timing(self, timing: HubTiming) -> TruthStep {
        let Stepped { tick, t_s, bodies, collisions, goal_reached_at, ended, wall_s } = self;
        TruthStep { tick, t_s, bodies, collisions, goal_reached_at, ended, wall_s, timing: Box::new(timing) }
    }
}

/// The whole simulated world.
pub struct Sim {
    sc: Scenario,
    /// The run's netem timeline in force: the scenario's `[[netem]]` rules and failures, plus those
    /// `swarm netem` added while running. The sim reads its freezes; the node republishes it.
    timeline: netem::Timeline,
    world: World,
    bodies: Vec<Body>,
    /// Each UAV's start pose: the origin of its odometry frame.
    starts: Vec<Pose<frame::World>>,
    limits: Limits,
    radio: Radio,
    /// The positions of the current tick, indexed.
    grid: Grid,
    rngs: Vec<UavRngs>,
    last_cmds: Vec<Cmd>,
    obstacle_contact: Vec<bool>,
    /// `uav_contact[i]`: the j > i in contact with i, ascending.
    uav_contact: Vec<Vec<usize>>,
    /// Whether UAV i touches another UAV now.
    uav_colliding: Vec<bool>,
    tick: u64,
    dt: f64,
    goal_reached_at: Option<f64>,
    /// Since when the goal rule has held without a break [s].
    goal_since: Option<f64>,
}

impl Sim {
    /// Builds the world and the bodies of a scenario.
    pub fn new(sc: &Scenario) -> Sim {
        let world = World::new(scenario_trees(sc), sc.world.walls.clone());
        let yaw0 = sc.swarm.start_heading_deg.to_radians();
        let starts: Vec<Pose<frame::World>> = start_positions(sc).iter().map(|p| Pose::new(p[0], p[1], yaw0)).collect();
        let bodies = starts.iter().map(|s| Body::at(s.x, s.y, s.yaw)).collect();
        let n = sc.count();
        let mut radio = Radio::of(&sc.radio);
        let grid = Grid::new(&starts.iter().map(|s| [s.x, s.y]).collect::<Vec<_>>(), grid_cell_m(sc));
        radio.update_with(&grid);
        let hover = Cmd::hover(0);
        Sim {
            world,
            bodies,
            starts,
            limits: Limits {
                max_speed_mps: sc.body.max_speed_mps,
                max_accel_mps2: sc.body.max_accel_mps2,
                max_yaw_rate: sc.body.max_yaw_rate_dps.to_radians(),
            },
            radio,
            grid,
            rngs: sc.uav_ids().map(|id| UavRngs::of(sc.seed, id)).collect(),
            last_cmds: vec![hover; n],
            obstacle_contact: vec![false; n],
            uav_contact: vec![Vec::new(); n],
            uav_colliding: vec![false; n],
            tick: 0,
            dt: sc.dt_s(),
            goal_reached_at: None,
            goal_since: None,
            timeline: netem::Timeline::from_scenario(sc),
            sc: sc.clone(),
        }
    }

    /// Current tick.
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Sim time of the current tick [s].
    pub fn t_s(&self) -> f64 {
        SimTime::of_tick(self.tick, self.dt).s()
    }

    /// The clock message of the current tick.
    pub fn clock(&self) -> Clock {
        Clock { tick: self.tick, t_s: self.t_s(), dt_s: self.dt }
    }

    /// Bodies, index = id − 1.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// The static world as a message for the recorder.
    pub fn truth_world(&self) -> TruthWorld {
        TruthWorld {
            trees: self.world.trees().iter().map(|t| [t.x, t.y, t.r]).collect(),
            walls: self.world.walls().iter().map(|w| [w.x1, w.y1, w.x2, w.y2, w.thickness]).collect(),
            starts: self.starts.iter().map(|s| [s.x, s.y, s.yaw]).collect(),
            goal: self.sc.swarm.goal,
            body_radius_m: self.sc.body.radius_m,
        }
    }

    /// Adds a timeline (from `swarm netem`, times already in sim time) to the one in force.
    pub fn extend_timeline(&mut self, added: swarm_config::Timeline) {
        self.timeline.extend(added);
    }

    /// The netem timeline in force.
    pub fn timeline(&self) -> &netem::Timeline {
        &self.timeline
    }

    /// Integrates one tick. `cmds[i]` is UAV i+1's command for this tick, `None` when it did not
    /// answer in time (it keeps its last command). `alive[i]` is whether its agent holds a
    /// liveliness token: a UAV whose agent lost it (killed, or cut off by the network) hovers where
    /// it is, as the agent itself commands when it loses the hub, a command that cannot cross a
    /// cut link.
    pub fn step(&mut self, cmds: &[Option<Cmd>], alive: &[bool], wall_s: f64) -> Stepped {
        let t_now = self.t_s();
        for (i, b) in self.bodies.iter_mut().enumerate() {
            if self.timeline.frozen_at(UavId::from_index(i), t_now) {
                // A frozen UAV hovers where it is, whatever its agent says (seed 000 6.2).
                self.last_cmds[i] = Cmd::hover(self.tick);
            } else if !alive.get(i).copied().unwrap_or(true) {
                self.last_cmds[i] = Cmd::hover(self.tick);
            } else if let Some(Some(c)) = cmds.get(i) {
                self.last_cmds[i] = *c;
            }
            b.step(&self.last_cmds[i], &self.limits, self.dt);
        }
        self.tick += 1;
        let t_s = self.t_s();
        let positions: Vec<[f64; 2]> = self.bodies.iter().map(|b| [b.pos.x, b.pos.y]).collect();
        self.grid = Grid::new(&positions, grid_cell_m(&self.sc));
        self.radio.update_with(&self.grid);
        let collisions = self.detect_collisions();
        self.goal_since = if self.goal_met() { self.goal_since.or(Some(t_s)) } else { None };
        // The goal counts once its rule has held for `end.hold_s` (0: at once), from the start
        // of that streak.
        if self.goal_reached_at.is_none() && self.goal_since.is_some_and(|s| t_s - s >= self.sc.end.hold_s - 1e-9) {
            self.goal_reached_at = self.goal_since;
        }
        let ended = if self.goal_reached_at.is_some() {
            Some(EndReason::Goal)
        } else if t_s >= self.sc.end.time_limit_s - 1e-9 {
            Some(EndReason::TimeLimit)
        } else {
            None
        };
        self.observe(cmds, alive, collisions, ended, wall_s)
    }

    /// Ground truth of the current state, without integrating (also the hub's last word when a
    /// run is stopped, with the reason it ended).
    pub fn observe(
        &self,
        cmds: &[Option<Cmd>],
        alive: &[bool],
        collisions: Vec<CollisionEvent>,
        ended: Option<EndReason>,
        wall_s: f64,
    ) -> Stepped {
        Stepped {
            tick: self.tick,
            t_s: self.t_s(),
            bodies: self.truth_bodies(cmds, alive),
            collisions,
            goal_reached_at: self.goal_reached_at,
            ended,
            wall_s,
        }
    }

    fn truth_bodies(&self, cmds: &[Option<Cmd>], alive: &[bool]) -> Vec<TruthBody> {
        self.bodies
            .iter()
            .enumerate()
            .map(|(i, b)| TruthBody {
                id: UavId::from_index(i),
                x: b.pos.x,
                y: b.pos.y,
                yaw: b.yaw,
                vx: b.vel.x,
                vy: b.vel.y,
                alive: alive.get(i).copied().unwrap_or(false),
                cmd_on_time: matches!(cmds.get(i), Some(Some(_))),
                obstacle_distance_m: self.world.clearance([b.pos.x, b.pos.y]),
                agent_distance_m: self.nearest_agent_distance(i),
                colliding: self.obstacle_contact[i] || self.uav_colliding[i],
            })
            .collect()
    }

    fn nearest_agent_distance(&self, i: usize) -> f64 {
        let p = self.bodies[i].pos;
        self.grid.nearest(i, |j| (self.bodies[j].pos - p).norm())
    }

    /// UAV–obstacle contact when the centre is closer than r_uav to an obstacle surface; UAV–UAV
    /// when centres are closer than 2·r_uav (SPEC section 2). Reports contacts that began now.
    fn detect_collisions(&mut self) -> Vec<CollisionEvent> {
        let r = self.sc.body.radius_m;
        let n = self.bodies.len();
        let mut events = Vec::new();
        self.uav_colliding = vec![false; n];
        for i in 0..n {
            let p = self.bodies[i].pos;
            let hit = self.world.clearance([p.x, p.y]) < r;
            if hit && !self.obstacle_contact[i] {
                events.push(CollisionEvent { id: UavId::from_index(i), other_uav: None, x: p.x, y: p.y });
            }
            self.obstacle_contact[i] = hit;
            // Only the pairs the grid puts near can touch; the others are out of contact.
            let mut touching = Vec::new();
            for j in self.grid.near_sorted(i, 2.0 * r).into_iter().filter(|&j| j > i) {
                let hit = (self.bodies[j].pos - p).norm() < 2.0 * r;
                if hit && self.uav_contact[i].binary_search(&j).is_err() {
                    events.push(CollisionEvent {
                        id: UavId::from_index(i),
                        other_uav: Some(UavId::from_index(j)),
                        x: p.x,
                        y: p.y,
                    });
                }
                if hit {
                    touching.push(j);
                    self.uav_colliding[i] = true;
                    self.uav_colliding[j] = true;
                }
            }
            self.uav_contact[i] = touching;
        }
        if self.sc.body.on_collision == OnCollision::Stop {
            for e in &events {
                self.bodies[e.id.index()].stopped = true;
                if let Some(o) = e.other_uav {
                    self.bodies[o.index()].stopped = true;
                }
            }
        }
        events
    }

    fn goal_met(&self) -> bool {
        let g = Vector2::new(self.sc.swarm.goal[0], self.sc.swarm.goal[1]);
        let r = self.sc.end.goal_radius_m;
        // Failed UAVs (no agent) and frozen ones are not part of the swarm that has to arrive.
        let t = self.t_s();
        let flying: Vec<Vector2<f64>> = self
            .sc
            .agent_ids()
            .filter(|&id| !self.timeline.frozen_at(id, t))
            .map(|id| self.bodies[id.index()].pos)
            .collect();
        match self.sc.end.goal_rule {
            GoalRule::All => flying.iter().all(|p| (p - g).norm() <= r),
            GoalRule::Centroid => {
                let c = flying.iter().sum::<Vector2<f64>>() / flying.len().max(1) as f64;
                (c - g).norm() <= r
            }
        }
    }
}

/// The grid's cell side [m]: half the radio's reach, the widest question asked of it each tick
/// besides the scan, at least a UAV's diameter.
fn grid_cell_m(sc: &Scenario) -> f64 {
    (0.5 * (sc.radio.range_m + sc.radio.hysteresis_m)).max(2.0 * sc.body.radius_m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_wire::CmdKind;

    pub(super) fn scenario() -> Scenario {
        Scenario::from_toml_str(
            r#"
name = "t"
[world]
trees = [{ x = 5.0, y = 0.0, r = 0.5 }]
[swarm]
count = 2
start_positions = [[0.0, 0.0], [0.0, 3.0]]
start_heading_deg = 90.0
goal = [10.0, 0.0]
informed = [1]
[end]
goal_radius_m = 1.0
time_limit_s = 1.0
"#,
            "t.toml",
        )
        .expect("valid")
    }

    pub(super) fn vel(x: f32) -> Option<Cmd> {
        Some(Cmd { tick: 0, kind: CmdKind::Velocity, x, y: 0.0, yaw_rate: 0.0 })
    }

    #[test]
    fn collisions_are_counted_once_per_contact_and_time_limit_ends() {
        let mut sc = scenario();
        sc.swarm.start_positions = Some(vec![[4.3, 0.0], [0.0, 3.0]]);
        let mut sim = Sim::new(&sc);
        let s = sim.step(&[vel(0.0), vel(0.0)], &[true, true], 0.0);
        assert_eq!(s.collisions.len(), 1, "clearance 0.2 < r 0.3");
        assert_eq!(s.collisions[0].other_uav, None);
        assert!(s.bodies[0].colliding);
        let s = sim.step(&[vel(0.0), vel(0.0)], &[true, true], 0.0);
        assert!(s.collisions.is_empty(), "same contact is not counted twice");
        let mut last = s;
        while last.ended.is_none() {
            last = sim.step(&[None, None], &[false, false], 0.0);
        }
        assert_eq!(last.ended, Some(EndReason::TimeLimit));
        assert_eq!(last.tick, 10);
    }

    #[test]
    fn a_frozen_uav_hovers_whatever_its_agent_says() {
        let mut sc = scenario();
        sc.failures =
            vec![swarm_config::Failure { at_s: 0.5, uav: UavId::new(1), kind: swarm_config::FailureKind::Freeze }];
        let mut sim = Sim::new(&sc);
        for _ in 0..5 {
            sim.step(&[vel(0.5), vel(0.0)], &[true, true], 0.0);
        }
        assert!(sim.bodies()[0].vel.norm() > 0.4, "flies until it freezes");
        for _ in 0..20 {
            sim.step(&[vel(0.5), vel(0.0)], &[true, true], 0.0);
        }
        assert!(sim.bodies()[0].vel.norm() < 1e-9, "frozen: hovers");
    }

    #[test]
    fn missing_command_keeps_the_last_one() {
        let mut sim = Sim::new(&scenario());
        for _ in 0..10 {
            sim.step(&[vel(0.5), vel(0.0)], &[true, true], 0.0);
        }
        let before = sim.bodies()[0].vel;
        sim.step(&[None, vel(0.0)], &[true, true], 0.0);
        assert!((sim.bodies()[0].vel - before).norm() < 1e-12, "keeps flying its last command");
    }

    #[test]
    fn a_uav_whose_agent_lost_its_token_hovers() {
        let mut sim = Sim::new(&scenario());
        for _ in 0..10 {
            sim.step(&[vel(0.5), vel(0.0)], &[true, true], 0.0);
        }
        assert!(sim.bodies()[0].vel.norm() > 0.4, "flies while its agent is alive");
        for _ in 0..10 {
            sim.step(&[vel(0.5), vel(0.0)], &[false, true], 0.0);
        }
        assert!(sim.bodies()[0].vel.norm() < 1e-9, "hovers once its agent is gone, whatever arrives");
    }
}
