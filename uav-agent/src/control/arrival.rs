//! Arrival: how a K21 swarm settles at its goal (the behaviour and its parameter:
//! `swarm_config::K21Params::arrival_radius_m`).
//!
//! Why a layer of its own: seed 000 is silent on arrival, and its K21 never stops. Every UAV
//! flies its body x axis at the speed eq. 4.16–4.17 leave to navigation, and the informed pull
//! their neighbours' headings round through the goal, so a swarm that reaches its goal orbits
//! it; a large one swings its centroid 20 m past the goal and back for minutes (issue 25). The
//! uninformed cannot see the goal, so arrival has to travel the way the informed UAV's existence
//! does (`hops`): a second hop count in every share, to the nearest *arrived* UAV (an informed UAV
//! inside the arrival disc). A UAV with such a path turns to what is closer to the arrival than
//! itself, and lets its navigation fade as it closes on it: an informed UAV to the goal at full
//! speed until it is inside the disc, then, slowing, to a point that brings its neighbourhood's
//! centroid towards the goal ([`CENTRING`]); the others to their nearest neighbour with a lower
//! count, within `cohesion_radius_m` of which they stop.
//! Cohesion, separation, avoidance and the barrier stay as they are. Until an informed
//! UAV arrives every count is "none" and K21 flies exactly as before, so the seed's in-flight
//! figures are untouched. Nothing here reads ground truth: odometry, the estimates and the
//! counts heard.

use super::controller::{Command, View};
use super::detour::Detour;
use super::hops::Hops;
use super::pilot::{bearing_in_body, k21_command};
use nalgebra::Vector2;
use swarm_config::{ControllerKind, K21Params, Scenario};
use swarm_types::UavId;
use swarm_wire::NO_PATH;

/// The arrival counts heard in shares, and this UAV's own.
#[derive(Debug, Default)]
pub struct Arrival {
    heard: Hops,
    /// Its flights' way out of a shut gap (K21's opt-in detour).
    detour: Detour,
}

/// The arrival radius the scenario gives K21 [m]; 0 (off) for the other controllers.
fn radius_m(sc: &Scenario) -> f64 {
    match sc.controller.kind {
        ControllerKind::K21 => sc.controller.k21.arrival_radius_m.unwrap_or(sc.end.goal_radius_m),
        _ => 0.0,
    }
}

impl Arrival {
    /// Notes sender `from`'s arrival count, sent at sim time `t_s`.
    pub fn hear(&mut self, from: UavId, count: u8, t_s: f64) {
        self.heard.hear(from, count, t_s);
    }

    /// Our own count at sim time `now`: 0 for an informed UAV within the arrival radius of its
    /// goal, else one more than the smallest count heard (see [`Hops::own`]).
    pub fn own(&mut self, sc: &Scenario, v: &View, now: f64) -> u8 {
        let r = radius_m(sc);
        let arrived = r > 0.0 && v.odom.goal.is_some_and(|g| (g[0] - v.odom.x).hypot(g[1] - v.odom.y) <= r);
        self.heard.own(arrived, now, sc.lost_contact.max_hops)
    }

    /// The command of this step: `flock` (the controller's) unless this UAV has a path to an
    /// arrived one; then K21 with its heading turned to what is closer to the arrival (the goal,
    /// or the nearest neighbour with a lower count) and its navigation faded as it closes on it
    /// (see the module doc).
    pub fn steer(&mut self, sc: &Scenario, v: &View, own: u8, flock: Command) -> Command {
        let r = radius_m(sc);
        if r <= 0.0 || own == NO_PATH {
            return flock;
        }
        let p = &sc.controller.k21;
        let (heading, fade) = match v.odom.goal {
            // An informed UAV: to the goal, at full speed until it is inside the disc, then
            // slowing towards the centre. Its heading no longer follows the swarm's (eq. 4.14
            // gives the goal one vote among its neighbours', which carries a large swarm past).
            Some(g) if own != 0 => (bearing_in_body(v.odom, g), 1.0),
            // Arrived: it brings its neighbourhood in, not only itself, aiming half way to where
            // the centroid of itself and its neighbours would sit on the goal.
            Some(g) => {
                let aim = centred(v, g);
                let d = (aim[0] - v.odom.x).hypot(aim[1] - v.odom.y);
                (bearing_in_body(v.odom, aim), d / r)
            }
            None => {
                let Some(next) = self.heard.nearest_lower(v.neighbours, own) else { return flock };
                (next.y.atan2(next.x), (next.norm() - p.cohesion_radius_m) / p.cohesion_radius_m)
            }
        };
        // An arrived UAV makes room: every neighbour closer than the separation radius pushes it,
        // not only those ahead (eq. 4.7-4.9 look ahead only, so a hovering cluster would never
        // yield to the UAVs arriving behind it).
        let all_around =
            if own == 0 { p.separation_radius_m.max(p.separation_all_around_m) } else { p.separation_all_around_m };
        let faded = K21Params { kn: p.kn * fade.clamp(0.0, 1.0), separation_all_around_m: all_around, ..p.clone() };
        let mut c = k21_command(&faded, v, v.neighbours, None, &[], &mut self.detour);
        // seed 000 eq. 4.14 with the target as the only heading.
        c.yaw_rate = p.heading_gain * heading;
        c
    }
}

/// How far an arrived UAV aims from the goal towards the point that would centre its
/// neighbourhood on it: 0 aims at the goal (the cluster packs tight at the centre, 0.91 m apart,
/// and drags the stragglers in slowly: forest-40-arrive's goal at 470 s), 1 at that point (the
/// swarm keeps its flight shape, too loose for the disc: never held). Half way: 372 s, 0.93 m.
const CENTRING: f64 = 0.5;

/// The point half way ([`CENTRING`]) from `goal` to where the centroid of this UAV and its
/// neighbour estimates would sit on the goal (odometry frame).
fn centred(v: &View, goal: [f64; 2]) -> [f64; 2] {
    let n = v.neighbours.len() as f64 + 1.0;
    let offset_body = v.neighbours.iter().map(|e| e.pos_in_body).sum::<Vector2<f64>>() / n * CENTRING;
    let offset = nalgebra::Rotation2::new(v.odom.yaw) * offset_body;
    [goal[0] - offset.x, goal[1] - offset.y]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world_model::Estimate;
    use swarm_wire::{CmdKind, Odom, VectorMagnitudes};

    fn scenario() -> Scenario {
        Scenario::from_arg("forest-5").expect("built in").0
    }

    fn odom(x: f64, goal: Option<[f64; 2]>) -> Odom {
        Odom { tick: 0, t_s: 0.0, x, y: 0.0, yaw: 0.0, vx: 0.0, vy: 0.0, goal, goal_vel: None }
    }

    fn view<'a>(o: &'a Odom, n: &'a [Estimate]) -> View<'a> {
        View {
            id: UavId::new(1),
            t_s: 1.0,
            odom: o,
            neighbours: n,
            trees: &[],
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

    fn neighbour(id: UavId, x: f64) -> Estimate {
        Estimate { id: Some(id), pos_in_body: Vector2::new(x, 0.0), heading: 0.0, age_s: 0.0 }
    }

    #[test]
    fn an_informed_uav_arrives_inside_the_disc_and_slows_towards_the_centre() {
        let sc = scenario();
        let r = sc.end.goal_radius_m;
        let goal = sc.swarm.goal;
        let mut a = Arrival::default();
        let far = odom(goal[0] - r - 1.0, Some(goal));
        assert_eq!(a.own(&sc, &view(&far, &[]), 1.0), NO_PATH, "outside the disc: not arrived");
        assert_eq!(a.steer(&sc, &view(&far, &[]), NO_PATH, flock()), flock(), "nobody arrived: K21 as it is");
        let behind = odom(goal[0] + r + 1.0, Some(goal));
        let back = a.steer(&sc, &view(&behind, &[]), 1, flock());
        assert!(back.yaw_rate.abs() > 1.0, "someone arrived: an informed UAV past the goal turns to it: {back:?}");
        let edge = odom(goal[0] - 0.9 * r, Some(goal));
        assert_eq!(a.own(&sc, &view(&edge, &[]), 1.0), 0);
        let centre = odom(goal[0] - 0.05 * r, Some(goal));
        let (at_edge, near_centre) =
            (a.steer(&sc, &view(&edge, &[]), 0, flock()), a.steer(&sc, &view(&centre, &[]), 0, flock()));
        assert!(at_edge.xy.x > 0.0 && near_centre.xy.x > 0.0, "towards the goal: {at_edge:?} {near_centre:?}");
        assert!(near_centre.xy.norm() < 0.1 * at_edge.xy.norm(), "slower near the centre: {at_edge:?} {near_centre:?}");
    }

    #[test]
    fn an_arrived_uav_brings_its_neighbourhood_in() {
        let sc = scenario();
        let goal = sc.swarm.goal;
        // On the goal, its three neighbours 4 m to its right (south): it aims 1.5 m north of
        // the goal (half of the 3 m its neighbourhood's centroid lies south of it) and turns left.
        let o = odom(goal[0], Some(goal));
        let south = |id| Estimate { id: Some(id), pos_in_body: Vector2::new(0.0, -4.0), heading: 0.0, age_s: 0.0 };
        let right = [south(UavId::new(2)), south(UavId::new(3)), south(UavId::new(4))];
        let aim = centred(&view(&o, &right), goal);
        assert!((aim[0] - goal[0]).abs() < 1e-9 && (aim[1] - (goal[1] + 1.5)).abs() < 1e-9, "{aim:?}");
        let c = Arrival::default().steer(&sc, &view(&o, &right), 0, flock());
        assert!(
            (c.yaw_rate - sc.controller.k21.heading_gain * std::f64::consts::FRAC_PI_2).abs() < 1e-9,
            "turns north: {c:?}"
        );
        // Facing north (yaw π/2), the same neighbours on its right lie east: it aims west.
        let north = Odom { yaw: std::f64::consts::FRAC_PI_2, ..odom(goal[0], Some(goal)) };
        let aim = centred(&view(&north, &right), goal);
        assert!((aim[0] - (goal[0] - 1.5)).abs() < 1e-9 && (aim[1] - goal[1]).abs() < 1e-9, "{aim:?}");
    }

    #[test]
    fn an_uninformed_uav_closes_on_a_lower_count_and_stops_within_cohesion_radius() {
        let sc = scenario();
        let mut a = Arrival::default();
        let o = odom(0.0, None);
        a.hear(UavId::new(2), 0, 1.0);
        a.hear(UavId::new(3), 4, 1.0);
        assert_eq!(a.own(&sc, &view(&o, &[]), 1.0), 1);
        // The neighbour with count 0 is 6 m ahead, the one with count 4 closer behind.
        let far = [neighbour(UavId::new(2), 6.0), neighbour(UavId::new(3), -3.0)];
        let c = a.steer(&sc, &view(&o, &far), 1, flock());
        assert!(c.xy.x > 0.0, "towards the lower count: {c:?}");
        let close = [neighbour(UavId::new(2), sc.controller.k21.cohesion_radius_m - 0.1)];
        let stopped = a.steer(&sc, &view(&o, &close), 1, flock());
        assert!(
            stopped.xy.norm() < 1e-9,
            "within the cohesion radius (and beyond separation's): it stops: {stopped:?}"
        );
        assert_eq!(a.steer(&sc, &view(&o, &far), NO_PATH, flock()), flock(), "no arrival heard: K21 as it is");
        let mut off = sc.clone();
        off.controller.k21.arrival_radius_m = Some(0.0);
        assert_eq!(a.steer(&off, &view(&o, &far), 1, flock()), flock(), "0 turns it off");
    }
}
