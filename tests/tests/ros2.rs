//! Our ROS 2 encodings read by a CDR implementation no one here wrote (PyPI `rosbags`, the
//! ROS 2 Jazzy type store): a UAV's scan as `sensor_msgs/msg/LaserScan`, its odometry as
//! `nav_msgs/msg/Odometry`, a `geometry_msgs/msg/Twist` both ways, and the RIHS01 type hashes
//! our data keys carry.

mod common;

use common::python;
use std::process::Command;
use swarm_wire::ros2::msgs::{laser_scan, odometry, Twist};
use swarm_wire::ros2::{LASER_SCAN, ODOMETRY, TWIST};
use swarm_wire::{Odom, Scan};

const CHECK: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros2/rosbags_check.py");

fn close(v: &serde_json::Value, want: f64) -> bool {
    v.as_f64().is_some_and(|x| (x - want).abs() < 1e-6)
}

#[test]
fn rosbags_reads_our_scan_odometry_and_twist_and_we_read_its_twist() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scan = Scan { tick: 12, t_secs: 1.25, angle_min: -3.0, angle_increment: 0.5, max_range_m: 12.0, ranges_m: vec![1.5, f32::INFINITY, 3.25] };
    let odom = Odom { tick: 12, t_secs: 1.25, x: 2.0, y: -1.0, yaw: std::f64::consts::FRAC_PI_2, vx: 0.0, vy: 1.0, goal: None, goal_vel: None };
    let twist = Twist { linear: [0.5, -0.25, 0.0], angular: [0.0, 0.0, 0.1] };
    std::fs::write(dir.path().join("scan.cdr"), laser_scan(&scan, "uav3/base_link", 0.1)).expect("write");
    std::fs::write(dir.path().join("odom.cdr"), odometry(&odom, "uav3/odom", "uav3/base_link")).expect("write");
    std::fs::write(dir.path().join("twist.cdr"), twist.encode()).expect("write");
    let o = Command::new(python()).arg(CHECK).arg(dir.path()).output().expect("python");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");

    for t in [LASER_SCAN, ODOMETRY, TWIST] {
        assert_eq!(r["hashes"][t.ros], t.hash, "{t:?}");
    }
    let s = &r["scan"];
    assert_eq!(s["header"]["stamp"]["sec"], 1);
    assert_eq!(s["header"]["stamp"]["nanosec"], 250_000_000);
    assert_eq!(s["header"]["frame_id"], "uav3/base_link");
    assert!(close(&s["angle_min"], -3.0) && close(&s["angle_max"], -2.0) && close(&s["angle_increment"], 0.5), "{s}");
    assert!(close(&s["range_max"], 12.0) && close(&s["scan_time"], 0.1), "{s}");
    assert_eq!(s["ranges"], serde_json::json!([1.5, null, 3.25]), "no hit is +inf");
    assert_eq!(s["intensities"], serde_json::json!([]));

    let d = &r["odom"];
    assert_eq!(d["header"]["frame_id"], "uav3/odom");
    assert_eq!(d["child_frame_id"], "uav3/base_link");
    let pose = &d["pose"]["pose"];
    assert!(close(&pose["position"]["x"], 2.0) && close(&pose["position"]["y"], -1.0), "{pose}");
    let half = std::f64::consts::FRAC_PI_4;
    assert!(close(&pose["orientation"]["z"], half.sin()) && close(&pose["orientation"]["w"], half.cos()), "{pose}");
    // Moving along +y of the odometry frame while facing +y: straight ahead in the body frame.
    let lin = &d["twist"]["twist"]["linear"];
    assert!(close(&lin["x"], 1.0) && close(&lin["y"], 0.0), "{lin}");
    assert_eq!(d["pose"]["covariance"].as_array().map(Vec::len), Some(36));

    let t = &r["twist"];
    assert!(close(&t["linear"]["x"], 0.5) && close(&t["linear"]["y"], -0.25) && close(&t["angular"]["z"], 0.1), "{t}");
    let theirs = std::fs::read(dir.path().join("twist_from_rosbags.cdr")).expect("rosbags' twist");
    assert_eq!(Twist::decode(&theirs), Ok(twist));
}
