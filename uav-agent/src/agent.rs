//! One control step of the onboard stack, with no IO: sensors and delivered neighbour messages
//! in; a command, a share message and diagnostics out. The Zenoh loop in `node` feeds it; tests
//! and benchmarks call it directly.
//!
//! Architecture invariant: an agent sees the world only through its own sensor messages and its
//! neighbours' shares. Nothing here can reach ground truth.

use crate::icp::{self, Match, Transform};
use crate::localization::{BroadcastTable, Estimate};
use crate::neighbours::{Database, Matcher, Received};
use crate::perception;
use crate::pilot::{Pilot, View};
use nalgebra::{Point2, Vector2};
use std::time::Instant;
use swarm_config::{ControllerKind, IcpParams, LocalizationMode, Scenario, TimeMode};
use swarm_wire::{
    AgentState, Cmd, Gnss, IcpCounts, LinkCounters, Msg, NeighbourEstimate, ObstacleShare, Odom, PoseShare,
    Scan,
};

/// What agents tell their neighbours: a pose (`broadcast`) or an obstacle set (`icp`).
#[derive(Debug, Clone, PartialEq)]
pub enum Share {
    /// Broadcast mode.
    Pose(PoseShare),
    /// ICP mode.
    Obstacles(ObstacleShare),
}

impl Share {
    /// Sender id.
    pub fn from(&self) -> u32 {
        match self {
            Share::Pose(p) => p.from,
            Share::Obstacles(o) => o.from,
        }
    }
    /// Tick it was sent at.
    pub fn tick(&self) -> u64 {
        match self {
            Share::Pose(p) => p.tick,
            Share::Obstacles(o) => o.tick,
        }
    }
    /// Sim time it was sent at [s].
    pub fn t_secs(&self) -> f64 {
        match self {
            Share::Pose(p) => p.t_secs,
            Share::Obstacles(o) => o.t_secs,
        }
    }
    /// The wire message.
    pub fn into_msg(self) -> Msg {
        match self {
            Share::Pose(p) => Msg::Pose(p),
            Share::Obstacles(o) => Msg::Obstacles(o),
        }
    }
}

/// What one step produces.
#[derive(Debug, Clone)]
pub struct StepOutput {
    /// The command for the hub.
    pub cmd: Cmd,
    /// The message to share with neighbours, if any.
    pub share: Option<Share>,
    /// Diagnostics (link counters are filled in by the caller).
    pub state: AgentState,
}

/// The real ICP behind the neighbour database.
struct IcpMatcher<'a>(&'a IcpParams);

impl Matcher for IcpMatcher<'_> {
    fn short(&mut self, reference: &[Point2<f64>], source: &[Point2<f64>], initial: Transform) -> Option<Match> {
        icp::icp(reference, source, initial, self.0).ok()
    }
    fn long(&mut self, reference: &[Point2<f64>], source: &[Point2<f64>]) -> Option<Match> {
        icp::initial_icp(reference, source, self.0).ok()
    }
}

/// The onboard state of one UAV between steps.
pub struct Agent {
    id: u32,
    sc: Scenario,
    table: BroadcastTable,
    db: Database,
    /// The newest obstacle set from each neighbour (one per sender), handed to the database by
    /// reference every step (it orders them by sender and ignores sets older than `stale_after_s`).
    received: Vec<Received>,
    /// The controller and what it keeps between steps.
    pilot: Pilot,
    /// The newest onboard relative sensing (`uvdar` mode).
    uvdar: Option<swarm_wire::Uvdar>,
}

impl Agent {
    /// The agent of UAV `id` under scenario `sc`.
    pub fn new(id: u32, sc: Scenario) -> Agent {
        let db = Database::new(sc.localization.icp.clone(), sc.localization.stale_after_s);
        let pilot = Pilot::new(&sc);
        Agent { id, sc, table: BroadcastTable::default(), db, received: Vec::new(), pilot, uvdar: None }
    }

    /// Takes a neighbour's share that the link has delivered (our own echo is ignored).
    pub fn on_share(&mut self, share: Share) {
        match share {
            Share::Pose(p) if p.from != self.id => self.table.update(p),
            Share::Obstacles(o) if o.from != self.id => {
                let held = self.received.iter().position(|r| r.from == o.from);
                if held.is_none_or(|i| o.t_secs > self.received[i].t_secs) {
                    let points = o.centres_m().map(|c| Point2::new(c[0], c[1])).collect();
                    let set = Received { from: o.from, t_secs: o.t_secs, points };
                    match held {
                        Some(i) => self.received[i] = set,
                        None => self.received.push(set),
                    }
                }
            }
            _ => {}
        }
    }

    /// Takes this tick's onboard relative sensing (`uvdar` mode).
    pub fn on_uvdar(&mut self, u: swarm_wire::Uvdar) {
        self.uvdar = Some(u);
    }

    /// Runs perception, localization and control for one tick.
    pub fn step(&mut self, scan: &Scan, odom: &Odom, gnss: Option<&Gnss>) -> StepOutput {
        let started = Instant::now();
        let seen = perception::extract(scan, &self.sc.perception, &perception::SegmentParams::default());
        let circles = seen.circles;
        let (estimates, icp_counts) = self.localize(scan.t_secs, &circles, gnss, started);
        let trees = self.trees_only(&circles, &estimates);
        let scan_points: Vec<Point2<f64>> = if matches!(self.sc.controller.kind, ControllerKind::A21 | ControllerKind::M23) {
            perception::scan_points(scan)
        } else {
            Vec::new()
        };
        let view = View {
            id: self.id,
            t_secs: scan.t_secs,
            odom,
            neighbours: &estimates,
            trees: &trees,
            walls: &seen.segments,
            scan_points: &scan_points,
        };
        let out = self.pilot.step(&self.sc, &view);
        let cmd = Cmd {
            tick: scan.tick,
            kind: out.kind,
            x: out.xy.x as f32,
            y: out.xy.y as f32,
            yaw_rate: out.yaw_rate as f32,
        };
        let share = match (self.sc.localization.mode, gnss) {
            (LocalizationMode::Broadcast, Some(g)) => Some(Share::Pose(PoseShare {
                from: self.id,
                tick: g.tick,
                t_secs: g.t_secs,
                x: g.x,
                y: g.y,
                yaw: g.yaw,
                vx: g.vx,
                vy: g.vy,
            })),
            (LocalizationMode::Broadcast, None) | (LocalizationMode::Uvdar, _) => None,
            // seed 000 3.2: the obstacle set is what an agent shares, in its body frame.
            (LocalizationMode::Icp, _) => Some(Share::Obstacles(ObstacleShare {
                from: self.id,
                tick: scan.tick,
                t_secs: scan.t_secs,
                centres_cm: ObstacleShare::quantize(circles.iter().map(|c| [c.center.x, c.center.y])),
            })),
        };
        let state = AgentState {
            id: self.id,
            tick: scan.tick,
            t_secs: scan.t_secs,
            step_time_us: started.elapsed().as_micros().min(u128::from(u32::MAX)) as u32,
            obstacles: trees.len() as u32,
            neighbours: estimates
                .iter()
                .map(|e| NeighbourEstimate {
                    id: e.id,
                    x: e.pos_in_body.x as f32,
                    y: e.pos_in_body.y as f32,
                    heading: e.heading as f32,
                    age_secs: e.age_secs as f32,
                })
                .collect(),
            in_radio_range: 0,
            vectors: out.vectors,
            link: LinkCounters::default(),
            icp: icp_counts,
            delays: Vec::new(),
        };
        StepOutput { cmd, share, state }
    }

    /// Neighbour estimates for this step, and the ICP work it took (`icp` mode).
    fn localize(
        &mut self,
        now: f64,
        circles: &[perception::Circle],
        gnss: Option<&Gnss>,
        started: Instant,
    ) -> (Vec<Estimate>, IcpCounts) {
        match (self.sc.localization.mode, gnss) {
            (LocalizationMode::Broadcast, Some(g)) => {
                (self.table.estimates(g, self.sc.localization.stale_after_s), IcpCounts::default())
            }
            // Without its own fix a broadcast agent cannot place anyone: fly on obstacles alone.
            (LocalizationMode::Broadcast, None) => (Vec::new(), IcpCounts::default()),
            // UVDAR gives range and bearing of each marker seen this tick; no heading.
            (LocalizationMode::Uvdar, _) => {
                let seen = self.uvdar.as_ref().filter(|u| (u.t_secs - now).abs() < 1e-6);
                let estimates = seen
                    .map(|u| {
                        u.seen
                            .iter()
                            .map(|s| {
                                let (r, b) = (f64::from(s.range_m), f64::from(s.bearing_rad));
                                Estimate { id: Some(s.id), pos_in_body: r * Vector2::new(b.cos(), b.sin()), heading: 0.0, age_secs: 0.0 }
                            })
                            .collect()
                    })
                    .unwrap_or_default();
                (estimates, IcpCounts::default())
            }
            (LocalizationMode::Icp, _) => {
                let own: Vec<Point2<f64>> = circles.iter().map(|c| c.center).collect();
                let stale = self.sc.localization.stale_after_s;
                self.received.retain(|r| now - r.t_secs <= stale + 1e-9);
                // The step-time failsafe (seed 000 6.2) guards a realtime deadline. In lockstep the
                // hub waits for us, so there is none; and a wall-clock decision would make the run
                // depend on machine load instead of repeating exactly.
                let realtime = self.sc.time.mode == TimeMode::Realtime;
                let mut elapsed_ms = || if realtime { started.elapsed().as_secs_f64() * 1e3 } else { 0.0 };
                let c = self.db.step(now, &own, &self.received, &mut IcpMatcher(&self.sc.localization.icp), &mut elapsed_ms);
                let estimates = self.db.estimates(now).into_iter().map(Into::into).collect();
                let counts = IcpCounts {
                    short: c.short,
                    long: c.long,
                    initial: c.initial,
                    deferred: c.skipped_long,
                    entries: self.db.len() as u32,
                    suspended: self.db.suspended_len() as u32,
                };
                (estimates, counts)
            }
        }
    }

    /// Obstacle circles minus those that are a localized neighbour seen by the LIDAR.
    fn trees_only(&self, circles: &[perception::Circle], estimates: &[Estimate]) -> Vec<perception::Circle> {
        let m = self.sc.perception.neighbour_match_m;
        circles.iter().filter(|c| estimates.iter().all(|e| (e.pos_in_body - c.center.coords).norm() > m)).copied().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scenario() -> Scenario {
        swarm_config::builtin("open-field-5").expect("builtin")
    }

    fn empty_scan(tick: u64) -> Scan {
        Scan {
            tick,
            t_secs: tick as f64 * 0.1,
            angle_min: 0.0,
            angle_increment: std::f32::consts::TAU / 8.0,
            max_range_m: 12.0,
            ranges_m: vec![f32::INFINITY; 8],
        }
    }

    fn odom(goal: Option<[f64; 2]>) -> Odom {
        Odom { tick: 1, t_secs: 0.1, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal, goal_vel: None }
    }

    #[test]
    fn alone_in_open_field_an_informed_agent_flies_at_kf_toward_the_goal() {
        let mut a = Agent::new(1, scenario());
        let g = Gnss { tick: 1, t_secs: 0.1, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0 };
        let out = a.step(&empty_scan(1), &odom(Some([30.0, 0.0])), Some(&g));
        assert_eq!(out.cmd.tick, 1);
        assert!((out.cmd.x - 0.4).abs() < 1e-6 && out.cmd.y.abs() < 1e-6, "{:?}", out.cmd);
        assert!(out.cmd.yaw_rate.abs() < 1e-6);
        let share = out.share.expect("broadcast mode shares its pose");
        assert_eq!(share.from(), 1);
    }

    #[test]
    fn goal_to_the_left_turns_left() {
        let mut a = Agent::new(1, scenario());
        let out = a.step(&empty_scan(1), &odom(Some([0.0, 10.0])), None);
        assert!(out.cmd.yaw_rate > 0.0, "{:?}", out.cmd);
    }

    #[test]
    fn a_neighbour_seen_by_lidar_is_not_an_obstacle_and_own_pose_is_ignored() {
        let mut a = Agent::new(1, scenario());
        a.on_share(Share::Pose(PoseShare { from: 1, tick: 0, t_secs: 0.0, x: 9.0, y: 9.0, yaw: 0.0, vx: 0.0, vy: 0.0 }));
        a.on_share(Share::Pose(PoseShare { from: 2, tick: 0, t_secs: 0.0, x: 3.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0 }));
        let g = Gnss { tick: 1, t_secs: 0.1, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0 };
        let out = a.step(&empty_scan(1), &odom(None), Some(&g));
        assert_eq!(out.state.neighbours.len(), 1, "own echo ignored");
        assert_eq!(out.state.neighbours[0].id, Some(2));
        let circle = perception::Circle { center: nalgebra::Point2::new(3.05, 0.0), radius: 0.3 };
        let tree = perception::Circle { center: nalgebra::Point2::new(0.0, 5.0), radius: 0.3 };
        let (est, _) = a.localize(0.1, &[], Some(&g), Instant::now());
        let left = a.trees_only(&[circle, tree], &est);
        assert_eq!(left, vec![tree]);
    }
}
