//! The simulation state and its step, free of any IO: the hub's Zenoh loop calls
//! [`Sim::sensors_each`] for the live UAVs, collects commands, then [`Sim::step`]. Pure and
//! seeded, so a lockstep run with the same commands repeats exactly.
//!
//! Scale: every pairwise question (radio links, contacts, the UAVs a scan can hit, the nearest
//! other UAV) goes through one [`Grid`] of the positions rebuilt each tick, and the sensors of a
//! large swarm are computed on every core, in chunks handed over in id order as they are done, so
//! the hub publishes the first chunks while the next are computed ([`Sim::sensors_each`]). Each
//! UAV draws only from its own seeded streams and the results are taken in id order, so nothing
//! depends on the number of threads.

use crate::body::{wrap_angle, Body, Limits};
use crate::forest::{rng, scenario_trees, start_positions, stream};
use crate::grid::Grid;
use crate::lidar;
use crate::radio::Radio;
use crate::world::World;
use nalgebra::{Rotation2, Vector2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use swarm_config::{GoalRule, LocalizationMode, OnCollision, Scenario};
use swarm_wire::{
    Clock, Cmd, CmdKind, CollisionEvent, EndReason, Gnss, HubTiming, Odom, RadioSet, Scan, SenseFrame, TruthBody,
    TruthStep, TruthWorld, Uvdar, UvdarSeen,
};

/// The seeded random streams of one UAV's sensors.
struct UavRngs {
    lidar: ChaCha8Rng,
    gnss: ChaCha8Rng,
    uvdar: ChaCha8Rng,
}

/// Below this many UAVs the sensors of a tick are computed on the calling thread: spawning
/// workers costs more than it saves.
const PARALLEL_FROM_UAVS: usize = 32;

/// UAVs per chunk of a pipelined tick ([`Sim::sensors_each`]): small enough that publication
/// starts after a few milliseconds, large enough that a chunk's hand-over costs nothing next to
/// its scans.
const CHUNK_UAVS: usize = 25;

/// A chunk of a pipelined tick: its number, and its UAVs with their streams.
type Chunk<'s, 'r> = (usize, &'s mut [(u32, &'r mut UavRngs)]);

/// One tick's ground truth as the simulation knows it: every part of `truth/step` but the hub's
/// wall-clock timing of the tick, which only the node measures ([`Stepped::with_timing`] joins
/// the two into the message).
#[derive(Debug, Clone, PartialEq)]
pub struct Stepped {
    /// Tick just integrated.
    pub tick: u64,
    /// Sim time at the end of the tick [s].
    pub t_secs: f64,
    /// Every body.
    pub bodies: Vec<TruthBody>,
    /// Collisions that began this tick.
    pub collisions: Vec<CollisionEvent>,
    /// Sim time the goal rule was first met, if it was.
    pub goal_reached_at: Option<f64>,
    /// Why the run ends here, on its last step.
    pub ended: Option<EndReason>,
    /// Wall seconds since tick 0.
    pub wall_secs: f64,
}

impl Stepped {
    /// The `truth/step` message: this tick's truth and what it cost the hub.
    pub fn with_timing(self, timing: HubTiming) -> TruthStep {
        let Stepped { tick, t_secs, bodies, collisions, goal_reached_at, ended, wall_secs } = self;
        TruthStep { tick, t_secs, bodies, collisions, goal_reached_at, ended, wall_secs, timing: Box::new(timing) }
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
    starts: Vec<[f64; 3]>,
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
        let starts: Vec<[f64; 3]> = start_positions(sc).iter().map(|p| [p[0], p[1], yaw0]).collect();
        let bodies = starts.iter().map(|s| Body::at(s[0], s[1], s[2])).collect();
        let n = sc.count();
        let mut radio = Radio::of(&sc.radio);
        let grid = Grid::new(&starts.iter().map(|s| [s[0], s[1]]).collect::<Vec<_>>(), grid_cell_m(sc));
        radio.update_with(&grid);
        let hover = Cmd { tick: 0, kind: CmdKind::Hover, x: 0.0, y: 0.0, yaw_rate: 0.0 };
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
            rngs: sc
                .uav_ids()
                .map(|id| UavRngs {
                    lidar: rng(sc.seed, stream::LIDAR + u64::from(id)),
                    gnss: rng(sc.seed, stream::GNSS_ERROR + u64::from(id)),
                    uvdar: rng(sc.seed, stream::UVDAR + u64::from(id)),
                })
                .collect(),
            last_cmds: vec![hover; n],
            obstacle_contact: vec![false; n],
            uav_contact: vec![Vec::new(); n],
            uav_colliding: vec![false; n],
            tick: 0,
            dt: sc.dt_secs(),
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
    pub fn t_secs(&self) -> f64 {
        self.tick as f64 * self.dt
    }

    /// The clock message of the current tick.
    pub fn clock(&self) -> Clock {
        Clock { tick: self.tick, t_secs: self.t_secs(), dt_secs: self.dt }
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
            starts: self.starts.clone(),
            goal: self.sc.swarm.goal,
            body_radius_m: self.sc.body.radius_m,
        }
    }

    /// The sensor frame of UAV `id` (1-based) for the current tick.
    #[cfg(test)]
    pub fn sensors(&mut self, id: u32) -> SenseFrame {
        self.sensors_all(&[id]).pop().expect("one UAV asked, one answer")
    }

    /// The sensor frames of the UAVs `ids` (1-based, each at most once) for the current tick, in
    /// the order given. Large swarms are spread over the cores (see [`Sim::sensors_each`]); each
    /// UAV draws only from its own streams, so the result does not depend on the split.
    pub fn sensors_all(&mut self, ids: &[u32]) -> Vec<SenseFrame> {
        let mut out = Vec::with_capacity(ids.len());
        let done: Result<(), std::convert::Infallible> = self.sensors_each(
            ids,
            |_, s| s,
            |_, s| {
                out.push(s);
                Ok(())
            },
        );
        match done {
            Ok(()) => out,
            Err(never) => match never {},
        }
    }

    /// The sensor frames of the UAVs `ids` (1-based, each at most once) for the current tick,
    /// each turned into a `T` by `prepare` on the thread that computed it (the hub encodes them
    /// there), then handed to `sink` on the calling thread, one UAV at a time in the order of
    /// `ids`. From [`PARALLEL_FROM_UAVS`] UAVs on, worker threads (one per core) compute chunks
    /// of [`CHUNK_UAVS`] while the calling thread sinks the chunks already done, so the sink's
    /// work (the hub's publication) overlaps the computation instead of waiting for all of it,
    /// and the first agents get their sensors early. Each UAV draws only from its own streams
    /// and the sink sees id order whatever the threads do, so nothing depends on the split. The
    /// first error of `sink` stops the sinking and is returned (the workers finish their chunks).
    pub fn sensors_each<T: Send, E>(
        &mut self,
        ids: &[u32],
        prepare: impl Fn(u32, SenseFrame) -> T + Sync,
        sink: impl FnMut(u32, T) -> Result<(), E>,
    ) -> Result<(), E> {
        let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
        self.sensors_each_on(ids, workers, prepare, sink)
    }

    /// [`Sim::sensors_each`] with `workers` worker threads at most (below 2: none, one UAV after
    /// the other on the calling thread); the tests pick it so the pipeline runs on any machine.
    fn sensors_each_on<T: Send, E>(
        &mut self,
        ids: &[u32],
        workers: usize,
        prepare: impl Fn(u32, SenseFrame) -> T + Sync,
        mut sink: impl FnMut(u32, T) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut rngs = std::mem::take(&mut self.rngs);
        let mut jobs: Vec<(u32, &mut UavRngs)> = Vec::with_capacity(ids.len());
        {
            let mut by_index: Vec<Option<&mut UavRngs>> = rngs.iter_mut().map(Some).collect();
            for &id in ids {
                if let Some(r) = (id as usize).checked_sub(1).and_then(|i| by_index.get_mut(i)).and_then(Option::take) {
                    jobs.push((id, r));
                }
            }
        }
        let this = &*self;
        let result = if jobs.len() < PARALLEL_FROM_UAVS || workers < 2 {
            jobs.into_iter().try_for_each(|(id, r)| sink(id, prepare(id, this.sensors_of(id, r))))
        } else {
            this.sensors_pipelined(&mut jobs, workers, &prepare, &mut sink)
        };
        self.rngs = rngs;
        result
    }

    /// [`Sim::sensors_each`] on `workers` threads: worker w computes chunks w, w + workers, …
    /// in that order and sends each whole; the calling thread sinks them in chunk order, holding
    /// any that arrive early.
    fn sensors_pipelined<T: Send, E>(
        &self,
        jobs: &mut [(u32, &mut UavRngs)],
        workers: usize,
        prepare: &(impl Fn(u32, SenseFrame) -> T + Sync),
        sink: &mut impl FnMut(u32, T) -> Result<(), E>,
    ) -> Result<(), E> {
        let mut per_worker: Vec<Vec<Chunk<'_, '_>>> = (0..workers).map(|_| Vec::new()).collect();
        let chunks = jobs.len().div_ceil(CHUNK_UAVS);
        for (k, part) in jobs.chunks_mut(CHUNK_UAVS).enumerate() {
            per_worker[k % workers].push((k, part));
        }
        std::thread::scope(|scope| {
            let (tx, rx) = std::sync::mpsc::channel::<(usize, Vec<(u32, T)>)>();
            for mine in per_worker {
                let tx = tx.clone();
                scope.spawn(move || {
                    for (k, part) in mine {
                        let done =
                            part.iter_mut().map(|(id, r)| (*id, prepare(*id, self.sensors_of(*id, r)))).collect();
                        if tx.send((k, done)).is_err() {
                            return;
                        }
                    }
                });
            }
            drop(tx);
            let mut early = std::collections::BTreeMap::new();
            let mut result = Ok(());
            for next in 0..chunks {
                let done = loop {
                    if let Some(d) = early.remove(&next) {
                        break d;
                    }
                    // A worker that panicked drops its sender; the scope re-raises the panic.
                    let Ok((k, d)) = rx.recv() else { return result };
                    early.insert(k, d);
                };
                if result.is_ok() {
                    result = done.into_iter().try_for_each(|(id, t)| sink(id, t));
                }
            }
            result
        })
    }

    /// The sensor frame of UAV `id`, drawing from its streams `r`.
    fn sensors_of(&self, id: u32, r: &mut UavRngs) -> SenseFrame {
        let i = (id - 1) as usize;
        let (tick, t_secs) = (self.tick, self.t_secs());
        let b = self.bodies[i];
        let scan = self.scan(i, tick, t_secs, &mut r.lidar);
        let s = self.starts[i];
        let start_from_world = Rotation2::new(-s[2]);
        let to_start = |p: Vector2<f64>| start_from_world * (p - Vector2::new(s[0], s[1]));
        let p = to_start(b.pos);
        let v = start_from_world * b.vel;
        let (goal, goal_vel) = if self.sc.is_informed(id) {
            let (g, gv) = self.sc.goal_motion_of(id, t_secs);
            let g = to_start(Vector2::new(g[0], g[1]));
            let gv = start_from_world * Vector2::new(gv[0], gv[1]);
            (Some([g.x, g.y]), (gv.norm() > 0.0).then_some([gv.x, gv.y]))
        } else {
            (None, None)
        };
        let odom =
            Odom { tick, t_secs, x: p.x, y: p.y, yaw: wrap_angle(b.yaw - s[2]), vx: v.x, vy: v.y, goal, goal_vel };
        let gnss = (self.sc.localization.mode == LocalizationMode::Broadcast).then(|| {
            let [ex, ey] = gnss_error(&self.sc, id, t_secs, &mut r.gnss);
            Gnss { tick, t_secs, x: b.pos.x + ex, y: b.pos.y + ey, yaw: b.yaw, vx: b.vel.x, vy: b.vel.y }
        });
        let in_range = self.radio.in_range(i).into_iter().map(|j| j as u32 + 1).collect();
        let loss = self.radio.losses(i);
        let uvdar =
            (self.sc.localization.mode == LocalizationMode::Uvdar).then(|| self.uvdar(i, tick, t_secs, &mut r.uvdar));
        SenseFrame { radio: RadioSet { tick, id, in_range, loss }, odom, gnss, uvdar, scan }
    }

    /// UAV index `i`'s LIDAR scan: the world and the other UAVs the beams can reach (found in the
    /// grid; a beam keeps its nearest hit whatever order the discs come in, so the scan equals
    /// one against every other UAV).
    fn scan(&self, i: usize, tick: u64, t_secs: f64, rng: &mut ChaCha8Rng) -> Scan {
        let b = self.bodies[i];
        let r_uav = self.sc.body.radius_m;
        let mut others: Vec<[f64; 3]> = Vec::new();
        self.grid.for_each_near([b.pos.x, b.pos.y], self.sc.lidar.max_range_m + r_uav.max(0.0), |j| {
            if j != i {
                others.push([self.bodies[j].pos.x, self.bodies[j].pos.y, r_uav]);
            }
        });
        let mut ranges = Vec::with_capacity(self.sc.lidar.beams as usize);
        lidar::scan(&self.world, [b.pos.x, b.pos.y, b.yaw], &others, &self.sc.lidar, rng, &mut ranges);
        let (angle_min, angle_increment) = lidar::beam_angles(&self.sc.lidar);
        Scan {
            tick,
            t_secs,
            angle_min,
            angle_increment,
            max_range_m: self.sc.lidar.max_range_m as f32,
            ranges_m: ranges,
        }
    }

    /// What UAV index `i` sees of the others by UVDAR (seed 003) now.
    fn uvdar(&self, i: usize, tick: u64, t_secs: f64, rng: &mut ChaCha8Rng) -> Uvdar {
        let poses: Vec<(u32, [f64; 2], f64)> =
            self.bodies.iter().enumerate().map(|(j, b)| (j as u32 + 1, [b.pos.x, b.pos.y], b.yaw)).collect();
        let seen = crate::uvdar::observe(&self.world, i, &poses, &self.sc.localization.uvdar, rng)
            .into_iter()
            .map(|o| UvdarSeen { id: o.id, range_m: o.range_m as f32, bearing_rad: o.bearing_rad as f32 })
            .collect();
        Uvdar { tick, t_secs, seen }
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
    pub fn step(&mut self, cmds: &[Option<Cmd>], alive: &[bool], wall_secs: f64) -> Stepped {
        let t_now = self.t_secs();
        for (i, b) in self.bodies.iter_mut().enumerate() {
            if self.timeline.frozen_at(i as u32 + 1, t_now) {
                // A frozen UAV hovers where it is, whatever its agent says (seed 000 6.2).
                self.last_cmds[i] = Cmd { tick: self.tick, kind: CmdKind::Hover, x: 0.0, y: 0.0, yaw_rate: 0.0 };
            } else if !alive.get(i).copied().unwrap_or(true) {
                self.last_cmds[i] = Cmd { tick: self.tick, kind: CmdKind::Hover, x: 0.0, y: 0.0, yaw_rate: 0.0 };
            } else if let Some(Some(c)) = cmds.get(i) {
                self.last_cmds[i] = *c;
            }
            b.step(&self.last_cmds[i], &self.limits, self.dt);
        }
        self.tick += 1;
        let t_secs = self.t_secs();
        let positions: Vec<[f64; 2]> = self.bodies.iter().map(|b| [b.pos.x, b.pos.y]).collect();
        self.grid = Grid::new(&positions, grid_cell_m(&self.sc));
        self.radio.update_with(&self.grid);
        let collisions = self.detect_collisions();
        self.goal_since = if self.goal_met() { self.goal_since.or(Some(t_secs)) } else { None };
        // The goal counts once its rule has held for `end.hold_s` (0: at once), from the start
        // of that streak.
        if self.goal_reached_at.is_none() && self.goal_since.is_some_and(|s| t_secs - s >= self.sc.end.hold_s - 1e-9) {
            self.goal_reached_at = self.goal_since;
        }
        let ended = if self.goal_reached_at.is_some() {
            Some(EndReason::Goal)
        } else if t_secs >= self.sc.end.time_limit_s - 1e-9 {
            Some(EndReason::TimeLimit)
        } else {
            None
        };
        self.observe(cmds, alive, collisions, ended, wall_secs)
    }

    /// Ground truth of the current state, without integrating (also the hub's last word when a
    /// run is stopped, with the reason it ended).
    pub fn observe(
        &self,
        cmds: &[Option<Cmd>],
        alive: &[bool],
        collisions: Vec<CollisionEvent>,
        ended: Option<EndReason>,
        wall_secs: f64,
    ) -> Stepped {
        Stepped {
            tick: self.tick,
            t_secs: self.t_secs(),
            bodies: self.truth_bodies(cmds, alive),
            collisions,
            goal_reached_at: self.goal_reached_at,
            ended,
            wall_secs,
        }
    }

    fn truth_bodies(&self, cmds: &[Option<Cmd>], alive: &[bool]) -> Vec<TruthBody> {
        self.bodies
            .iter()
            .enumerate()
            .map(|(i, b)| TruthBody {
                id: i as u32 + 1,
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
                events.push(CollisionEvent { id: i as u32 + 1, other_uav: None, x: p.x, y: p.y });
            }
            self.obstacle_contact[i] = hit;
            // Only the pairs the grid puts near can touch; the others are out of contact.
            let mut touching = Vec::new();
            for j in self.grid.near_sorted(i, 2.0 * r).into_iter().filter(|&j| j > i) {
                let hit = (self.bodies[j].pos - p).norm() < 2.0 * r;
                if hit && self.uav_contact[i].binary_search(&j).is_err() {
                    events.push(CollisionEvent { id: i as u32 + 1, other_uav: Some(j as u32 + 1), x: p.x, y: p.y });
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
                self.bodies[(e.id - 1) as usize].stopped = true;
                if let Some(o) = e.other_uav {
                    self.bodies[(o - 1) as usize].stopped = true;
                }
            }
        }
        events
    }

    fn goal_met(&self) -> bool {
        let g = Vector2::new(self.sc.swarm.goal[0], self.sc.swarm.goal[1]);
        let r = self.sc.end.goal_radius_m;
        // Failed UAVs (no agent) and frozen ones are not part of the swarm that has to arrive.
        let t = self.t_secs();
        let flying: Vec<Vector2<f64>> = self
            .sc
            .agent_ids()
            .filter(|&id| !self.timeline.frozen_at(id, t))
            .map(|id| self.bodies[(id - 1) as usize].pos)
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

/// The artificial error of UAV `id`'s GNSS-like fix at `t` (seed 001 eq. 45–46): zero, or while
/// the scenario's `broadcast_error` is active for it, a vector of uniform direction whose length
/// is uniform in [0, δa], fresh every tick, drawn from the UAV's stream `r`.
fn gnss_error(sc: &Scenario, id: u32, t: f64, r: &mut ChaCha8Rng) -> [f64; 2] {
    let Some(e) = sc.localization.broadcast_error.as_ref().filter(|e| e.active(id, t)) else {
        return [0.0, 0.0];
    };
    // seed 001 eq. 46: f(|δa|) = 1/δa on [0, δa]; the direction is uniform.
    let len = e.delta_a_m * r.gen::<f64>();
    let dir = std::f64::consts::TAU * r.gen::<f64>();
    [len * dir.cos(), len * dir.sin()]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scenario() -> Scenario {
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

    fn vel(x: f32) -> Option<Cmd> {
        Some(Cmd { tick: 0, kind: CmdKind::Velocity, x, y: 0.0, yaw_rate: 0.0 })
    }

    /// A crowd large enough for the pipelined path (100 UAVs, chunks of [`CHUNK_UAVS`]).
    fn crowd() -> Scenario {
        Scenario::from_toml_str(
            r#"
name = "crowd"
seed = 7
[world]
trees = [{ x = 5.0, y = 0.0, r = 0.5 }, { x = -4.0, y = 6.0, r = 0.4 }]
[swarm]
count = 100
start_area = { center = [0.0, 0.0], radius_m = 24.0, min_spacing_m = 3.0 }
goal = [60.0, 0.0]
informed = "all"
[localization]
mode = "broadcast"
[end]
time_limit_s = 100.0
"#,
            "crowd.toml",
        )
        .expect("valid")
    }

    #[test]
    fn pipelined_sensors_equal_one_uav_at_a_time_in_the_order_asked() {
        let sc = crowd();
        let mut ids: Vec<u32> = sc.uav_ids().collect();
        ids.reverse();
        ids.retain(|&id| id != 50);
        assert!(ids.len() >= PARALLEL_FROM_UAVS, "large enough for the workers");
        let (mut pipelined, mut alone) = (Sim::new(&sc), Sim::new(&sc));
        for _ in 0..3 {
            let mut order = Vec::new();
            // Three workers whatever this machine has, so the pipeline itself is what is tested.
            let got = pipelined.sensors_each_on(
                &ids,
                3,
                |id, s| (id, format!("{s:?}")),
                |id, (prepared_for, text)| {
                    order.push(id);
                    assert_eq!(prepared_for, id, "prepared and sunk for the same UAV");
                    assert_eq!(text, format!("{:?}", alone.sensors(id)), "UAV {id}");
                    Ok::<(), ()>(())
                },
            );
            assert_eq!(got, Ok(()));
            assert_eq!(order, ids, "sunk in the order asked, UAV 50 left out");
            let cmds = vec![vel(0.4); 100];
            pipelined.step(&cmds, &[true; 100], 0.0);
            alone.step(&cmds, &[true; 100], 0.0);
        }
    }

    #[test]
    fn the_first_sink_error_stops_the_sinking() {
        let sc = crowd();
        let ids: Vec<u32> = sc.uav_ids().collect();
        let mut sim = Sim::new(&sc);
        let mut sunk = 0;
        let got = sim.sensors_each_on(
            &ids,
            3,
            |_, s| s.scan.ranges_m.len(),
            |id, _| {
                sunk += 1;
                if id == 40 {
                    Err(id)
                } else {
                    Ok(())
                }
            },
        );
        assert_eq!(got, Err(40));
        assert_eq!(sunk, 40, "nothing after the error");
        assert_eq!(sim.sensors_all(&ids).len(), 100, "the streams are back for the next tick");
    }

    #[test]
    fn odometry_is_in_the_start_frame_and_goal_only_for_informed() {
        let mut sim = Sim::new(&scenario());
        let s1 = sim.sensors(1);
        // Start heading 90°: the world goal (10, 0) is 10 m to the right, i.e. at (0, -10).
        let g = s1.odom.goal.expect("UAV 1 is informed");
        assert!(g[0].abs() < 1e-9 && (g[1] + 10.0).abs() < 1e-9, "{g:?}");
        assert_eq!(sim.sensors(2).odom.goal, None, "UAV 2 is not informed");
        assert_eq!(s1.radio.in_range, vec![2]);
        // Fly body-forward (world +y) for a while: odometry x grows, y stays.
        for _ in 0..5 {
            sim.step(&[vel(0.2), vel(0.0)], &[true, true], 0.0);
        }
        let o = sim.sensors(1).odom;
        assert!(o.x > 0.0 && o.y.abs() < 1e-9 && o.yaw.abs() < 1e-12, "{o:?}");
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
    fn the_broadcast_error_is_uniform_in_length_up_to_delta_a_and_only_where_asked() {
        let mut sc = scenario();
        sc.localization.mode = LocalizationMode::Broadcast;
        sc.localization.broadcast_error = Some(swarm_config::BroadcastError {
            delta_a_m: 2.0,
            uavs: swarm_config::UavSet::Ids(vec![1]),
            from_s: 1.0,
            until_s: Some(3.0),
        });
        let mut r = rng(sc.seed, stream::GNSS_ERROR + 1);
        let n = 20_000;
        let lengths: Vec<f64> = (0..n).map(|_| gnss_error(&sc, 1, 2.0, &mut r)).map(|[x, y]| x.hypot(y)).collect();
        // seed 001 eq. 46: |δa| uniform on [0, 2]: mean 1, variance 4/12.
        let mean = lengths.iter().sum::<f64>() / f64::from(n);
        let var = lengths.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / f64::from(n);
        assert!(lengths.iter().all(|&l| l <= 2.0));
        assert!((mean - 1.0).abs() < 0.02, "{mean}");
        assert!((var - 1.0 / 3.0).abs() < 0.02, "{var}");
        assert_eq!(gnss_error(&sc, 2, 2.0, &mut r), [0.0, 0.0], "UAV 2 is not affected");
        assert_eq!(gnss_error(&sc, 1, 0.5, &mut r), [0.0, 0.0], "before the window");
        assert_eq!(gnss_error(&sc, 1, 3.0, &mut r), [0.0, 0.0], "after the window");
    }

    #[test]
    fn a_frozen_uav_hovers_whatever_its_agent_says() {
        let mut sc = scenario();
        sc.failures = vec![swarm_config::Failure { at_s: 0.5, uav: 1, kind: swarm_config::FailureKind::Freeze }];
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
