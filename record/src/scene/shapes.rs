//! Pure conversions from our wire messages to the Foxglove SDK's schemas: no channels, no state,
//! so each is tested on its own. Frames: `world` (the hub's), and `uav{id}` for each UAV's body
//! (x forward, y left, yaw about z), placed in `world` by the transforms on `/tf`. Everything is
//! drawn in the plane at [`FLY_Z_M`].

use foxglove::messages::{
    Color, CubePrimitive, CylinderPrimitive, FrameTransform, LaserScan, LinePrimitive, Log, Point3, Pose, PoseInFrame,
    Quaternion, SceneEntity, SceneUpdate, SpherePrimitive, Timestamp, Vector3,
};
use swarm_types::UavId;
use swarm_wire::msg::{Scan, TruthBody, TruthWorld};

/// The world frame's name.
pub const WORLD: &str = "world";
/// The height the swarm flies at in the pictures [m] (the simulation is planar).
pub const FLY_Z_M: f64 = 1.0;
/// Tree and wall height in the pictures [m].
const OBSTACLE_HEIGHT_M: f64 = 2.0;

/// UAV `id`'s body frame name.
pub fn body_frame(id: UavId) -> String {
    format!("uav{id}")
}

/// A sim time [s] as a Foxglove timestamp (sim time counts from the Unix epoch).
pub fn stamp(t_s: f64) -> Timestamp {
    Timestamp::saturating_from_epoch_secs_f64(t_s.max(0.0))
}

/// A sim time [s] as the log time of an MCAP message [ns].
pub fn log_time_ns(t_s: f64) -> u64 {
    (t_s.max(0.0) * 1e9).round() as u64
}

/// The rotation of `yaw` [rad] about z as a unit quaternion: (0, 0, sin(yaw/2), cos(yaw/2)).
pub fn yaw_quat(yaw: f64) -> Quaternion {
    let h = 0.5 * yaw;
    Quaternion { x: 0.0, y: 0.0, z: h.sin(), w: h.cos() }
}

/// An opaque colour from 0..1 channels.
pub fn rgb(r: f64, g: f64, b: f64) -> Color {
    Color { r, g, b, a: 1.0 }
}

fn at(x: f64, y: f64, z: f64, yaw: f64) -> Option<Pose> {
    Some(Pose { position: Some(Vector3 { x, y, z }), orientation: Some(yaw_quat(yaw)) })
}

/// The world as one scene: trees as cylinders, walls as boxes, the goal as a flat disc of the
/// scenario's `goal_radius_m` (the hub's world does not carry it).
pub fn world(w: &TruthWorld, goal_radius_m: f64) -> SceneUpdate {
    let h = OBSTACLE_HEIGHT_M;
    let cylinders = w
        .trees
        .iter()
        .map(|[x, y, r]| CylinderPrimitive {
            pose: at(*x, *y, 0.5 * h, 0.0),
            size: Some(Vector3 { x: 2.0 * r, y: 2.0 * r, z: h }),
            bottom_scale: 1.0,
            top_scale: 1.0,
            color: Some(rgb(0.18, 0.45, 0.2)),
        })
        .chain(std::iter::once(CylinderPrimitive {
            pose: at(w.goal[0], w.goal[1], 0.01, 0.0),
            size: Some(Vector3 { x: 2.0 * goal_radius_m, y: 2.0 * goal_radius_m, z: 0.02 }),
            bottom_scale: 1.0,
            top_scale: 1.0,
            color: Some(Color { r: 0.9, g: 0.75, b: 0.1, a: 0.6 }),
        }))
        .collect();
    let cubes = w
        .walls
        .iter()
        .map(|[x1, y1, x2, y2, thick]| CubePrimitive {
            pose: at(0.5 * (x1 + x2), 0.5 * (y1 + y2), 0.5 * h, (y2 - y1).atan2(x2 - x1)),
            size: Some(Vector3 { x: (x2 - x1).hypot(y2 - y1), y: *thick, z: h }),
            color: Some(rgb(0.45, 0.45, 0.5)),
        })
        .collect();
    let e = SceneEntity { frame_id: WORLD.into(), id: "world".into(), cylinders, cubes, ..Default::default() };
    SceneUpdate { entities: vec![e], ..Default::default() }
}

/// The transform placing UAV `b`'s body frame in the world at `t_s`.
pub fn transform(b: &TruthBody, t_s: f64) -> FrameTransform {
    FrameTransform {
        timestamp: Some(stamp(t_s)),
        parent_frame_id: WORLD.into(),
        child_frame_id: body_frame(b.id),
        translation: Some(Vector3 { x: b.x, y: b.y, z: FLY_Z_M }),
        rotation: Some(yaw_quat(b.yaw)),
    }
}

/// UAV `b`'s pose in the world at `t_s`.
pub fn pose(b: &TruthBody, t_s: f64) -> PoseInFrame {
    PoseInFrame { timestamp: Some(stamp(t_s)), frame_id: WORLD.into(), pose: at(b.x, b.y, FLY_Z_M, b.yaw) }
}

/// UAV `id`'s scan, in its body frame. Ranges are the wire's, widened to f64 exactly (no return
/// stays +inf).
pub fn laser_scan(id: UavId, s: &Scan) -> LaserScan {
    let n = s.ranges_m.len().max(1) as f64;
    LaserScan {
        timestamp: Some(stamp(s.t_s)),
        frame_id: body_frame(id),
        pose: at(0.0, 0.0, 0.0, 0.0),
        start_angle: f64::from(s.angle_min),
        end_angle: f64::from(s.angle_min) + f64::from(s.angle_increment) * (n - 1.0),
        ranges: s.ranges_m.iter().map(|&r| f64::from(r)).collect(),
        intensities: Vec::new(),
    }
}

/// Line segments `[a, b]` in the world plane, one colour each, as one line list.
pub fn segments(segs: &[([f64; 2], [f64; 2], Color)], thickness_m: f64) -> LinePrimitive {
    let p = |q: [f64; 2]| Point3 { x: q[0], y: q[1], z: FLY_Z_M };
    LinePrimitive {
        r#type: foxglove::messages::line_primitive::Type::LineList as i32,
        pose: at(0.0, 0.0, 0.0, 0.0),
        thickness: thickness_m,
        points: segs.iter().flat_map(|(a, b, _)| [p(*a), p(*b)]).collect(),
        colors: segs.iter().flat_map(|(_, _, c)| [*c, *c]).collect(),
        ..Default::default()
    }
}

/// A polyline in the world plane.
pub fn strip(points: impl IntoIterator<Item = [f64; 2]>, color: Color, thickness_m: f64) -> LinePrimitive {
    LinePrimitive {
        r#type: foxglove::messages::line_primitive::Type::LineStrip as i32,
        pose: at(0.0, 0.0, 0.0, 0.0),
        thickness: thickness_m,
        points: points.into_iter().map(|q| Point3 { x: q[0], y: q[1], z: FLY_Z_M }).collect(),
        color: Some(color),
        ..Default::default()
    }
}

/// Small balls at world points.
pub fn dots(points: &[[f64; 2]], color: Color, diameter_m: f64) -> Vec<SpherePrimitive> {
    points
        .iter()
        .map(|q| SpherePrimitive {
            pose: at(q[0], q[1], FLY_Z_M, 0.0),
            size: Some(Vector3 { x: diameter_m, y: diameter_m, z: diameter_m }),
            color: Some(color),
        })
        .collect()
}

/// One entity in the world frame at `t_s`, to be replaced by the next of the same `id`.
pub fn entity(id: String, t_s: f64) -> SceneEntity {
    SceneEntity { timestamp: Some(stamp(t_s)), frame_id: WORLD.into(), id, ..Default::default() }
}

/// A log line of the run at `t_s`.
pub fn log(t_s: f64, level: foxglove::messages::log::Level, name: &str, message: String) -> Log {
    Log { timestamp: Some(stamp(t_s)), level: level as i32, message, name: name.into(), file: String::new(), line: 0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_quaternion_is_unit_and_turns_x_onto_the_heading() {
        let q = yaw_quat(std::f64::consts::FRAC_PI_2);
        assert!((q.z * q.z + q.w * q.w - 1.0).abs() < 1e-12);
        // x axis rotated by q: (1 - 2z², 2wz) for a pure z rotation.
        assert!((1.0 - 2.0 * q.z * q.z).abs() < 1e-12 && (2.0 * q.w * q.z - 1.0).abs() < 1e-12);
    }

    #[test]
    fn laser_scan_keeps_the_wire_ranges_exactly() {
        let s = Scan {
            tick: 3,
            t_s: 0.3,
            angle_min: -1.0,
            angle_increment: 0.5,
            max_range_m: 9.0,
            ranges_m: vec![1.25, f32::INFINITY, 0.1],
        };
        let l = laser_scan(UavId::new(4), &s);
        assert_eq!(l.frame_id, "uav4");
        assert_eq!(l.ranges.iter().map(|&r| r as f32).collect::<Vec<_>>(), s.ranges_m);
        assert!((l.end_angle - 0.0).abs() < 1e-12);
        assert_eq!(log_time_ns(0.3), 300_000_000);
    }

    #[test]
    fn walls_are_boxes_along_their_segment() {
        let w = TruthWorld {
            trees: vec![[1.0, 2.0, 0.3]],
            walls: vec![[0.0, 0.0, 0.0, 4.0, 0.2]],
            starts: vec![],
            goal: [9.0, 9.0],
            body_radius_m: 0.2,
        };
        let u = world(&w, 4.0);
        let e = &u.entities[0];
        assert_eq!(e.cylinders.len(), 2, "the tree and the goal");
        let goal = e.cylinders[1].size.expect("goal size");
        assert!(
            (goal.x - 8.0).abs() < 1e-12 && (goal.y - 8.0).abs() < 1e-12,
            "the goal disc is 2 x 4 m across: {goal:?}"
        );
        let size = e.cubes[0].size.expect("size");
        assert!((size.x - 4.0).abs() < 1e-12 && (size.y - 0.2).abs() < 1e-12);
    }
}
