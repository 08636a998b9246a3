//! `own-controller`: the `swarm` command line with one more controller, `potential-field`.
//!
//! A scenario names it as `[controller] kind = "potential-field"`; every agent the run starts is
//! this executable, so it flies there. Run it as
//! `cargo run --release -p own-controller -- run examples/own-controller/forest-5-own.toml`.

use nalgebra::{Rotation2, Vector2};
use swarm_config::Scenario;
use swarm_wire::{CmdKind, VectorMagnitudes};
use uav_agent::{Command, Controller, Controllers, View};

/// A potential field: pulled to the goal (or, uninformed, to the neighbours), pushed off
/// neighbours and trees. It keeps nothing between steps but its gains.
struct PotentialField {
    speed_mps: f64,
    keep_apart_m: f64,
    tree_margin_m: f64,
}

impl Controller for PotentialField {
    fn step(&mut self, v: &View) -> Command {
        // The goal, turned from the odometry frame into the body frame.
        let to_body = Rotation2::new(-v.odom.yaw);
        let goal = v.odom.goal.map(|g| to_body * Vector2::new(g[0] - v.odom.x, g[1] - v.odom.y));
        let mut pull = goal.map_or_else(Vector2::zeros, |g| g.normalize() * self.speed_mps);
        let mut push = Vector2::zeros();
        if !v.neighbours.is_empty() {
            let centre = v.neighbours.iter().map(|n| n.pos_in_body).sum::<Vector2<f64>>() / v.neighbours.len() as f64;
            pull += 0.3 * centre; // cohesion: stay with the swarm
        }
        for n in v.neighbours {
            let d = n.pos_in_body.norm().max(0.1);
            if d < self.keep_apart_m {
                push -= n.pos_in_body / d * (self.keep_apart_m - d); // separation
            }
        }
        for t in v.trees {
            let c = t.center.coords;
            let clear = (c.norm() - t.radius).max(0.05);
            if clear < self.tree_margin_m {
                let away = -c.normalize() * (1.0 / clear - 1.0 / self.tree_margin_m);
                let side = Vector2::new(c.y, -c.x).normalize() * away.norm() * 0.5; // slide past
                push += away + side;
            }
        }
        let v_cmd = pull + push;
        let xy = if v_cmd.norm() > self.speed_mps { v_cmd.normalize() * self.speed_mps } else { v_cmd };
        let vectors = VectorMagnitudes {
            navigation: pull.norm() as f32,
            avoidance: push.norm() as f32,
            output: xy.norm() as f32,
            ..Default::default()
        };
        Command { kind: CmdKind::Velocity, xy, yaw_rate: 0.0, vectors }
    }
}

fn potential_field(_: &Scenario) -> Box<dyn Controller> {
    Box::new(PotentialField { speed_mps: 1.0, keep_apart_m: 2.0, tree_margin_m: 1.5 })
}

fn main() -> std::process::ExitCode {
    swarm::cli::main_with(Controllers::builtin().with("potential-field", potential_field))
}
