//! The pilots of the built-in controllers: each a [`Controller`] that runs one control step of
//! its seed's controller, from what perception and localization made of this tick to a command
//! for the hub.
//!
//! Why a module of its own: the controllers ([`k21`], [`p17`], [`a21`], [`m23`]) are pure
//! functions of their seeds' inputs, each in its own frame and units. A pilot owns what its
//! controller keeps between steps (P17's previous velocity and its neighbours' velocity tracker,
//! A21's occupancy grid and planned path, M23's costmap) and does the conversions, so the
//! agent's step stays one readable pipeline.
//!
//! Frames: perception and localization give everything in the body frame. K21 and A21 work in
//! it; P17 works in the agent's odometry frame (its steering update integrates velocities, which
//! must not turn with the body), and A21's planner too (the grid is a map). Commands go out in
//! the body frame.
//!
//! Choices where the seeds are silent:
//! - P17 and A21 do not steer the heading (seed 003 holds a constant desired heading; seed 001's
//!   equations have no yaw): their yaw rate is 0. The LIDAR sees all around, so nothing is lost.
//! - P17 neighbour velocities come from position differences of identified neighbours (seed 001
//!   eq. 9); an anonymous neighbour (`identify = "scan"` in ICP mode) counts with velocity 0.
//! - P17 walls are the segments perception extracts (the visible face, thickness 0); its
//!   cylinders are the circles that are not a localized neighbour.
//! - A21's collision term takes the scan points within `dr` that are not a localized neighbour
//!   (seed 003 computes it from its map, whose occupied cells are laser hits). A21 plans on its own
//!   occupancy grid every `replan_period_s` with the heuristic of seed 003 IV-C, unknown = free,
//!   and subtracts `damping_per_s`·v from eq. 1's acceleration (the seed's tracker damps; ours
//!   is a bare double integrator).

use super::controller::{Command, Controller, View};
use super::detour::Detour;
use super::m23::{self, FollowerInput, LeaderWait, UavState};
use super::neighbour_velocity::VelocityTracker;
use super::{a21, k21, p17};
use crate::geometry::{wrap_angle, Pose2};
use crate::planning::{
    CostQuery, Costmap, GridParams, Heuristic, OccupancyGrid, PlanParams, SocialAgent, LETHAL_OBSTACLE,
};
use crate::world_model::Estimate;
use nalgebra::{Point2, Rotation2, Vector2};
use std::sync::Arc;
use swarm_config::Scenario;
use swarm_wire::{CmdKind, Odom, VectorMagnitudes};

/// K21 (seed 000 chapter 4): the seed's controller keeps nothing between steps; our opt-in
/// detour remembers how long the barrier has held the UAV.
#[derive(Debug)]
pub struct K21Pilot {
    params: swarm_config::K21Params,
    detour: Detour,
}

impl K21Pilot {
    pub(super) fn new(sc: &Scenario) -> K21Pilot {
        K21Pilot { params: sc.controller.k21.clone(), detour: Detour::new() }
    }
}

impl Controller for K21Pilot {
    fn step(&mut self, v: &View) -> Command {
        k21_command(&self.params, v, v.neighbours, goal_heading(v.odom), &[], &mut self.detour)
    }
}

/// P17 (seed 001 chapter 3): its previous velocity and its neighbours' velocity tracker.
#[derive(Debug)]
pub struct P17Pilot {
    values: swarm_config::P17Values,
    /// v[t−1] of seed 001 eq. 40 [m/s], odometry frame.
    prev_vel: Vector2<f64>,
    /// Neighbour velocities from position differences (eq. 9).
    tracker: VelocityTracker,
}

impl P17Pilot {
    pub(super) fn new(sc: &Scenario) -> P17Pilot {
        P17Pilot {
            values: sc.controller.p17.values(),
            prev_vel: Vector2::zeros(),
            tracker: VelocityTracker::new(sc.localization.stale_after_s),
        }
    }
}

impl Controller for P17Pilot {
    fn step(&mut self, v: &View) -> Command {
        fly_p17(&self.values, v, &mut self.prev_vel, &mut self.tracker)
    }
}

/// A21 (seed 003 section III): the map from its own scans and the path planned on it.
#[derive(Debug)]
pub struct A21Pilot {
    params: swarm_config::A21Params,
    /// The map built from its own scans (seed 003 IV-C).
    grid: Box<OccupancyGrid>,
    /// The current path to the goal, odometry frame.
    path: Vec<Point2<f64>>,
    /// When it was planned [s].
    planned_at: Option<f64>,
    /// The control period [s]: how long a command lasts.
    period_s: f64,
    /// The fastest it flies [m/s]: its own cap, else the body's.
    top_speed_mps: f64,
}

impl A21Pilot {
    pub(super) fn new(sc: &Scenario) -> A21Pilot {
        let a = &sc.controller.a21;
        let grid = GridParams {
            resolution_m: a.grid_resolution_m,
            max_range_m: sc.lidar.max_range_m,
            ..GridParams::default()
        };
        let period_s = 1.0 / sc.time.control_hz;
        // A swarm of one has no flock to wait for (`phi_alone`'s reason): it flies its path.
        let params = if sc.count() == 1 { swarm_config::A21Params { phi_alone: 1.0, ..a.clone() } } else { a.clone() };
        let top_speed_mps = a.max_speed_mps.unwrap_or(sc.body.max_speed_mps);
        A21Pilot {
            params,
            grid: Box::new(OccupancyGrid::new(grid)),
            path: Vec::new(),
            planned_at: None,
            period_s,
            top_speed_mps,
        }
    }
}

impl Controller for A21Pilot {
    fn step(&mut self, v: &View) -> Command {
        let limits = (self.period_s, self.top_speed_mps);
        let cmd = fly_a21(&self.params, v, &mut self.grid, &mut self.path, &mut self.planned_at, limits);
        match self.params.max_speed_mps {
            Some(cap) => capped(cmd, v.odom, cap, self.period_s),
            None => cmd,
        }
    }

    fn wants_scan_points(&self) -> bool {
        true
    }
}

/// The goal's bearing in the body frame (seed 000 eq. 4.15 minus own heading).
fn goal_heading(odom: &Odom) -> Option<f64> {
    odom.goal.map(|g| bearing_in_body(odom, g))
}

/// The bearing of `target` (odometry frame) in the body frame [rad].
pub(super) fn bearing_in_body(odom: &Odom, target: [f64; 2]) -> f64 {
    wrap_angle((target[1] - odom.y).atan2(target[0] - odom.x) - odom.yaw)
}

/// One K21 step on `neighbours`, the view's trees plus `more_obstacles` (body frame), towards
/// `goal_heading` (body frame), out of a shut gap by `detour` (when the scenario turns it on):
/// the flock's step, and the lost-contact and arrival layers' flights.
pub(super) fn k21_command(
    p: &swarm_config::K21Params,
    v: &View,
    neighbours: &[Estimate],
    goal_heading: Option<f64>,
    more_obstacles: &[Vector2<f64>],
    detour: &mut Detour,
) -> Command {
    let neighbours: Vec<k21::Neighbour> =
        neighbours.iter().map(|e| k21::Neighbour { pos: e.pos_in_body, heading: e.heading }).collect();
    let obstacles: Vec<Vector2<f64>> =
        v.trees.iter().map(|c| c.center.coords).chain(more_obstacles.iter().copied()).collect();
    let input = k21::Input { neighbours: &neighbours, obstacles: &obstacles, goal_heading, bodies: v.near_bodies };
    let mut out = k21::step(p, &input);
    if p.detour_after_s > 0.0 {
        out.velocity = detour.steer(p, v.t_s, v.odom.yaw, &out, || k21::barrier_points(p, &input));
    }
    Command {
        kind: CmdKind::Velocity,
        xy: out.velocity,
        yaw_rate: out.yaw_rate,
        vectors: VectorMagnitudes {
            cohesion: out.cohesion.norm() as f32,
            separation: out.separation.norm() as f32,
            avoidance: out.avoidance.norm() as f32,
            navigation: out.navigation.norm() as f32,
            output: out.velocity.norm() as f32,
        },
    }
}

/// Own pose in the odometry frame: position and the rotation body → odometry.
fn pose(odom: &Odom) -> (Vector2<f64>, Rotation2<f64>) {
    (Vector2::new(odom.x, odom.y), Rotation2::new(odom.yaw))
}

fn fly_p17(
    values: &swarm_config::P17Values,
    v: &View,
    prev_vel: &mut Vector2<f64>,
    tracker: &mut VelocityTracker,
) -> Command {
    let (p0, rot) = pose(v.odom);
    let to_odom = |b: Vector2<f64>| p0 + rot * b;
    tracker.forget_stale(v.t_s);
    let neighbours: Vec<p17::Neighbour> = v
        .neighbours
        .iter()
        .map(|e| {
            let pos = to_odom(e.pos_in_body);
            // seed 001 eq. 9: a neighbour's velocity from its position differences.
            let vel = e.id.and_then(|id| tracker.update(id, pos, v.t_s - e.age_s)).unwrap_or_else(Vector2::zeros);
            p17::Neighbour { pos, vel_mps: vel }
        })
        .collect();
    let cylinders: Vec<p17::Cylinder> =
        v.trees.iter().map(|c| p17::Cylinder { centre: to_odom(c.center.coords), radius_m: c.radius }).collect();
    let walls: Vec<p17::Wall> = v
        .walls
        .iter()
        .map(|s| p17::Wall { a: to_odom(s.a.coords), b: to_odom(s.b.coords), thickness_m: 0.0 })
        .collect();
    // seed 001 eq. 38 (static goal) or eq. 39 (a goal that moves).
    let goal = v.odom.goal.map(|g| {
        let pos = Vector2::new(g[0], g[1]);
        match v.odom.goal_vel {
            Some([vx, vy]) => p17::Goal::Dynamic { pos, vel_mps: Vector2::new(vx, vy) },
            None => p17::Goal::Static { pos },
        }
    });
    let out = p17::step(
        values,
        &p17::Input {
            pos: p0,
            prev_vel_mps: *prev_vel,
            neighbours: &neighbours,
            cylinders: &cylinders,
            walls: &walls,
            goal,
        },
    );
    *prev_vel = out.velocity_mps;
    let f = &out.forces;
    odom_velocity(
        rot,
        out.velocity_mps,
        VectorMagnitudes {
            cohesion: f.cohesion.norm() as f32,
            separation: f.separation.norm() as f32,
            avoidance: (f.avoidance_separation + f.avoidance_alignment).norm() as f32,
            navigation: f.navigation.norm() as f32,
            output: out.velocity_mps.norm() as f32,
        },
    )
}

/// A velocity command from a velocity in the odometry frame, with no heading control.
fn odom_velocity(rot: Rotation2<f64>, vel: Vector2<f64>, vectors: VectorMagnitudes) -> Command {
    Command { kind: CmdKind::Velocity, xy: rot.inverse() * vel, yaw_rate: 0.0, vectors }
}

fn fly_a21(
    a: &swarm_config::A21Params,
    v: &View,
    grid: &mut OccupancyGrid,
    path: &mut Vec<Point2<f64>>,
    planned_at: &mut Option<f64>,
    (period_s, top_speed_mps): (f64, f64),
) -> Command {
    let (p0, rot) = pose(v.odom);
    grid.update(Pose2::new(p0.x, p0.y, v.odom.yaw), v.static_points);
    let direction = v.odom.goal.and_then(|g| {
        let due = planned_at.is_none_or(|t| v.t_s - t >= a.replan_period_s - 1e-9);
        if due {
            let params =
                PlanParams { heuristic: Heuristic::A21, inflation_radius_m: a.inflation_m, ..PlanParams::default() };
            *path = grid.plan(Point2::from(p0), Point2::new(g[0], g[1]), &params).map(|p| p.points).unwrap_or_default();
            *planned_at = Some(v.t_s);
        }
        // seed 003 eq. 7: x̂ⁿ along the path, turned into the body frame.
        a21::navigation_direction(path, Point2::from(p0), a.path_lookahead_m).map(|d| rot.inverse() * d)
    });
    let neighbours: Vec<Vector2<f64>> = v.neighbours.iter().map(|e| e.pos_in_body).collect();
    let obstacle_points: Vec<Vector2<f64>> =
        v.static_points.iter().map(|p| p.coords).filter(|p| p.norm() <= a.dr_m).collect();
    let input = a21::Input { neighbours: &neighbours, obstacle_points: &obstacle_points, path_direction: direction };
    let out = a21::step(a, &input);
    // The damping the seed's trajectory tracker provides (see `A21Params::damping_per_s`).
    let vel_body = rot.inverse() * Vector2::new(v.odom.vx, v.odom.vy);
    let mut acceleration = out.acceleration - a.damping_per_s * vel_body;
    if a.safety {
        // The safety layer holds the velocity this command reaches by the period's end.
        let reached = vel_body + acceleration * period_s;
        acceleration = (a21::safe_velocity(a, reached, &input, top_speed_mps) - vel_body) / period_s;
    }
    Command {
        kind: CmdKind::Acceleration,
        xy: acceleration,
        yaw_rate: 0.0,
        vectors: VectorMagnitudes {
            cohesion: out.proximal.norm() as f32,
            separation: 0.0,
            avoidance: out.collision.norm() as f32,
            navigation: out.navigation.norm() as f32,
            output: acceleration.norm() as f32,
        },
    }
}

/// `cmd` (an acceleration) cut so that the velocity it reaches by the end of the control period
/// is at most `cap` [m/s]: a' = (clamp(v + a·T, cap) − v) / T, body frame.
fn capped(mut cmd: Command, odom: &Odom, cap: f64, period_s: f64) -> Command {
    let (_, rot) = pose(odom);
    let v = rot.inverse() * Vector2::new(odom.vx, odom.vy);
    let reached = v + cmd.xy * period_s;
    if reached.norm() > cap {
        cmd.xy = (reached * (cap / reached.norm()) - v) / period_s;
        cmd.vectors.output = cmd.xy.norm() as f32;
    }
    cmd
}

/// M23 (seed 004 chapter 3): a costmap from the agent's own scans with its neighbours as social
/// costs, a formation goal from the topology (validated against the costmap), an A* path on the
/// costmap, the reduced-DWA tracker, and the leader's wait. Everything is in the odometry frame;
/// with the common start heading of a scenario its axes are the world's, so LF offsets given in
/// the world frame apply as they are. Followers learn where the leader is only from their
/// neighbour estimates, so the network's faults reach the formation too.
#[derive(Debug)]
pub struct M23Pilot {
    sc: Arc<Scenario>,
    costmap: Costmap,
    wait: LeaderWait,
    tracker: VelocityTracker,
    goal: Option<Point2<f64>>,
    goal_at: Option<f64>,
    path: Vec<Point2<f64>>,
}

impl M23Pilot {
    pub(super) fn new(sc: &Scenario) -> M23Pilot {
        M23Pilot {
            sc: Arc::new(sc.clone()),
            costmap: Costmap::new(&sc.controller.m23.costmap),
            wait: LeaderWait::default(),
            tracker: VelocityTracker::new(sc.localization.stale_after_s),
            goal: None,
            goal_at: None,
            path: Vec::new(),
        }
    }

    fn fly(&mut self, v: &View) -> Command {
        let sc = &Arc::clone(&self.sc);
        let p = &sc.controller.m23;
        let (p0, rot) = pose(v.odom);
        let me_id = v.id;
        // The map: the static scan points (a neighbour's hits would leave a trail of lethal cells
        // behind it), and the neighbours as social costs (seed 004 eq. 11).
        self.costmap.update(Pose2::new(p0.x, p0.y, v.odom.yaw), v.static_points);
        self.tracker.forget_stale(v.t_s);
        let mut known = Vec::new();
        let mut social = Vec::new();
        for e in v.neighbours {
            let pos = p0 + rot * e.pos_in_body;
            let vel = e.id.and_then(|id| self.tracker.update(id, pos, v.t_s - e.age_s)).unwrap_or_else(Vector2::zeros);
            social.push(SocialAgent { position: Point2::from(pos), velocity: vel });
            if let Some(id) = e.id {
                known.push(UavState { id, position: Point2::from(pos), heading: v.odom.yaw + e.heading });
            }
        }
        self.costmap.set_neighbours(&social);
        let me = UavState { id: me_id, position: Point2::from(p0), heading: v.odom.yaw };
        let own_goal = v.odom.goal.map(|g| Point2::new(g[0], g[1]));
        let hold = self.leader_holds(sc, v.t_s, &me, &known);
        self.update_goal(sc, v.t_s, &me, &known, own_goal);
        let path: &[Point2<f64>] = if hold { &[] } else { &self.path };
        let vel_odom = Vector2::new(v.odom.vx, v.odom.vy);
        // The tracker sees the neighbours where they are now as lethal discs, as seed 004's local
        // planner saw them in its LIDAR's obstacle layer.
        let others = social.iter().map(|a| a.position);
        let costs =
            WithNeighbours::new(&self.costmap, others, Point2::from(p0), 2.0 * sc.body.radius_m + NEIGHBOUR_MARGIN_M);
        let out = m23::track(path, Point2::from(p0), vel_odom, sc.dt_s(), &costs, p);
        let speed = out.velocity.norm() as f32;
        odom_velocity(
            rot,
            out.velocity,
            VectorMagnitudes { navigation: speed, output: speed, ..VectorMagnitudes::default() },
        )
    }

    /// The leader's wait (seed 004 Fig. 38): while a follower is farther than MAX_DISTANCE, at
    /// most MAX_TIME. `None` (not every follower known) lets the timer decide.
    fn leader_holds(&mut self, sc: &Scenario, t: f64, me: &UavState, known: &[UavState]) -> bool {
        let p = &sc.controller.m23;
        if p.topology == swarm_config::Topology::None || me.id != p.leader_id {
            return false;
        }
        let followers: Vec<Point2<f64>> = known.iter().map(|u| u.position).collect();
        let all_known = known.len() + 1 >= sc.agent_ids().count();
        let far = m23::any_follower_far(me.position, &followers, p.max_distance_m);
        self.wait.step(t, (all_known || far).then_some(far), p)
    }

    /// Every `goal_period_s`: the goal (seed 004 Fig. 40) and a new A* path on the costmap.
    fn update_goal(&mut self, sc: &Scenario, t: f64, me: &UavState, known: &[UavState], own_goal: Option<Point2<f64>>) {
        let p = &sc.controller.m23;
        if self.goal_at.is_some_and(|g| t - g < p.goal_period_s - 1e-9) {
            return;
        }
        self.goal_at = Some(t);
        let Some(own) = own_goal else { return };
        let leader = if me.id == p.leader_id { Some(me) } else { known.iter().find(|u| u.id == p.leader_id) };
        let input = FollowerInput {
            me: *me,
            leader,
            neighbours: known,
            // The leader's own goal (Table 7's per-UAV goals when given): every UAV reads it from
            // the scenario, as Fig. 42a line 601 reads `leader_goal`.
            leader_goal: Point2::from(sc.goal_of(p.leader_id, t)),
            own_goal: own,
            previous_goal: self.goal,
        };
        // A follower that has never known its reference (anonymous ICP neighbours, or nobody in
        // range yet) flies to its own goal rather than hovering.
        self.goal = m23::follower_goal(p.topology, &input, &self.costmap, p).or(Some(own));
        self.path =
            self.goal.and_then(|g| self.costmap.plan(me.position, g)).map(|path| path.points).unwrap_or_default();
    }
}

impl Controller for M23Pilot {
    fn step(&mut self, v: &View) -> Command {
        self.fly(v)
    }

    fn wants_scan_points(&self) -> bool {
        true
    }
}

/// Clearance kept between two bodies by the M23 tracker beyond touching [m].
const NEIGHBOUR_MARGIN_M: f64 = 0.2;

/// The costmap with each neighbour's disc lethal: what the M23 tracker must not step into.
/// A UAV already inside a neighbour's disc (the neighbour came to it) may leave it but not go
/// deeper: for that neighbour the lethal disc shrinks to the present distance. (A disc lethal
/// throughout made the UAV's own cell lethal, and the tracker, which lets a UAV on a lethal cell
/// move to any cell no costlier so that it can back out, then let two UAVs close to 0.3 m.)
struct WithNeighbours<'a> {
    map: &'a Costmap,
    /// Each neighbour and the distance within which it is lethal.
    others: Vec<(Point2<f64>, f64)>,
}

impl<'a> WithNeighbours<'a> {
    fn new(
        map: &'a Costmap,
        others: impl Iterator<Item = Point2<f64>>,
        me: Point2<f64>,
        radius_m: f64,
    ) -> WithNeighbours<'a> {
        WithNeighbours { map, others: others.map(|o| (o, radius_m.min((o - me).norm()))).collect() }
    }
}

impl CostQuery for WithNeighbours<'_> {
    fn cost_at(&self, p: Point2<f64>) -> Option<u8> {
        if self.others.iter().any(|(o, r)| (o - p).norm() < *r) {
            return Some(LETHAL_OBSTACLE);
        }
        CostQuery::cost_at(self.map, p)
    }
    fn resolution(&self) -> f64 {
        CostQuery::resolution(self.map)
    }
}
