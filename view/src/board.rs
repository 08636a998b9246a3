//! What the web page draws, as JSON: the world once, then frames of the latest truth step with
//! the radio graph, the estimates, the collisions and failures so far, and each agent's numbers.
//! Pure: fed message by message like the recorder, tested without a network.

use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::sync::Arc;
use swarm_record::scene;
use swarm_types::UavId;
use swarm_wire::msg::{AgentState, CollisionEvent, RadioSet, TruthStep, TruthWorld};

/// The page's view of the run.
#[derive(Default)]
pub struct Board {
    world: Option<Value>,
    step: Option<Arc<TruthStep>>,
    radio: BTreeMap<UavId, Vec<UavId>>,
    timeline: netem::Timeline,
    states: BTreeMap<UavId, AgentState>,
    collisions: Vec<CollisionEvent>,
    lost: BTreeMap<UavId, f64>,
    /// The scenario's goal radius [m], drawn around the goal.
    goal_radius_m: f64,
    /// The scenario's controller by name (`k21`, ...): what the panels' numbers mean.
    controller: String,
}

impl Board {
    /// A board for `sc` (its netem timeline until the hub says otherwise).
    pub fn new(sc: &swarm_config::Scenario) -> Board {
        Board {
            timeline: netem::Timeline::from_scenario(sc),
            goal_radius_m: sc.end.goal_radius_m,
            controller: sc.controller.kind.name().to_string(),
            ..Board::default()
        }
    }

    /// The world frame the page draws first.
    pub fn on_world(&mut self, run: &str, w: &TruthWorld) {
        self.world = Some(json!({
            "kind": "world", "run": run, "trees": w.trees, "walls": w.walls, "goal": w.goal,
            "starts": w.starts, "body_radius_m": w.body_radius_m, "goal_radius_m": self.goal_radius_m,
            "controller": self.controller,
        }));
    }

    /// The world frame, once known.
    pub fn world(&self) -> Option<&Value> {
        self.world.as_ref()
    }

    /// The netem timeline in force.
    pub fn on_timeline(&mut self, t: swarm_config::Timeline) {
        self.timeline = netem::Timeline::from(t);
    }

    /// One radio set.
    pub fn on_radio(&mut self, r: &RadioSet) {
        self.radio.insert(r.id, r.in_range.clone());
    }

    /// One agent state (kept as the UAV's latest).
    pub fn on_state(&mut self, st: AgentState) {
        self.states.insert(st.id, st);
    }

    /// One truth step (shared with the scan store).
    pub fn on_step(&mut self, s: Arc<TruthStep>) {
        self.collisions.extend(s.collisions.iter().copied());
        for b in s.bodies.iter().filter(|b| !b.alive) {
            self.lost.entry(b.id).or_insert(s.t_s);
        }
        self.step = Some(s);
    }

    /// The latest truth step, if any.
    pub fn tick(&self) -> Option<u64> {
        self.step.as_ref().map(|s| s.tick)
    }

    /// The frame of the latest step: what the page redraws.
    pub fn frame(&self) -> Option<Value> {
        let s = self.step.as_ref()?;
        let uavs: Vec<Value> = s
            .bodies
            .iter()
            .map(|b| json!({"id": b.id, "x": b.x, "y": b.y, "yaw": b.yaw, "v": b.vx.hypot(b.vy), "alive": b.alive, "colliding": b.colliding}))
            .collect();
        let pos: BTreeMap<UavId, [f64; 3]> = s.bodies.iter().map(|b| (b.id, [b.x, b.y, b.yaw])).collect();
        let links: Vec<Value> =
            scene::radio_links(&self.radio, &self.timeline, s.t_s, |id| pos.get(&id).map(|p| [p[0], p[1]]))
                .into_iter()
                .map(|l| json!([l.ids[0], l.ids[1], l.class.name()]))
                .collect();
        let mut estimates = BTreeMap::new();
        let mut numbers = BTreeMap::new();
        for (id, st) in &self.states {
            let Some(&pose) = pos.get(id) else { continue };
            estimates.insert(id.to_string(), scene::estimates_in_world(pose, st));
            numbers.insert(id.to_string(), scene::numbers(st));
        }
        let speed = if s.wall_s > 0.0 { Some(s.t_s / s.wall_s) } else { None };
        Some(json!({
            "kind": "step", "tick": s.tick, "t": s.t_s, "speed": speed, "ended": s.ended.map(|e| format!("{e:?}")),
            "uavs": uavs, "links": links, "estimates": estimates, "numbers": numbers,
            "collisions": self.collisions.iter().map(|c| json!([c.id, c.x, c.y, c.other_uav])).collect::<Vec<_>>(),
            "lost": self.lost,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use swarm_wire::msg::TruthBody;

    fn body(id: u32, x: f64, alive: bool) -> TruthBody {
        TruthBody {
            id: UavId::new(id),
            x,
            y: 0.0,
            yaw: 0.0,
            vx: 0.3,
            vy: 0.4,
            alive,
            cmd_on_time: true,
            obstacle_distance_m: 1.0,
            agent_distance_m: 1.0,
            colliding: false,
        }
    }

    #[test]
    fn the_world_carries_the_scenarios_goal_radius_and_controller() {
        let sc = swarm_config::Scenario::from_arg("forest-5").expect("built-in").0;
        let mut b = Board::new(&sc);
        let w = TruthWorld { trees: vec![], walls: vec![], starts: vec![], goal: [30.0, 0.0], body_radius_m: 0.3 };
        b.on_world("r", &w);
        assert_eq!(b.world().expect("world")["goal_radius_m"], sc.end.goal_radius_m);
        assert_ne!(sc.end.goal_radius_m, 1.0, "forest-5's disc is not the 1 m the page drew before");
        assert_eq!(b.world().expect("world")["controller"], "k21");
    }

    #[test]
    fn a_frame_holds_the_latest_step_links_and_losses() {
        let sc = swarm_config::Scenario::from_arg("forest-5").expect("built-in").0;
        let mut b = Board::new(&sc);
        assert!(b.frame().is_none());
        b.on_radio(&RadioSet { tick: 1, id: UavId::new(1), in_range: vec![UavId::new(2)], loss: vec![] });
        let step = |tick, alive| TruthStep {
            tick,
            t_s: tick as f64 * 0.1,
            bodies: vec![body(1, 1.0, true), body(2, 2.0, alive)],
            collisions: vec![],
            goal_reached_at: None,
            ended: None,
            wall_s: 0.01,
            timing: Box::default(),
        };
        b.on_step(Arc::new(step(1, true)));
        b.on_step(Arc::new(step(2, false)));
        let f = b.frame().expect("frame");
        assert_eq!(f["tick"], 2);
        assert_eq!(f["uavs"][1]["x"], 2.0);
        assert!((f["uavs"][1]["v"].as_f64().expect("speed [m/s]") - 0.5).abs() < 1e-9, "the true speed |(vx, vy)|");
        assert_eq!(f["links"][0], json!([1, 2, "clean"]));
        assert_eq!(f["lost"]["2"], 0.2);
        assert!((f["speed"].as_f64().expect("speed") - 20.0).abs() < 1e-9);
    }
}
