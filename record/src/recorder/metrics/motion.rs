//! Motion: what the bodies did, from the ground truth alone: each UAV's distances to obstacles
//! and to the nearest UAV, its path and its track, the collisions, the lattice spacing, and how
//! and when the run ended. Why its own part: these judge the flight itself (seed 004 3.5's
//! formation metrics, the goal, the collisions) and need nothing the agents said, so they are
//! folded from the truth steps alone; solitude reads the track kept here.

use super::stats::mean_finite;
use crate::recorder::solitude::solitude;
use crate::summary::{AgentSummary, CollisionRecord, FormationMetrics};
use std::collections::BTreeMap;
use swarm_types::{Hysteresis, UavId};
use swarm_wire::{EndReason, TruthStep, TruthWorld};

/// One tick of a UAV's truth track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackSample {
    /// Sim time [s].
    pub t_s: f64,
    /// World position [m].
    pub x_m: f64,
    /// World position [m].
    pub y_m: f64,
    /// Distance to the nearest obstacle surface, as the hub reports it [m].
    pub obstacle_m: f64,
    /// Distance to the nearest other UAV of any kind, as the hub reports it [m].
    pub nearest_uav_m: f64,
}

/// The window at the end of a run over which the lattice spacing is reported [s].
const LATTICE_WINDOW_S: f64 = 10.0;

/// Window and distance of seed 004's blocking rule: blocked while it moved less than 0.1 m
/// during the last 1 s.
const BLOCKING_WINDOW_S: f64 = 1.0;
const BLOCKING_DISTANCE_M: f64 = 0.1;

/// One UAV's motion over the run.
#[derive(Debug, Clone)]
struct UavMotion {
    min_obst: f64,
    sum_obst: f64,
    min_agent: f64,
    sum_agent: f64,
    /// Truth steps that had its body.
    n: u64,
    path: f64,
    /// Where it was last (its start pose before its first step).
    last: Option<(f64, f64)>,
    /// One sample per truth step that had its body (so empty for a UAV only the world named).
    track: Vec<TrackSample>,
}

impl Default for UavMotion {
    fn default() -> Self {
        UavMotion {
            min_obst: f64::INFINITY,
            sum_obst: 0.0,
            min_agent: f64::INFINITY,
            sum_agent: 0.0,
            n: 0,
            path: 0.0,
            last: None,
            track: Vec::new(),
        }
    }
}

/// The motion of the run, folded truth step by truth step.
#[derive(Debug, Default)]
pub(super) struct Motion {
    world: Option<TruthWorld>,
    /// Per UAV named by the world's starts or a truth step.
    uavs: BTreeMap<UavId, UavMotion>,
    collisions: Vec<CollisionRecord>,
    last_step: Option<TruthStep>,
    ticks: u64,
    /// Mean nearest-neighbour distance over the UAVs at each tick: (sim time, metres).
    spacing: Vec<(f64, f64)>,
}

/// The run-wide part of the summary that motion answers.
pub(super) struct RunMotion {
    pub(super) trees: usize,
    pub(super) end_reason: &'static str,
    pub(super) time_to_goal_s: Option<f64>,
    pub(super) sim_time_s: f64,
    pub(super) wall_time_s: f64,
    pub(super) sim_speed: f64,
    pub(super) ticks: u64,
    pub(super) collision_events: Vec<CollisionRecord>,
    pub(super) min_obstacle_distance_m: f64,
    pub(super) min_agent_distance_m: f64,
    pub(super) lattice_spacing_m: f64,
    pub(super) lattice_spacing_std_m: f64,
    pub(super) formation: FormationMetrics,
}

fn finite_or_inf(v: f64) -> f64 {
    if v.is_finite() {
        v
    } else {
        f64::INFINITY
    }
}

impl Motion {
    /// Notes the static world; paths are measured from the start poses.
    pub(super) fn on_world(&mut self, w: TruthWorld) {
        for (i, s) in w.starts.iter().enumerate() {
            let a = self.uavs.entry(UavId::from_index(i)).or_default();
            if a.last.is_none() {
                a.last = Some((s[0], s[1]));
            }
        }
        self.world = Some(w);
    }

    /// Folds one ground-truth step.
    pub(super) fn on_step(&mut self, s: &TruthStep) {
        self.ticks += 1;
        for b in &s.bodies {
            let a = self.uavs.entry(b.id).or_default();
            let (od, ad) = (finite_or_inf(b.obstacle_distance_m), finite_or_inf(b.agent_distance_m));
            a.min_obst = a.min_obst.min(od);
            a.min_agent = a.min_agent.min(ad);
            if od.is_finite() {
                a.sum_obst += od;
            }
            if ad.is_finite() {
                a.sum_agent += ad;
            }
            a.n += 1;
            if let Some((x, y)) = a.last {
                a.path += (b.x - x).hypot(b.y - y);
            }
            a.last = Some((b.x, b.y));
            a.track.push(TrackSample {
                t_s: s.t_s,
                x_m: b.x,
                y_m: b.y,
                obstacle_m: b.obstacle_distance_m,
                nearest_uav_m: b.agent_distance_m,
            });
        }
        let nn: Vec<f64> = s.bodies.iter().map(|b| b.agent_distance_m).filter(|d| d.is_finite()).collect();
        if !nn.is_empty() {
            self.spacing.push((s.t_s, nn.iter().sum::<f64>() / nn.len() as f64));
        }
        for c in &s.collisions {
            self.collisions.push(CollisionRecord { t_s: s.t_s, id: c.id, other_uav: c.other_uav, x_m: c.x, y_m: c.y });
        }
        self.last_step = Some(s.clone());
    }

    /// Whether the hub has marked the last step.
    pub(super) fn ended(&self) -> Option<EndReason> {
        self.last_step.as_ref().and_then(|s| s.ended)
    }

    /// The static world, once known.
    pub(super) fn world(&self) -> Option<&TruthWorld> {
        self.world.as_ref()
    }

    /// The last step seen.
    pub(super) fn last_step(&self) -> Option<&TruthStep> {
        self.last_step.as_ref()
    }

    /// Collisions so far.
    pub(super) fn collision_count(&self) -> usize {
        self.collisions.len()
    }

    /// The UAVs the world's starts or a truth step named, in id order.
    pub(super) fn uavs(&self) -> impl Iterator<Item = UavId> + '_ {
        self.uavs.keys().copied()
    }

    /// Fills in `a`'s distances, path, blocking time and solitude (by the radio's rule `radio`).
    pub(super) fn fill(&self, a: &mut AgentSummary, radio: Hysteresis) {
        let blank = UavMotion::default();
        let m = self.uavs.get(&a.id).unwrap_or(&blank);
        let n = m.n.max(1) as f64;
        a.min_obstacle_distance_m = m.min_obst;
        a.mean_obstacle_distance_m = if m.min_obst.is_finite() { m.sum_obst / n } else { f64::INFINITY };
        a.min_agent_distance_m = m.min_agent;
        a.mean_agent_distance_m = if m.min_agent.is_finite() { m.sum_agent / n } else { f64::INFINITY };
        a.path_length_m = m.path;
        // From the track; a UAV with none (only the world named it) has no such numbers.
        (a.blocking_time_s, a.agent_distance_std_m) = (0.0, f64::NAN);
        (a.time_alone_s, a.alone_spells, a.rejoined, a.rejoined_at_s, a.max_nearest_uav_m) =
            (0.0, 0, None, None, f64::NAN);
        if !m.track.is_empty() {
            a.blocking_time_s = blocking_time(&m.track);
            a.agent_distance_std_m = std_dev(m.track.iter().map(|s| s.nearest_uav_m));
            let alone = solitude(&m.track, radio);
            a.time_alone_s = alone.time_alone_s;
            a.alone_spells = alone.spells;
            a.rejoined = alone.rejoined;
            a.rejoined_at_s = alone.rejoined_at_s;
            a.max_nearest_uav_m = alone.max_nearest_uav_m;
        }
    }

    /// The run-wide motion, over the agents' summaries `agents` (filled in by [`Motion::fill`]).
    pub(super) fn summary(&self, agents: &[AgentSummary]) -> RunMotion {
        let last = self.last_step.as_ref();
        let (sim_time_s, wall_time_s) = last.map_or((0.0, 0.0), |s| (s.t_s, s.wall_s));
        let end_reason = self.ended().map_or("incomplete", EndReason::name);
        let min = |f: fn(&AgentSummary) -> f64| agents.iter().map(f).fold(f64::INFINITY, f64::min);
        let (lattice_spacing_m, lattice_spacing_std_m) = self.lattice_spacing();
        RunMotion {
            trees: self.world.as_ref().map_or(0, |w| w.trees.len()),
            end_reason,
            time_to_goal_s: last.and_then(|s| s.goal_reached_at),
            sim_time_s,
            wall_time_s,
            sim_speed: if wall_time_s > 0.0 { sim_time_s / wall_time_s } else { 0.0 },
            ticks: self.ticks,
            collision_events: self.collisions.clone(),
            min_obstacle_distance_m: min(|a| a.min_obstacle_distance_m),
            min_agent_distance_m: min(|a| a.min_agent_distance_m),
            lattice_spacing_m,
            lattice_spacing_std_m,
            formation: formation_metrics(agents),
        }
    }

    /// Mean and standard deviation over the last [`LATTICE_WINDOW_S`] of sim time of the mean
    /// nearest-neighbour distance (seed 001 4.1 reports the equilibrium spacing ξ this way).
    fn lattice_spacing(&self) -> (f64, f64) {
        let Some(&(t_end, _)) = self.spacing.last() else { return (f64::NAN, f64::NAN) };
        let tail = || self.spacing.iter().filter(move |(t, _)| *t >= t_end - LATTICE_WINDOW_S).map(|&(_, d)| d);
        (mean_finite(tail()), std_dev(tail()))
    }
}

/// Seconds a UAV was blocked, from its track (seed 004 3.5).
fn blocking_time(samples: &[TrackSample]) -> f64 {
    let mut blocked = 0.0;
    let mut back = 0;
    for i in 1..samples.len() {
        let TrackSample { t_s: t, x_m: x, y_m: y, .. } = samples[i];
        while back < i && samples[back + 1].t_s <= t - BLOCKING_WINDOW_S + 1e-9 {
            back += 1;
        }
        let TrackSample { t_s: t0, x_m: x0, y_m: y0, .. } = samples[back];
        if t - t0 >= BLOCKING_WINDOW_S - 1e-9 && (x - x0).hypot(y - y0) < BLOCKING_DISTANCE_M {
            blocked += t - samples[i - 1].t_s;
        }
    }
    blocked
}

/// Standard deviation of the finite values (NaN when there are none).
fn std_dev(values: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    let mean = mean_finite(v.iter().copied());
    mean_finite(v.iter().map(|x| (x - mean).powi(2))).sqrt()
}

fn formation_metrics(agents: &[AgentSummary]) -> FormationMetrics {
    let mean = |f: fn(&AgentSummary) -> f64| mean_finite(agents.iter().map(f));
    FormationMetrics {
        mean_neighbour_distance_m: mean(|a| a.mean_agent_distance_m),
        neighbour_distance_deviation_m: mean(|a| a.agent_distance_std_m),
        mean_blocking_time_s: mean(|a| a.blocking_time_s),
        mean_trajectory_length_m: mean(|a| a.path_length_m),
        mean_obstacle_distance_m: mean(|a| a.mean_obstacle_distance_m),
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::body;
    use super::super::Metrics;
    use super::*;
    use swarm_wire::CollisionEvent;

    #[test]
    fn blocking_counts_the_time_spent_moving_less_than_10_cm_per_second() {
        // 0.1 s ticks: moving at 0.5 m/s for 3 s, then still for 2 s, then 0.05 m/s for 2 s.
        let mut samples = Vec::new();
        let mut x = 0.0;
        for k in 0..=70 {
            let t = f64::from(k) * 0.1;
            samples.push(TrackSample { t_s: t, x_m: x, y_m: 0.0, obstacle_m: 1.0, nearest_uav_m: 1.0 });
            x += if t < 3.0 - 1e-9 {
                0.05
            } else if t < 5.0 - 1e-9 {
                0.0
            } else {
                0.005
            };
        }
        // Still from 3.0 s: blocked once the last second moved < 0.1 m, i.e. from 3.9 s (at 3.9
        // it moved 0.05 m since 2.9) through 7.0 s: 3.1 s (the crawl moves 0.05 m per second).
        let b = blocking_time(&samples);
        assert!((b - 3.1).abs() < 0.11, "{b}");
        assert_eq!(blocking_time(&samples[..31]), 0.0, "moving: never blocked");
        assert!((std_dev([1.0, 3.0].into_iter()) - 1.0).abs() < 1e-12);
        assert!(std_dev([f64::NAN].into_iter()).is_nan());
    }

    #[test]
    fn metrics_fold_min_mean_path_collisions_and_end() {
        let sc = swarm_config::builtin("open-field-5").expect("builtin");
        let mut m = Metrics::default();
        let step = |tick, x, od, ad, ended, goal| TruthStep {
            tick,
            t_s: tick as f64 * 0.1,
            bodies: vec![body(1, x, od, ad, tick != 2)],
            collisions: if tick == 2 {
                vec![CollisionEvent { id: UavId::new(1), other_uav: None, x, y: 0.0 }]
            } else {
                vec![]
            },
            goal_reached_at: goal,
            ended,
            wall_s: tick as f64 * 0.01,
            timing: Box::new(swarm_wire::HubTiming {
                work_us: 1000 * tick as u32,
                cmds: 2,
                late_ms: if tick == 2 { vec![5.0, 40.0] } else { vec![] },
            }),
        };
        m.on_step(&step(1, 0.0, 2.0, 3.0, None, None));
        m.on_step(&step(2, 3.0, 1.0, 5.0, None, None));
        assert_eq!(m.ended(), None);
        m.on_step(&step(3, 7.0, 3.0, 1.0, Some(EndReason::Goal), Some(0.3)));
        let s = m.summary("r", &sc);
        assert_eq!(s.end_reason, "goal");
        assert!(s.reached_goal);
        assert_eq!(s.time_to_goal_s, Some(0.3));
        assert_eq!(s.collisions, 1);
        assert!((s.sim_speed - 10.0).abs() < 1e-9);
        let a = &s.agents[0];
        assert_eq!((a.min_obstacle_distance_m, a.min_agent_distance_m), (1.0, 1.0));
        assert!((a.mean_obstacle_distance_m - 2.0).abs() < 1e-12);
        assert!((a.mean_agent_distance_m - 3.0).abs() < 1e-12);
        assert!((a.path_length_m - 7.0).abs() < 1e-12);
        assert_eq!(a.late_ticks, 1);
        let t = &s.timing;
        assert_eq!((t.commands, t.late_commands), (6, 2));
        assert!((t.late_share - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(t.late_p99_ms, 40.0, "nearest rank of two: the larger");
        assert_eq!((t.hub_tick_p50_ms, t.hub_tick_p99_ms), (1.0, 2.0), "the last (ended) step measures no work");
        assert!(t.agent_step_p50_ms.is_nan(), "no agent state folded");
    }
}
