//! One control step of the onboard stack, with no IO: a sensor frame and the neighbours' shares
//! delivered so far in; a command, a share message and a report out. The Zenoh loop in `node`
//! feeds it; tests and benchmarks call it directly.
//!
//! [`Agent::step`] is a pipeline of typed stages, each taking what the one before produced:
//!
//! 1. perception: the scan becomes circles, wall segments and points ([`perception::extract`]);
//! 2. localization: the mode's [`Localizer`] places the neighbours;
//! 3. the view: the obstacles minus the neighbours the LIDAR sees, built once ([`surroundings`]);
//! 4. control: the scenario's [`Controller`] turns the view into a command, which the [`LostContact`] layer
//!    replaces while the agent has lost its swarm;
//! 5. out: the command, the share the localizer sends, and a [`StepReport`] that becomes the
//!    agent's state message once the node adds what its link measured ([`StepReport::into_state`]).
//!
//! Architecture invariant: an agent sees the world only through its own sensor messages and its
//! neighbours' shares. Nothing here can reach ground truth.

use crate::control::{Arrival, Command, Controller, Controllers, Hops, LostContact, UnknownController, View};
use crate::localization::{Localizer, Share};
use crate::perception::{self, Extracted};
use crate::sensing::{Needs, SensorFrame};
use crate::world_model::{Body, Circle, Estimate};
use nalgebra::Point2;
use std::time::Instant;
use swarm_config::Scenario;
use swarm_types::UavId;
use swarm_wire::{AgentState, Cmd, DelaySample, IcpCounts, LinkCounters, NeighbourEstimate, Traffic, VectorMagnitudes};

/// What one step produces.
#[derive(Debug, Clone)]
pub struct StepOutput {
    /// The command for the hub.
    pub cmd: Cmd,
    /// The message to share with neighbours, if any.
    pub share: Option<Share>,
    /// What the step saw and did, for the state message.
    pub report: StepReport,
}

/// What one step saw and did: the agent's part of its state message.
#[derive(Debug, Clone, PartialEq)]
pub struct StepReport {
    /// Agent id.
    pub id: UavId,
    /// Tick of the step.
    pub tick: u64,
    /// Sim time [s].
    pub t_s: f64,
    /// Wall time the step took (perception + localization + control) [µs].
    pub step_time_us: u32,
    /// Obstacles that are not a neighbour.
    pub obstacles: u32,
    /// The neighbour estimates, body frame.
    pub neighbours: Vec<NeighbourEstimate>,
    /// Magnitudes of the controller's terms.
    pub vectors: VectorMagnitudes,
    /// ICP work (`icp` mode).
    pub icp: IcpCounts,
}

/// What the node's link layer measured, the rest of the state message.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinkReport {
    /// Neighbours in radio range (subscribed to).
    pub in_radio_range: u32,
    /// The link's counters, including this step's share.
    pub counters: LinkCounters,
    /// Delays of the shares delivered since the last report.
    pub delays: Vec<DelaySample>,
    /// What the agent's session received since it opened.
    pub traffic: Traffic,
}

impl StepReport {
    /// The agent's state message: this report and what the link measured, in one place.
    pub fn into_state(self, link: LinkReport) -> AgentState {
        AgentState {
            id: self.id,
            tick: self.tick,
            t_s: self.t_s,
            step_time_us: self.step_time_us,
            obstacles: self.obstacles,
            neighbours: self.neighbours,
            in_radio_range: link.in_radio_range,
            vectors: self.vectors,
            link: link.counters,
            icp: self.icp,
            delays: link.delays,
            traffic: link.traffic,
        }
    }
}

/// The onboard state of one UAV between steps.
pub struct Agent {
    id: UavId,
    sc: Scenario,
    /// The localization mode's localizer and what it keeps between steps.
    localizer: Localizer,
    /// The controller and what it keeps between steps.
    pilot: Box<dyn Controller>,
    /// Where the swarm was last estimated, and whether the agent has lost it.
    lost: LostContact,
    /// The hop counts to the nearest informed UAV heard in shares.
    hops: Hops,
    /// The hop counts of the last step: to the nearest informed UAV and the nearest arrived one.
    counts: (u8, u8),
    /// The hop counts to the nearest arrived UAV heard in shares.
    arrival: Arrival,
}

impl Agent {
    /// The agent of UAV `id` under scenario `sc`, flown by the controller of `controllers`
    /// the scenario names.
    pub fn new(id: UavId, sc: Scenario, controllers: &Controllers) -> Result<Agent, UnknownController> {
        let localizer = Localizer::new(id, &sc);
        let pilot = controllers.make(&sc)?;
        Ok(Agent {
            id,
            sc,
            localizer,
            pilot,
            lost: LostContact::new(),
            hops: Hops::default(),
            counts: (u8::MAX, u8::MAX),
            arrival: Arrival::default(),
        })
    }

    /// The UAV this agent flies.
    pub fn id(&self) -> UavId {
        self.id
    }

    /// The sensors a frame must carry for this agent's localizer.
    pub fn needs(&self) -> Needs {
        self.localizer.needs()
    }

    /// Takes a neighbour's share that the link has delivered (our own echo is ignored). By
    /// reference: on an agent host every listener gets the same decoded share, and the localizer
    /// keeps only what it needs of it.
    pub fn on_share(&mut self, share: &Share) {
        if share.from() != self.id {
            self.hops.hear(share.from(), share.hops(), share.t_s());
            self.arrival.hear(share.from(), share.arrival(), share.t_s());
        }
        self.localizer.receive(share);
    }

    /// The radio links to `senders` came up at sim time `t_s`: they entered our radio set (the
    /// caller's admission says who did). The `icp` mode's crowd rules may wait to place a
    /// neighbour just come into range (`crowd_new_links_wait`); the first call is the start.
    pub fn links_came_up(&mut self, senders: &[UavId], t_s: f64) {
        self.localizer.links_came_up(senders, t_s);
    }

    /// Runs perception, localization and control for one frame.
    pub fn step(&mut self, frame: &SensorFrame) -> StepOutput {
        let seen = self.perceive(frame);
        let command = self.pilot.step(&seen.view(self.id, frame));
        self.finish(frame, seen, command)
    }

    /// The hop counts of the last step (to the nearest informed UAV, to the nearest arrived one;
    /// `u8::MAX` for none, and before the first step): what an external controller's view carries.
    pub fn counts(&self) -> (u8, u8) {
        self.counts
    }

    /// The first half of a step: perception and localization, up to the [`View`] a controller
    /// gets ([`Perceived::view`]). An external controller answers it from outside the process;
    /// [`Agent::finish`] takes its command.
    pub fn perceive(&mut self, frame: &SensorFrame) -> Perceived {
        let started = Instant::now();
        let segments = perception::SegmentParams::default();
        let seen = perception::extract(&frame.scan, &self.sc.perception, &segments);
        let localized = self.localizer.localize(frame, &seen.circles, started);
        let max_rms_m = segments.circle_max_rms_m;
        let around = surroundings(&seen, &localized.estimates, &self.sc, max_rms_m, self.pilot.wants_scan_points());
        Perceived { started, seen, localized, around }
    }

    /// The second half of a step: the controller's `command` (replaced by the lost-contact
    /// layer while the swarm is lost, then by the arrival layer once this UAV has a path to an
    /// arrived one: that gradient leads to the goal, where a lost-contact flight back leads to
    /// where the swarm was), the share, and the report.
    pub fn finish(&mut self, frame: &SensorFrame, seen: Perceived, command: Command) -> StepOutput {
        let view = seen.view(self.id, frame);
        let now = frame.scan.t_s;
        let hops = self.hops.own(frame.odom.goal.is_some(), now, self.sc.lost_contact.max_hops);
        let arrival = self.arrival.own(&self.sc, &view, now);
        self.counts = (hops, arrival);
        let command = self.lost.steer(&self.sc, &view, hops, &self.hops, command);
        // An external controller's command is its own; only the built-in K21 gets the arrival.
        let external = self.sc.controller.external.contains(&self.id);
        let command = if external { command } else { self.arrival.steer(&self.sc, &view, arrival, command) };
        let share = self.localizer.share(frame, &seen.seen.circles).map(|s| s.with_counts(hops, arrival));
        let report = StepReport {
            id: self.id,
            tick: frame.tick(),
            t_s: frame.scan.t_s,
            step_time_us: seen.started.elapsed().as_micros().min(u128::from(u32::MAX)) as u32,
            obstacles: seen.around.trees.len() as u32,
            neighbours: seen.localized.estimates.iter().map(neighbour_estimate).collect(),
            vectors: command.vectors,
            icp: seen.localized.icp,
        };
        StepOutput { cmd: cmd_of(frame.tick(), &command), share, report }
    }
}

/// What a step perceived and localized, before control.
#[derive(Debug)]
pub struct Perceived {
    /// When the step began (wall clock): the step time runs to [`Agent::finish`].
    started: Instant,
    /// The scan's circles, segments and points.
    seen: Extracted,
    /// The neighbour estimates.
    localized: crate::localization::Localized,
    /// The obstacles once the neighbours are taken out.
    around: Surroundings,
}

impl Perceived {
    /// The controller's view of this step for UAV `id`.
    pub fn view<'a>(&'a self, id: UavId, frame: &'a SensorFrame) -> View<'a> {
        View {
            id,
            t_s: frame.scan.t_s,
            odom: &frame.odom,
            neighbours: &self.localized.estimates,
            trees: &self.around.trees,
            walls: &self.seen.segments,
            static_points: &self.around.static_points,
            near_bodies: &self.around.near_bodies,
        }
    }
}

/// The obstacles of a step once the neighbours the LIDAR sees are taken out of them.
#[derive(Debug, Clone, Default, PartialEq)]
struct Surroundings {
    /// Circles that are not a localized neighbour.
    trees: Vec<Circle>,
    /// Scan points that are not a localized neighbour (only when asked for: a map's input).
    static_points: Vec<Point2<f64>>,
    /// The bodies near the UAV in the groups that join several ([`surroundings`]).
    near_bodies: Vec<Body>,
}

/// Separates the neighbours from the obstacles `seen`, once for everything downstream: a circle
/// or point within `match_m` of a neighbour estimate is that neighbour. Also keeps the bodies
/// within reach of K21's barrier, neighbours or not, since a body is a body whoever it is: those
/// of the groups that join several, and the circle a neighbour was matched to when its centre is
/// within `barrier_m`. The circle is where the LIDAR sees the body now; the estimate may lag it
/// (a shared pose's age) or be off by up to `match_m` (ICP), and a UAV that steers by the
/// estimate alone can touch a neighbour standing still beside it (issue 46).
fn surroundings(
    seen: &Extracted,
    estimates: &[Estimate],
    sc: &Scenario,
    max_rms_m: f64,
    with_points: bool,
) -> Surroundings {
    let match_m = sc.perception.neighbour_match_m;
    let is_neighbour = |p: &Point2<f64>| estimates.iter().any(|e| (e.pos_in_body - p.coords).norm() <= match_m);
    let trees = seen.circles.iter().filter(|c| !is_neighbour(&c.center)).copied().collect();
    let static_points =
        if with_points { seen.points().filter(|p| !is_neighbour(p)).copied().collect() } else { Vec::new() };
    let k21 = &sc.controller.k21;
    let on = k21.barrier_on_bodies();
    let reach = if on { k21.barrier_m.max(k21.barrier_surface_m) } else { 0.0 };
    let mut near_bodies = perception::bodies::bodies(&seen.joined, reach, &sc.perception, max_rms_m);
    let neighbour_within_barrier =
        |c: &&Circle| on && c.center.coords.norm() < k21.barrier_m && is_neighbour(&c.center);
    let as_body = |c: &Circle| Body { nearest: c.nearest_point(), centre: Some(c.center.coords) };
    near_bodies.extend(seen.circles.iter().filter(neighbour_within_barrier).map(as_body));
    Surroundings { trees, static_points, near_bodies }
}

/// The pilot's command as the wire message of `tick`.
fn cmd_of(tick: u64, c: &Command) -> Cmd {
    Cmd { tick, kind: c.kind, x: c.xy.x as f32, y: c.xy.y as f32, yaw_rate: c.yaw_rate as f32 }
}

/// A neighbour estimate as the state message reports it.
fn neighbour_estimate(e: &Estimate) -> NeighbourEstimate {
    NeighbourEstimate {
        id: e.id,
        x: e.pos_in_body.x as f32,
        y: e.pos_in_body.y as f32,
        heading: e.heading as f32,
        age_s: e.age_s as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_wire::{Gnss, Odom, PoseShare, Scan};

    fn scenario() -> Scenario {
        swarm_config::builtin("open-field-5").expect("builtin")
    }

    fn frame(goal: Option<[f64; 2]>, gnss: Option<Gnss>) -> SensorFrame {
        let scan = Scan {
            tick: 1,
            t_s: 0.1,
            angle_min: 0.0,
            angle_increment: std::f32::consts::TAU / 8.0,
            max_range_m: 12.0,
            ranges_m: vec![f32::INFINITY; 8],
        };
        let odom = Odom { tick: 1, t_s: 0.1, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal, goal_vel: None };
        SensorFrame { scan, odom, gnss, uvdar: None }
    }

    fn fix() -> Gnss {
        Gnss { tick: 1, t_s: 0.1, x: 0.0, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0 }
    }

    #[test]
    fn alone_in_open_field_an_informed_agent_flies_at_kf_toward_the_goal() {
        let mut a = Agent::new(UavId::new(1), scenario(), &Controllers::builtin()).expect("agent");
        let out = a.step(&frame(Some([30.0, 0.0]), Some(fix())));
        assert_eq!(out.cmd.tick, 1);
        assert!((out.cmd.x - 0.4).abs() < 1e-6 && out.cmd.y.abs() < 1e-6, "{:?}", out.cmd);
        assert!(out.cmd.yaw_rate.abs() < 1e-6);
        let share = out.share.expect("broadcast mode shares its pose");
        assert_eq!(share.from(), UavId::new(1));
    }

    #[test]
    fn goal_to_the_left_turns_left() {
        let mut a = Agent::new(UavId::new(1), scenario(), &Controllers::builtin()).expect("agent");
        let out = a.step(&frame(Some([0.0, 10.0]), None));
        assert!(out.cmd.yaw_rate > 0.0, "{:?}", out.cmd);
        assert!(out.share.is_none(), "no fix, nothing to share");
    }

    #[test]
    fn own_pose_is_ignored() {
        let mut a = Agent::new(UavId::new(1), scenario(), &Controllers::builtin()).expect("agent");
        a.on_share(&Share::Pose(PoseShare {
            from: UavId::new(1),
            tick: 0,
            t_s: 0.0,
            x: 9.0,
            y: 9.0,
            yaw: 0.0,
            vx: 0.0,
            vy: 0.0,
            hops: 0,
            arrival: 0,
        }));
        a.on_share(&Share::Pose(PoseShare {
            from: UavId::new(2),
            tick: 0,
            t_s: 0.0,
            x: 3.0,
            y: 0.0,
            yaw: 0.0,
            vx: 0.0,
            vy: 0.0,
            hops: 0,
            arrival: 0,
        }));
        let out = a.step(&frame(None, Some(fix())));
        assert_eq!(out.report.neighbours.len(), 1, "own echo ignored");
        assert_eq!(out.report.neighbours[0].id, Some(UavId::new(2)));
    }

    #[test]
    fn a_neighbour_seen_by_lidar_is_not_an_obstacle() {
        let neighbour = Estimate {
            id: Some(UavId::new(2)),
            pos_in_body: nalgebra::Vector2::new(3.0, 0.0),
            heading: 0.0,
            age_s: 0.0,
        };
        let circle = Circle { center: Point2::new(3.05, 0.0), radius: 0.3 };
        let tree = Circle { center: Point2::new(0.0, 5.0), radius: 0.3 };
        let seen = Extracted {
            circles: vec![circle, tree],
            segments: Vec::new(),
            beams: vec![Some(circle.center), Some(tree.center)],
            joined: Vec::new(),
        };
        let mut sc = scenario();
        sc.perception.neighbour_match_m = 0.5;
        let around = surroundings(&seen, &[neighbour], &sc, 0.06, true);
        assert_eq!(around, Surroundings { trees: vec![tree], static_points: vec![tree.center], near_bodies: vec![] });
        assert!(surroundings(&seen, &[neighbour], &sc, 0.06, false).static_points.is_empty());
    }

    #[test]
    fn a_neighbours_circle_within_the_barrier_is_a_body_where_the_lidar_sees_it() {
        // ICP places the neighbour 0.45 m off where the LIDAR sees it, 0.8 m ahead: the circle
        // is that neighbour (within match_m), and a body of the barrier at the LIDAR's place.
        let neighbour = Estimate { id: None, pos_in_body: nalgebra::Vector2::new(0.8, 0.45), heading: 0.0, age_s: 0.0 };
        let seen_at = |x: f64| {
            let circle = Circle { center: Point2::new(x, 0.0), radius: 0.3 };
            Extracted { circles: vec![circle], segments: Vec::new(), beams: vec![Some(circle.center)], joined: vec![] }
        };
        let sc = scenario();
        let around = surroundings(&seen_at(0.8), &[neighbour], &sc, 0.06, false);
        assert!(around.trees.is_empty(), "a neighbour, not a tree: {around:?}");
        let b = around.near_bodies.first().copied().expect("a body");
        assert_eq!(around.near_bodies.len(), 1);
        assert!((b.centre.expect("centre") - nalgebra::Vector2::new(0.8, 0.0)).norm() < 1e-12, "{b:?}");
        assert!((b.nearest - nalgebra::Vector2::new(0.5, 0.0)).norm() < 1e-12, "{b:?}");
        // Beyond barrier_m (1 m) it is the neighbour alone, as before.
        let far = Estimate { pos_in_body: nalgebra::Vector2::new(1.2, 0.45), ..neighbour };
        assert!(surroundings(&seen_at(1.2), &[far], &sc, 0.06, false).near_bodies.is_empty());
        // And nothing with the barrier off.
        let mut off = scenario();
        off.controller.k21.barrier_m = 0.0;
        assert!(surroundings(&seen_at(0.8), &[neighbour], &off, 0.06, false).near_bodies.is_empty());
    }

    /// A noiseless 750-beam scan of discs (x, y, r), body frame.
    fn scan_of(discs: &[(f64, f64, f64)]) -> Scan {
        perception::tests::synthetic_scan(750, 0.0, discs, None)
    }

    #[test]
    fn a_uav_joined_into_a_crowds_group_is_a_body_of_its_own() {
        // A UAV (0.3 m radius) 0.72 m ahead in a crowd 0.72-0.9 m apart: seed 000's grouping
        // joins them into one group, whose fitted circle lies 1.13 m off (forest-100-icp's goal
        // point). The UAV straddles beam 0, so the group is also joined across the scan's wrap.
        let crowd = [(0.72, 0.0, 0.3), (1.0, 0.85, 0.3), (1.0, -0.85, 0.3), (1.6, 0.45, 0.3), (1.6, -0.45, 0.3)];
        let sc = scenario();
        let seen = perception::extract(&scan_of(&crowd), &sc.perception, &perception::SegmentParams::default());
        assert!(
            seen.circles.iter().all(|c| c.center.coords.norm() >= 1.0),
            "the barrier on circle centres misses it: {:?}",
            seen.circles
        );
        let around = surroundings(&seen, &[], &sc, 0.06, false);
        let ahead = nalgebra::Vector2::new(0.72, 0.0);
        assert!(
            around.near_bodies.iter().any(|b| b.centre.is_some_and(|c| (c - ahead).norm() < 0.01)),
            "{:?}",
            around.near_bodies
        );
        // Off with barrier_surface_m = 0.
        let mut off = scenario();
        off.controller.k21.barrier_surface_m = 0.0;
        assert!(surroundings(&seen, &[], &off, 0.06, false).near_bodies.is_empty());
        // Trunks 2 m or more apart, one 0.8 m off: each its own group, nothing joined.
        let trees = [(0.0, 1.1, 0.3), (2.0, 1.5, 0.3), (-1.5, -1.8, 0.2)];
        let seen = perception::extract(&scan_of(&trees), &sc.perception, &perception::SegmentParams::default());
        assert_eq!(seen.circles.len(), 3);
        assert!(surroundings(&seen, &[], &sc, 0.06, false).near_bodies.is_empty());
    }

    #[test]
    fn the_state_message_joins_the_step_and_the_link() {
        let mut a = Agent::new(UavId::new(1), scenario(), &Controllers::builtin()).expect("agent");
        let out = a.step(&frame(None, Some(fix())));
        let link = LinkReport {
            in_radio_range: 3,
            counters: LinkCounters { sent_msgs: 1, ..LinkCounters::default() },
            ..LinkReport::default()
        };
        let state = out.report.clone().into_state(link);
        assert_eq!((state.id, state.tick, state.in_radio_range, state.link.sent_msgs), (UavId::new(1), 1, 3, 1));
        assert_eq!(state.vectors, out.report.vectors);
    }
}
