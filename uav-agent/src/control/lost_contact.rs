//! Lost contact: what every controller does once the agent has had no neighbour estimate for a
//! while (the behaviour and its parameters: `swarm_config::LostContactParams`).
//!
//! Why a layer of its own, after the controller: a flocking controller with no neighbour has
//! nothing to flock to, and each seed's controller then does its own thing (K21 flies on along
//! its body x axis for ever). This layer watches the neighbour estimates, remembers where the
//! swarm was last estimated in the agent's odometry frame, and once the agent is lost replaces
//! the controller's command: a slow flight back there with seed 000's obstacle avoidance on the
//! trees and walls of the scan, then a hover until a neighbour is estimated again (or, when the
//! scenario sets `search_after_s`, once held that long, a flight on the way it last travelled
//! with a path: the swarm may have gone on beyond radio range). The
//! controller still runs every step, so its maps and memory stay current for when contact is
//! back. Nothing here reads ground truth: odometry, the scan and the estimates only.

use super::controller::{Command, View};
use super::detour::Detour;
use super::hops::Hops;
use super::pilot::{bearing_in_body, k21_command};
use nalgebra::{Rotation2, Vector2};
use swarm_config::{ControllerKind, Scenario};

/// What the layer does this step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    /// In contact (or not lost long enough, or informed): the controller's command.
    Flock,
    /// Lost, but the swarm is heard beyond the controller's reach: fly towards the centroid of
    /// those estimates (odometry frame) [m], at K21's speed.
    Approach(Vector2<f64>),
    /// Lost and hearing no one: fly back to where the swarm was last estimated (odometry
    /// frame) [m], slowly.
    Return(Vector2<f64>),
    /// Lost and back where the swarm was: hover and wait.
    Hold,
    /// In contact, but the group has had no path to an informed UAV for a while: fly back to
    /// where this UAV last had one (odometry frame) [m], flocking, at the flock's speed.
    Regroup(Vector2<f64>),
    /// A path, but every neighbour closer to the informed (a lower hop count) is beyond the
    /// controller's reach, and has been for `after_s`: fly, flocking, towards the nearest of
    /// them (odometry frame) [m].
    Follow(Vector2<f64>),
    /// Held for `search_after_s`: fly on to `to` (odometry frame) [m], the way this UAV last
    /// travelled with a path; `with_group` flocking at K21's speed, else alone at `speed_mps`.
    Search { to: Vector2<f64>, with_group: bool },
}

/// The time constant of the travel direction's smoothing [s]: long against avoidance's swerves
/// round a trunk (a few seconds), short against a flight of minutes.
const TRAVEL_TAU_S: f64 = 10.0;

/// The layer's memory between steps.
#[derive(Debug, Default)]
pub struct LostContact {
    /// Sim time of the last step with a neighbour estimate within reach [s].
    last_contact_s: Option<f64>,
    /// Centroid of the last neighbour estimates, odometry frame [m].
    swarm_odom: Option<Vector2<f64>>,
    /// Reached the place: hover until contact is back (sticky, so a hover's drift does not
    /// start a new flight).
    holding: bool,
    /// Sim time of the last step with a path to an informed UAV [s].
    last_path_s: Option<f64>,
    /// Where this UAV last had a path to an informed UAV, odometry frame [m].
    path_odom: Option<Vector2<f64>>,
    /// Back where the group last had a path: hover until it has one again (sticky).
    regroup_holding: bool,
    /// Sim time of the last step with a neighbour closer to the informed within reach, or with
    /// no path at all [s].
    led_s: Option<f64>,
    /// Where this UAV was then, odometry frame [m].
    led_odom: Option<Vector2<f64>>,
    /// Own velocity while it had a path, smoothed over [`TRAVEL_TAU_S`], odometry frame [m/s],
    /// and when it was last updated [s].
    travel: Option<(Vector2<f64>, f64)>,
    /// Since when it has held (alone or with its group) [s].
    hold_since_s: Option<f64>,
    /// Where the search flies to, odometry frame [m], and whether it got there.
    search: Option<(Vector2<f64>, bool)>,
    /// The flights' way out of a shut gap (K21's opt-in detour).
    detour: Detour,
    /// The kind of the last phase, to log its changes.
    last_kind: Option<std::mem::Discriminant<Phase>>,
}

/// The distance within which a neighbour estimate is contact: the scenario's, or the reach of
/// its controller (K21 ignores neighbours beyond `neighbour_radius_m`; the others' cohesion pulls
/// at any range).
fn contact_radius_m(sc: &Scenario) -> f64 {
    sc.lost_contact.contact_radius_m.unwrap_or(match sc.controller.kind {
        ControllerKind::K21 => sc.controller.k21.neighbour_radius_m,
        _ => f64::INFINITY,
    })
}

impl LostContact {
    /// A layer that has seen no neighbour yet.
    pub fn new() -> LostContact {
        LostContact::default()
    }

    /// Notes this step's neighbour estimates and hop count (see [`crate::control::hops`]) and
    /// decides the phase.
    /// `heard`: the counts heard in shares, by sender (each estimate's count is its sender's).
    pub fn phase(&mut self, sc: &Scenario, v: &View, hops: u8, heard: &Hops) -> Phase {
        let phase = self.hold_or_go(sc, v, hops, heard);
        if !matches!(phase, Phase::Hold | Phase::Search { .. }) {
            (self.hold_since_s, self.search) = (None, None);
        }
        phase
    }

    /// [`Self::phase`] before the search's memory is cleared.
    fn hold_or_go(&mut self, sc: &Scenario, v: &View, hops: u8, heard: &Hops) -> Phase {
        let p = &sc.lost_contact;
        let p0 = Vector2::new(v.odom.x, v.odom.y);
        if hops < p.max_hops {
            self.last_path_s = Some(v.t_s);
            self.path_odom = Some(p0);
            self.note_travel(v);
        }
        if !v.neighbours.is_empty() {
            let n = v.neighbours.len() as f64;
            let centroid_body = v.neighbours.iter().map(|e| e.pos_in_body).sum::<Vector2<f64>>() / n;
            self.swarm_odom = Some(p0 + Rotation2::new(v.odom.yaw) * centroid_body);
            self.holding = false;
            let reach = contact_radius_m(sc);
            if v.neighbours.iter().any(|e| e.pos_in_body.norm() <= reach) {
                self.last_contact_s = Some(v.t_s);
                return self.group_phase(sc, v, p0, hops, heard);
            }
        }
        let (Some(since), Some(target)) = (self.last_contact_s, self.swarm_odom) else { return Phase::Flock };
        let informed_flies_on = v.odom.goal.is_some() && !p.informed_return;
        if !p.enabled || informed_flies_on || v.t_s - since < p.after_s - 1e-9 {
            return Phase::Flock;
        }
        if !v.neighbours.is_empty() {
            return Phase::Approach(target);
        }
        match hold_at(&mut self.holding, target, p0, p.hold_radius_m, Phase::Return(target)) {
            Phase::Hold => self.search_phase(sc, v.t_s, p0, false),
            going => going,
        }
    }

    /// Smooths own odometry velocity into the travel direction (first-order, [`TRAVEL_TAU_S`]).
    fn note_travel(&mut self, v: &View) {
        let vel = Vector2::new(v.odom.vx, v.odom.vy);
        self.travel = Some(match self.travel {
            None => (vel, v.t_s),
            Some((old, t)) => {
                let a = ((v.t_s - t) / TRAVEL_TAU_S).clamp(0.0, 1.0);
                (old + a * (vel - old), v.t_s)
            }
        });
    }

    /// Holding since `hold_since_s`: hover, or once that has lasted `search_after_s`, fly on
    /// `search_distance_m` along the travel direction, then hover there (sticky until the
    /// phase is neither). No search without a travel direction (no path ever, or hardly moving).
    fn search_phase(&mut self, sc: &Scenario, now: f64, p0: Vector2<f64>, with_group: bool) -> Phase {
        let p = &sc.lost_contact;
        let since = *self.hold_since_s.get_or_insert(now);
        if p.search_after_s <= 0.0 || now - since < p.search_after_s - 1e-9 {
            return Phase::Hold;
        }
        let Some(travel) = self.travel.map(|(t, _)| t).filter(|t| t.norm() > 0.05) else { return Phase::Hold };
        let (to, arrived) = self.search.get_or_insert((p0 + travel.normalize() * p.search_distance_m, false));
        *arrived |= (*to - p0).norm() <= p.hold_radius_m;
        if *arrived {
            Phase::Hold
        } else {
            Phase::Search { to: *to, with_group }
        }
    }

    /// In contact: flock, unless the group has had no path to an informed UAV for
    /// `regroup_after_s` (and this UAV is uninformed and once had one); then back to where it
    /// last had one, and hover there (sticky) until a path is back. With a path but no
    /// neighbour closer to the informed within reach for `after_s`, follow the nearest such
    /// neighbour beyond reach ([`Phase::Follow`]): flocking alone follows nobody out of reach.
    fn group_phase(&mut self, sc: &Scenario, v: &View, p0: Vector2<f64>, hops: u8, heard: &Hops) -> Phase {
        let p = &sc.lost_contact;
        let (Some(since), Some(target)) = (self.last_path_s, self.path_odom) else { return Phase::Flock };
        if !p.enabled || p.regroup_after_s <= 0.0 || v.odom.goal.is_some() {
            return Phase::Flock;
        }
        if v.t_s - since < p.regroup_after_s - 1e-9 {
            self.regroup_holding = false;
            return self.follow_phase(sc, v, p0, hops, heard);
        }
        match hold_at(&mut self.regroup_holding, target, p0, p.hold_radius_m, Phase::Regroup(target)) {
            Phase::Hold => self.search_phase(sc, v.t_s, p0, true),
            going => going,
        }
    }

    /// With a path: flock while a neighbour with a lower count is within reach (or none is
    /// localized, or not for `after_s` yet); else towards the nearest one beyond reach. With
    /// `lead_in_sight`, none localized for `after_s` is not led either: back to where it last
    /// was, hovering there (and searching, as a group with no path).
    fn follow_phase(&mut self, sc: &Scenario, v: &View, p0: Vector2<f64>, hops: u8, heard: &Hops) -> Phase {
        let p = &sc.lost_contact;
        let reach = contact_radius_m(sc);
        let nearest = heard.nearest_lower(v.neighbours, hops);
        let unseen = p.lead_in_sight && hops < p.max_hops;
        let led = hops >= p.max_hops || nearest.map_or(!unseen, |n| n.norm() <= reach);
        if led || self.led_s.is_none() {
            (self.led_s, self.led_odom) = (Some(v.t_s), Some(p0));
        }
        let long = v.t_s - self.led_s.unwrap_or(v.t_s) >= p.after_s - 1e-9;
        match (nearest, self.led_odom) {
            (Some(n), _) if !led && long => Phase::Follow(p0 + Rotation2::new(v.odom.yaw) * n),
            // The path runs through UAVs it hears but does not localize (ICP among few shared
            // trees): nobody to follow, so back to where it was last led, as a group with no path.
            (None, Some(target)) if !led && long => {
                match hold_at(&mut self.regroup_holding, target, p0, p.hold_radius_m, Phase::Regroup(target)) {
                    Phase::Hold => self.search_phase(sc, v.t_s, p0, true),
                    going => going,
                }
            }
            _ => Phase::Flock,
        }
    }

    /// The command of this step: the controller's (`flock`) unless the agent, or its group,
    /// is lost; `hops` is this step's hop count to the nearest informed UAV.
    pub fn steer(&mut self, sc: &Scenario, v: &View, hops: u8, heard: &Hops, flock: Command) -> Command {
        let phase = self.phase(sc, v, hops, heard);
        let kind = Some(std::mem::discriminant(&phase));
        if kind != self.last_kind {
            self.last_kind = kind;
            tracing::debug!(t_s = v.t_s, ?phase, hops, "lost contact: a new phase");
        }
        let detour = &mut self.detour;
        match phase {
            Phase::Flock => flock,
            Phase::Regroup(target) | Phase::Follow(target) => regroup(sc, v, target, detour),
            Phase::Hold => Command::hover(),
            Phase::Approach(target) => fly_to(sc, v, target, sc.controller.k21.kf, detour),
            Phase::Return(target) | Phase::Search { to: target, with_group: false } => {
                fly_to(sc, v, target, sc.lost_contact.speed_mps, detour)
            }
            Phase::Search { to, with_group: true } => regroup(sc, v, to, detour),
        }
    }
}

/// Hover once within `radius_m` of `target` (sticky through `holding`, so a hover's drift
/// does not start a new flight), else `going` (`p0`: where the UAV is, odometry frame).
fn hold_at(holding: &mut bool, target: Vector2<f64>, p0: Vector2<f64>, radius_m: f64, going: Phase) -> Phase {
    *holding |= (target - p0).norm() <= radius_m;
    if *holding {
        Phase::Hold
    } else {
        going
    }
}

/// The flight to the swarm: K21 with no neighbour and the place as its goal (seed 000 eq.
/// 4.14–4.17 turn the UAV towards it and avoid the closest obstacle, eq. 4.10–4.13), scaled from
/// K21's speed `kf` to `speed_mps`. Wall faces count as obstacles at their point nearest the UAV.
fn fly_to(sc: &Scenario, v: &View, target_odom: Vector2<f64>, speed_mps: f64, detour: &mut Detour) -> Command {
    let heading = bearing_in_body(v.odom, [target_odom.x, target_odom.y]);
    let mut c = k21_command(&sc.controller.k21, v, &[], Some(heading), &wall_points(v), detour);
    let scale = speed_mps / sc.controller.k21.kf;
    c.xy *= scale;
    c.vectors.output = c.xy.norm() as f32;
    c
}

/// The group's flight back: K21 with the neighbours and the place as its goal, as an informed
/// UAV of seed 000 flies to its goal (eq. 4.1–4.17), at K21's speed.
fn regroup(sc: &Scenario, v: &View, target_odom: Vector2<f64>, detour: &mut Detour) -> Command {
    let heading = bearing_in_body(v.odom, [target_odom.x, target_odom.y]);
    k21_command(&sc.controller.k21, v, v.neighbours, Some(heading), &wall_points(v), detour)
}

/// The point of each wall face nearest the UAV, body frame [m].
fn wall_points(v: &View) -> Vec<Vector2<f64>> {
    v.walls
        .iter()
        .map(|s| {
            let (a, ab) = (s.a.coords, s.b.coords - s.a.coords);
            let t = if ab.norm_squared() > 0.0 { (-a.dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0) } else { 0.0 };
            a + t * ab
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world_model::{Circle, Estimate};
    use nalgebra::Point2;
    use swarm_types::UavId;
    use swarm_wire::NO_PATH;
    use swarm_wire::{CmdKind, Odom, VectorMagnitudes};

    fn scenario() -> Scenario {
        swarm_config::builtin("forest-5").expect("builtin")
    }

    fn odom(x: f64, y: f64, yaw: f64, goal: Option<[f64; 2]>) -> Odom {
        Odom { tick: 0, t_s: 0.0, x, y, yaw, vx: 0.0, vy: 0.0, goal, goal_vel: None }
    }

    fn view<'a>(t: f64, o: &'a Odom, n: &'a [Estimate], trees: &'a [Circle]) -> View<'a> {
        View {
            id: UavId::new(1),
            t_s: t,
            odom: o,
            neighbours: n,
            trees,
            walls: &[],
            static_points: &[],
            near_bodies: &[],
        }
    }

    fn flock() -> Command {
        Command {
            kind: CmdKind::Velocity,
            xy: Vector2::new(0.4, 0.0),
            yaw_rate: 0.0,
            vectors: VectorMagnitudes::default(),
        }
    }

    fn neighbour(x: f64, y: f64) -> Estimate {
        Estimate { id: Some(UavId::new(2)), pos_in_body: Vector2::new(x, y), heading: 0.0, age_s: 0.0 }
    }

    #[test]
    fn lost_after_the_delay_it_flies_back_slowly_then_holds() {
        let sc = scenario();
        let after = sc.lost_contact.after_s;
        let mut l = LostContact::new();
        // Heading +y at (0, 0), neighbours 2 m ahead and 2 m left-ahead: centroid (−1, 2) in odometry.
        let o = odom(0.0, 0.0, std::f64::consts::FRAC_PI_2, None);
        assert_eq!(
            l.phase(&sc, &view(0.0, &o, &[neighbour(2.0, 0.0), neighbour(2.0, 2.0)], &[]), NO_PATH, &Hops::default()),
            Phase::Flock
        );
        let far = odom(0.0, 10.0, std::f64::consts::FRAC_PI_2, None);
        assert_eq!(
            l.phase(&sc, &view(after - 0.1, &far, &[], &[]), NO_PATH, &Hops::default()),
            Phase::Flock,
            "not lost yet"
        );
        match l.phase(&sc, &view(after, &far, &[], &[]), NO_PATH, &Hops::default()) {
            Phase::Return(t) => assert!((t - Vector2::new(-1.0, 2.0)).norm() < 1e-9, "{t}"),
            other => panic!("{other:?}"),
        }
        let c = l.steer(&sc, &view(after + 0.1, &far, &[], &[]), NO_PATH, &Hops::default(), flock());
        assert!(c.xy.norm() <= sc.lost_contact.speed_mps + 1e-9 && c.yaw_rate.abs() > 0.0, "turns back, slowly: {c:?}");
        let there = odom(-1.0, 2.5, 0.0, None);
        assert_eq!(l.phase(&sc, &view(after + 20.0, &there, &[], &[]), NO_PATH, &Hops::default()), Phase::Hold);
        let c = l.steer(
            &sc,
            &view(after + 20.1, &odom(-1.0, 4.0, 0.0, None), &[], &[]),
            NO_PATH,
            &Hops::default(),
            flock(),
        );
        assert_eq!(c.kind, CmdKind::Hover, "holding is sticky");
        let back =
            l.steer(&sc, &view(after + 21.0, &there, &[neighbour(3.0, 0.0)], &[]), NO_PATH, &Hops::default(), flock());
        assert_eq!(back, flock(), "contact again: the controller flies");
    }

    #[test]
    fn a_uav_whose_way_to_the_informed_is_beyond_reach_follows_it_after_the_delay() {
        let sc = scenario();
        let after = sc.lost_contact.after_s;
        let reach = sc.controller.k21.neighbour_radius_m;
        // UAV 3 within reach has our count; UAV 2, one hop nearer an informed UAV, is beyond reach.
        let mate = Estimate { id: Some(UavId::new(3)), ..neighbour(2.0, 0.0) };
        let ahead = Estimate { id: Some(UavId::new(2)), ..neighbour(reach + 3.0, 1.0) };
        let mut heard = Hops::default();
        heard.hear(UavId::new(3), 2, 0.0);
        heard.hear(UavId::new(2), 1, 0.0);
        let o = odom(0.0, 0.0, 0.0, None);
        let mut l = LostContact::new();
        assert_eq!(l.phase(&sc, &view(0.0, &o, &[mate, ahead], &[]), 2, &heard), Phase::Flock, "not for after_s yet");
        assert_eq!(
            l.phase(&sc, &view(after, &o, &[mate, ahead], &[]), 2, &heard),
            Phase::Follow(Vector2::new(reach + 3.0, 1.0))
        );
        let near = Estimate { id: Some(UavId::new(2)), ..neighbour(3.0, 1.0) };
        assert_eq!(
            l.phase(&sc, &view(after + 0.1, &o, &[mate, near], &[]), 2, &heard),
            Phase::Flock,
            "within reach: flock"
        );
        heard.hear(UavId::new(2), 2, 0.1);
        assert_eq!(
            l.phase(&sc, &view(2.0 * after + 1.0, &o, &[mate, ahead], &[]), 2, &heard),
            Phase::Flock,
            "nobody nearer the informed"
        );
    }

    #[test]
    fn with_the_lead_in_sight_a_path_through_nobody_localized_turns_it_back_to_where_it_was_led() {
        let mut sc = scenario();
        sc.lost_contact.lead_in_sight = true;
        let after = sc.lost_contact.after_s;
        // UAV 3 within reach has our count 2; UAV 2 has count 1: localized at first, then only heard.
        let mate = Estimate { id: Some(UavId::new(3)), ..neighbour(2.0, 0.0) };
        let lead = Estimate { id: Some(UavId::new(2)), ..neighbour(3.0, 1.0) };
        let mut heard = Hops::default();
        heard.hear(UavId::new(3), 2, 0.0);
        heard.hear(UavId::new(2), 1, 0.0);
        let at = |x: f64| odom(x, 0.0, 0.0, None);
        let mut l = LostContact::new();
        let (o0, o4) = (at(0.0), at(4.0));
        assert_eq!(l.phase(&sc, &view(0.0, &o0, &[mate, lead], &[]), 2, &heard), Phase::Flock, "led");
        let off = LostContact::new();
        for (t, expected) in
            [(0.1, Phase::Flock), (after - 0.1, Phase::Flock), (after, Phase::Regroup(Vector2::zeros()))]
        {
            heard.hear(UavId::new(2), 1, t);
            heard.hear(UavId::new(3), 2, t);
            assert_eq!(l.phase(&sc, &view(t, &o4, &[mate], &[]), 2, &heard), expected, "at {t} s");
        }
        // Back where it was led: it holds there, as a group with no path does.
        let o_back = at(0.5);
        assert_eq!(l.phase(&sc, &view(after + 5.0, &o_back, &[mate], &[]), 2, &heard), Phase::Hold);
        // Its leader in sight again: it flocks.
        assert_eq!(l.phase(&sc, &view(after + 5.1, &o_back, &[mate, lead], &[]), 2, &heard), Phase::Flock);

        // Off (the default): a path heard is a path, and it flocks on.
        let (sc, mut l) = (scenario(), off);
        assert!(!sc.lost_contact.lead_in_sight);
        assert_eq!(l.phase(&sc, &view(0.0, &o0, &[mate, lead], &[]), 2, &heard), Phase::Flock);
        assert_eq!(l.phase(&sc, &view(after + 1.0, &o4, &[mate], &[]), 2, &heard), Phase::Flock);
    }

    #[test]
    fn a_group_without_a_path_to_the_informed_flies_back_flocking_and_holds() {
        let sc = scenario();
        let after = sc.lost_contact.regroup_after_s;
        let mut l = LostContact::new();
        let mates = [neighbour(2.0, 0.0), neighbour(0.0, 2.0)];
        assert_eq!(
            l.phase(&sc, &view(0.0, &odom(3.0, 0.0, 0.0, None), &mates, &[]), 4, &Hops::default()),
            Phase::Flock,
            "a path: flock"
        );
        let on = odom(8.0, 0.0, 0.0, None);
        assert_eq!(
            l.phase(&sc, &view(after - 0.1, &on, &mates, &[]), NO_PATH, &Hops::default()),
            Phase::Flock,
            "not for long enough"
        );
        assert_eq!(
            l.phase(&sc, &view(after, &on, &mates, &[]), NO_PATH, &Hops::default()),
            Phase::Regroup(Vector2::new(3.0, 0.0))
        );
        let c = l.steer(&sc, &view(after, &on, &mates, &[]), NO_PATH, &Hops::default(), flock());
        assert!(
            c.yaw_rate.abs() > 0.0 && c.vectors.cohesion + c.vectors.separation > 0.0,
            "turns back, still flocking: {c:?}"
        );
        let there = odom(3.5, 0.0, 0.0, None);
        assert_eq!(l.phase(&sc, &view(after + 20.0, &there, &mates, &[]), NO_PATH, &Hops::default()), Phase::Hold);
        assert_eq!(
            l.phase(&sc, &view(after + 21.0, &odom(5.0, 0.0, 0.0, None), &mates, &[]), NO_PATH, &Hops::default()),
            Phase::Hold,
            "sticky"
        );
        assert_eq!(
            l.phase(&sc, &view(after + 22.0, &there, &mates, &[]), 3, &Hops::default()),
            Phase::Flock,
            "a path again: flock"
        );
        let informed = odom(8.0, 0.0, 0.0, Some([30.0, 0.0]));
        let mut i = LostContact::new();
        i.phase(&sc, &view(0.0, &informed, &mates, &[]), 0, &Hops::default());
        assert_eq!(
            i.phase(&sc, &view(100.0, &informed, &mates, &[]), NO_PATH, &Hops::default()),
            Phase::Flock,
            "the informed fly on"
        );
        let mut never = LostContact::new();
        assert_eq!(
            never.phase(&sc, &view(100.0, &on, &mates, &[]), NO_PATH, &Hops::default()),
            Phase::Flock,
            "never had a path: nowhere to go"
        );
    }

    /// A UAV flying +x with a path at `vx` from t = 0 to 20 s, then a group without a path.
    fn flown_with_a_path(l: &mut LostContact, sc: &Scenario, mates: &[Estimate], vx: f64) {
        for k in 0..=200 {
            let t = k as f64 * 0.1;
            let o = Odom { vx, ..odom(t * vx, 0.0, 0.0, None) };
            l.phase(sc, &view(t, &o, mates, &[]), 2, &Hops::default());
        }
    }

    #[test]
    fn a_group_held_for_search_after_s_flies_on_the_way_it_travelled_then_holds() {
        let mut sc = scenario();
        sc.lost_contact.search_after_s = 30.0;
        let (after, hold) = (sc.lost_contact.regroup_after_s, sc.lost_contact.search_after_s);
        let mates = [neighbour(1.0, 3.0), neighbour(1.0, -3.0)];
        let mut l = LostContact::new();
        flown_with_a_path(&mut l, &sc, &mates, 0.4);
        // Last path at (8, 0) at 20 s; back there (held) from 20 + after on.
        let there = odom(8.0, 0.0, 0.0, None);
        let at =
            |l: &mut LostContact, t: f64, o: &Odom| l.phase(&sc, &view(t, o, &mates, &[]), NO_PATH, &Hops::default());
        assert_eq!(at(&mut l, 20.0 + after, &there), Phase::Hold);
        assert_eq!(at(&mut l, 20.0 + after + hold - 0.1, &there), Phase::Hold, "not held for long enough");
        let to = Vector2::new(8.0 + sc.lost_contact.search_distance_m, 0.0);
        assert_eq!(at(&mut l, 20.0 + after + hold, &there), Phase::Search { to, with_group: true });
        let c = l.steer(&sc, &view(20.0 + after + hold, &there, &mates, &[]), NO_PATH, &Hops::default(), flock());
        assert!(c.xy.x > sc.lost_contact.speed_mps, "on at the flock's speed, not the lone search's: {c:?}");
        let arrived = odom(to.x - 0.5, 0.0, 0.0, None);
        assert_eq!(at(&mut l, 100.0, &arrived), Phase::Hold, "there: hold");
        assert_eq!(at(&mut l, 101.0, &there), Phase::Hold, "sticky");
        assert_eq!(l.phase(&sc, &view(102.0, &there, &mates, &[]), 3, &Hops::default()), Phase::Flock, "a path again");
        // Off by default; and no search for a UAV that hardly moved while it had a path.
        let mut off = LostContact::new();
        let default = scenario();
        flown_with_a_path(&mut off, &default, &mates, 0.4);
        let held = |l: &mut LostContact, sc: &Scenario, t: f64| {
            l.phase(sc, &view(t, &there, &mates, &[]), NO_PATH, &Hops::default())
        };
        assert_eq!(held(&mut off, &default, 20.0 + after), Phase::Hold);
        assert_eq!(held(&mut off, &default, 500.0), Phase::Hold, "search off: holds for good");
        let mut still = LostContact::new();
        flown_with_a_path(&mut still, &sc, &mates, 0.0);
        let here = odom(0.0, 0.0, 0.0, None);
        assert_eq!(still.phase(&sc, &view(20.0 + after, &here, &mates, &[]), NO_PATH, &Hops::default()), Phase::Hold);
        assert_eq!(
            still.phase(&sc, &view(500.0, &here, &mates, &[]), NO_PATH, &Hops::default()),
            Phase::Hold,
            "no way"
        );
    }

    #[test]
    fn a_uav_lost_alone_searches_on_its_own_at_the_slow_speed() {
        let mut sc = scenario();
        sc.lost_contact.search_after_s = 30.0;
        let mut l = LostContact::new();
        // Flew +y with a path for 20 s, neighbours about it; then alone.
        for k in 0..=200 {
            let t = k as f64 * 0.1;
            let o = Odom { vy: 0.4, ..odom(0.0, t * 0.4, std::f64::consts::FRAC_PI_2, None) };
            l.phase(&sc, &view(t, &o, &[neighbour(2.0, 0.0)], &[]), 2, &Hops::default());
        }
        // The last centroid: 2 m ahead of (0, 8), heading +y: (0, 10). Held there from 40 s.
        let there = odom(0.0, 10.0, 0.0, None);
        let alone = |l: &mut LostContact, t: f64| l.phase(&sc, &view(t, &there, &[], &[]), NO_PATH, &Hops::default());
        assert_eq!(alone(&mut l, 40.0), Phase::Hold);
        let to = Vector2::new(0.0, 10.0 + sc.lost_contact.search_distance_m);
        match alone(&mut l, 70.0) {
            Phase::Search { to: got, with_group: false } => assert!((got - to).norm() < 1e-6, "{got}"),
            other => panic!("{other:?}"),
        }
        let c = l.steer(&sc, &view(70.1, &there, &[], &[]), NO_PATH, &Hops::default(), flock());
        assert!(c.xy.norm() <= sc.lost_contact.speed_mps + 1e-9, "slowly: {c:?}");
    }

    #[test]
    fn a_swarm_heard_beyond_reach_is_approached() {
        let sc = scenario();
        let reach = sc.controller.k21.neighbour_radius_m;
        let mut l = LostContact::new();
        let o = odom(0.0, 0.0, 0.0, None);
        l.phase(&sc, &view(0.0, &o, &[neighbour(2.0, 0.0)], &[]), NO_PATH, &Hops::default());
        let heard = [neighbour(reach + 3.0, 0.0)];
        assert_eq!(l.phase(&sc, &view(1.0, &o, &heard, &[]), NO_PATH, &Hops::default()), Phase::Flock, "not lost yet");
        assert_eq!(
            l.phase(&sc, &view(sc.lost_contact.after_s, &o, &heard, &[]), NO_PATH, &Hops::default()),
            Phase::Approach(Vector2::new(reach + 3.0, 0.0))
        );
        let c = l.steer(&sc, &view(sc.lost_contact.after_s, &o, &heard, &[]), NO_PATH, &Hops::default(), flock());
        assert!(c.xy.x > sc.lost_contact.speed_mps, "at the flock's speed: {c:?}");
    }

    #[test]
    fn informed_uavs_and_those_never_in_contact_fly_on() {
        let mut sc = scenario();
        let mut never = LostContact::new();
        let o = odom(0.0, 0.0, 0.0, None);
        assert_eq!(never.phase(&sc, &view(100.0, &o, &[], &[]), NO_PATH, &Hops::default()), Phase::Flock);
        let mut informed = LostContact::new();
        let g = odom(0.0, 0.0, 0.0, Some([30.0, 0.0]));
        informed.phase(&sc, &view(0.0, &g, &[neighbour(2.0, 0.0)], &[]), NO_PATH, &Hops::default());
        assert_eq!(informed.phase(&sc, &view(100.0, &g, &[], &[]), NO_PATH, &Hops::default()), Phase::Flock);
        sc.lost_contact.enabled = false;
        let mut l = LostContact::new();
        l.phase(&sc, &view(0.0, &o, &[neighbour(2.0, 0.0)], &[]), NO_PATH, &Hops::default());
        assert_eq!(l.phase(&sc, &view(100.0, &o, &[], &[]), NO_PATH, &Hops::default()), Phase::Flock);
    }

    #[test]
    fn the_flight_back_avoids_a_tree_in_the_way() {
        let sc = scenario();
        let o = odom(0.0, 0.0, 0.0, None);
        let open = fly_to(&sc, &view(10.0, &o, &[], &[]), Vector2::new(10.0, 0.0), 0.25, &mut Detour::new());
        let tree = [Circle { center: Point2::new(1.5, 0.1), radius: 0.2 }];
        let blocked = fly_to(&sc, &view(10.0, &o, &[], &tree), Vector2::new(10.0, 0.0), 0.25, &mut Detour::new());
        assert!(open.xy.y.abs() < 1e-9 && open.xy.x > 0.0, "{open:?}");
        assert!(blocked.xy.y < -1e-3, "steers away from a tree just left of the line: {blocked:?}");
    }
}
