//! The truth a ROS user sees in RViz: where each UAV's odometry frame lies in the world
//! (`/tf_static`: `world` -> `uav{id}/odom`, from the start poses) and the world itself
//! (`/world/markers`: trees, walls and the goal disc). Both come from the hub's `truth/world`,
//! so the bridge publishes them only where truth may go (docs/ros2.md).

use swarm_ros2::msgs::frames::{tf_message, Transform};
use swarm_ros2::msgs::markers::{marker_array, Marker, Shape};
use swarm_ros2::msgs::Header;
use swarm_wire::TruthWorld;

/// The world frame's name.
pub const WORLD: &str = "world";

/// How tall the trees and walls are drawn [m] (the world is planar; the LIDAR scans at 1 m).
const HEIGHT_M: f64 = 2.0;

/// `/tf_static`: each UAV's odometry frame in the world, at its start pose.
pub fn static_transforms(w: &TruthWorld, t_s: f64) -> Vec<u8> {
    let transforms: Vec<Transform> = w
        .starts
        .iter()
        .enumerate()
        .map(|(i, s)| Transform {
            header: Header::new(t_s, WORLD),
            child: format!("uav{}/odom", i + 1),
            x: s[0],
            y: s[1],
            yaw: s[2],
        })
        .collect();
    tf_message(&transforms)
}

/// `/world/markers`: the trees as brown cylinders, walls as grey boxes, the goal as a green disc
/// of the scenario's goal radius.
pub fn markers(w: &TruthWorld, goal_radius_m: f64, t_s: f64) -> Vec<u8> {
    let mut m = Vec::with_capacity(w.trees.len() + w.walls.len() + 1);
    for (i, t) in w.trees.iter().enumerate() {
        m.push(Marker {
            ns: "trees",
            id: i as i32,
            shape: Shape::Cylinder,
            at: [t[0], t[1], HEIGHT_M / 2.0],
            yaw: 0.0,
            scale: [2.0 * t[2], 2.0 * t[2], HEIGHT_M],
            rgba: [0.45, 0.3, 0.15, 1.0],
        });
    }
    for (i, wall) in w.walls.iter().enumerate() {
        let [x1, y1, x2, y2, thickness] = *wall;
        let (dx, dy) = (x2 - x1, y2 - y1);
        m.push(Marker {
            ns: "walls",
            id: i as i32,
            shape: Shape::Cube,
            at: [(x1 + x2) / 2.0, (y1 + y2) / 2.0, HEIGHT_M / 2.0],
            yaw: dy.atan2(dx),
            scale: [dx.hypot(dy), thickness, HEIGHT_M],
            rgba: [0.5, 0.5, 0.5, 1.0],
        });
    }
    let r = goal_radius_m.max(0.2);
    m.push(Marker {
        ns: "goal",
        id: 0,
        shape: Shape::Cylinder,
        at: [w.goal[0], w.goal[1], 0.01],
        yaw: 0.0,
        scale: [2.0 * r, 2.0 * r, 0.02],
        rgba: [0.1, 0.7, 0.2, 0.4],
    });
    marker_array(&Header::new(t_s, WORLD), &m)
}
