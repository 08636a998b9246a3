//! Our ROS 2 encodings read by a CDR implementation no one here wrote (PyPI `rosbags`, the
//! ROS 2 Jazzy type store): a UAV's scan as `sensor_msgs/msg/LaserScan`, its odometry as
//! `nav_msgs/msg/Odometry`, a `geometry_msgs/msg/Twist` both ways, and the RIHS01 type hashes
//! our data keys carry.

mod common;

use common::python;
use std::process::Command;
use swarm_ros2::msgs::command::Twist;
use swarm_ros2::msgs::sensor::{laser_scan, odometry};
use swarm_ros2::types::{LASER_SCAN, ODOMETRY, TWIST};
use swarm_wire::{Odom, Scan};

const CHECK: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros2/rosbags_check.py");

fn close(v: &serde_json::Value, want: f64) -> bool {
    v.as_f64().is_some_and(|x| (x - want).abs() < 1e-6)
}

#[test]
fn rosbags_reads_our_scan_odometry_and_twist_and_we_read_its_twist() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scan = Scan {
        tick: 12,
        t_s: 1.25,
        angle_min: -3.0,
        angle_increment: 0.5,
        max_range_m: 12.0,
        ranges_m: vec![1.5, f32::INFINITY, 3.25],
    };
    let odom = Odom {
        tick: 12,
        t_s: 1.25,
        x: 2.0,
        y: -1.0,
        yaw: std::f64::consts::FRAC_PI_2,
        vx: 0.0,
        vy: 1.0,
        goal: None,
        goal_vel: None,
    };
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
    assert_eq!(s["ranges"], serde_json::json!([1.5, "inf", 3.25]), "no hit is +inf");
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

const ROS_CLIENT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros2/ros_client.py");

/// A run with `--ros2` and UAV 3 external, in realtime so a person's pace is the run's: a
/// client that follows rmw_zenoh's documented key, attachment and token formats, logged in as
/// `ros`, finds UAV 3's node, reads its scan and odometry by ROS names and drives it through
/// cmd_vel; it cannot read the run's own keys.
#[test]
fn a_ros_client_sees_uav_3_and_drives_it_through_cmd_vel() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scenario = common::forest5_cut(dir.path(), 15.0);
    let out = dir.path().join("run");
    let run = common::run_id("ros2");
    let args = [
        "run",
        &scenario,
        "--external",
        "3",
        "--ros2",
        "--time-mode",
        "realtime",
        "--out",
        out.to_str().expect("utf8"),
        "--run",
        &run,
        "--quiet",
    ];
    let swarm = Command::new(common::SWARM)
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("swarm run");
    let loc = common::hub_locator(&out);
    let password = out.join("credentials/ros.password");
    let client = Command::new(python())
        .args([ROS_CLIENT, &loc, &run, password.to_str().expect("utf8")])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("python");
    let o = common::wait_output(swarm, common::RUN_LIMIT, "swarm run --ros2");
    let c = common::wait_output(client, std::time::Duration::from_secs(150), "ros_client.py");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(c.status.success(), "{}", String::from_utf8_lossy(&c.stderr));
    let seen: serde_json::Value = serde_json::from_slice(&c.stdout).expect("json");
    let graph: Vec<&str> = seen["graph"].as_array().expect("graph").iter().filter_map(|k| k.as_str()).collect();
    let has = |kind: &str, tail: &str| {
        graph.iter().any(|k| k.contains(&format!("/{kind}/%/%uav3/swarm")) && k.ends_with(tail))
    };
    assert!(has("NN", "/NN/%/%uav3/swarm"), "{graph:?}");
    assert!(has("MP", &format!("/%uav3%scan/{}/{}/2::,5:,:,:,,", LASER_SCAN.dds, LASER_SCAN.hash)), "{graph:?}");
    assert!(has("MP", &format!("/%uav3%odom/{}/{}/2::,5:,:,:,,", ODOMETRY.dds, ODOMETRY.hash)), "{graph:?}");
    assert!(has("MS", &format!("/%uav3%cmd_vel/{}/{}/::,10:,:,:,,", TWIST.dds, TWIST.hash)), "{graph:?}");
    assert!(!graph.iter().any(|k| k.contains("%uav2%cmd_vel")), "UAV 2 is not external: {graph:?}");
    assert!(seen["scans"].as_u64().expect("scans") >= 50, "{seen}");
    assert_eq!(seen["bad_attachments"], 0, "{seen}");
    assert_eq!(seen["scan_seq_increasing"], true, "{seen}");
    assert_eq!(seen["scan_frame"], "uav3/base_link");
    assert!(seen["ranges"].as_u64().expect("ranges") > 100, "{seen}");
    assert_eq!(seen["run_keys"], 0, "the ros user read the run's own keys: {seen}");
    let xs: Vec<f64> = seen["odom_x"].as_array().expect("odom").iter().filter_map(|x| x.as_f64()).collect();
    let moved = xs.last().expect("odometry") - xs.first().expect("odometry");
    assert!(moved > 3.0, "UAV 3 moved {moved:.2} m ahead on cmd_vel 0.8 m/s: {seen}");
    let s = common::summary(&out);
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);
    let three = s["agents"].as_array().expect("agents").iter().find(|a| a["id"] == 3).expect("UAV 3");
    eprintln!(
        "ROS client: {} scans, first seq {}, {} cmd_vel sent; UAV 3 moved {moved:.2} m on odometry, late ticks {}, mean step {:.3} ms",
        seen["scans"], seen["scan_seq_first"], seen["cmd_vel_sent"], three["late_ticks"], three["mean_step_time_ms"].as_f64().unwrap_or(f64::NAN)
    );
}
