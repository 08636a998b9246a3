//! ROS 2's own code against the run: ROS 2 Jazzy's rclpy (PyPI wheels, Fast DDS) and PyPI
//! zenoh-ros2-sdk, no code of ours on the ROS side.
//!
//! - Over DDS, in a network namespace of its own with nothing but loopback (so discovery meets
//!   no other test and no packet leaves the machine), rclpy subscribes to a UAV's scan, odometry,
//!   the clock and the world markers, follows sim time, lists the graph, and flies an external
//!   UAV with its Twist.
//! - rclpy plays a vehicle's drivers for an agent on ROS topics: it publishes scan, odometry and
//!   goal, and gets the agent's TwistStamped of each tick.
//! - forest-5 with UAV 3's agent fed only through ROS topics reaches the goal with no collision,
//!   byte for byte the same twice on DDS and once on rmw_zenoh.
//! - On rmw_zenoh, rclpy's serializer reads the bytes we put and makes the Twist that flies UAV 3,
//!   and zenoh-ros2-sdk lists and echoes our topics.
//! - The type hashes in our keys are those of the installed messages' own descriptions.
//!
//! Each prints what it saw (`cargo test -- --nocapture` shows it; `.ci/run` runs them).

mod common;

/// What ROS 2's own code saw, printed and kept in `target/tmp/rclpy-report.txt` (appended, one
/// test after another): CI prints that file after the test command, so what was measured shows
/// without running these tests twice.
macro_rules! report {
    ($($arg:tt)*) => {{
        let line = format!($($arg)*);
        println!("{line}");
        let path = concat!(env!("CARGO_TARGET_TMPDIR"), "/rclpy-report.txt");
        let file = std::fs::OpenOptions::new().create(true).append(true).open(path);
        if let Ok(mut f) = file {
            let _ = std::io::Write::write_all(&mut f, format!("{line}\n").as_bytes());
        }
    }};
}

use common::{ros_python, ros_share, LoopbackNs};
use serde_json::Value;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::Duration;

const RCLPY_DDS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros2/rclpy_dds.py");
const RCLPY_AGENT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros2/rclpy_agent.py");
const RCLPY_ZENOH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/ros2/rclpy_zenoh.py");

/// How long a ROS client may take.
const CLIENT_LIMIT: Duration = Duration::from_secs(150);

/// A Python of the ROS venv inside `ns`, with Fast DDS kept to loopback as ROS 2 asks for it.
fn rclpy_in(ns: &LoopbackNs, script: &str) -> Command {
    let mut c = ns.command(ros_python());
    c.arg(script).env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST").env("ROS_DOMAIN_ID", "0");
    c.stdout(Stdio::piped()).stderr(Stdio::piped());
    c
}

/// The client's JSON line, after checking it exited well.
fn json_of(o: &Output, what: &str) -> Value {
    assert!(o.status.success(), "{what} failed: {}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let line = text.lines().last().unwrap_or_else(|| panic!("{what} printed nothing"));
    serde_json::from_str(line).unwrap_or_else(|e| panic!("{what} printed {line:?}: {e}"))
}

fn strs(v: &Value) -> Vec<String> {
    v.as_array().map(|a| a.iter().filter_map(|x| x.as_str().map(String::from)).collect()).unwrap_or_default()
}

/// The types rclpy lists for `topic` in `topics` (`{topic: [types]}`).
fn types<'a>(topics: &'a Value, topic: &str) -> Vec<&'a str> {
    topics[topic].as_array().map(|a| a.iter().filter_map(Value::as_str).collect()).unwrap_or_default()
}

fn moved(xs: &Value) -> f64 {
    let xs: Vec<f64> = xs.as_array().expect("odometry").iter().filter_map(Value::as_f64).collect();
    xs.last().copied().unwrap_or(0.0) - xs.first().copied().unwrap_or(0.0)
}

/// `swarm run ARGS` inside `ns` for `scenario` into `out`, under a fresh run id.
fn run_in(ns: &LoopbackNs, scenario: &str, out: &Path, args: &[&str]) -> std::process::Child {
    ns.command(common::SWARM)
        .args(["run", scenario, "--out", out.to_str().expect("utf8"), "--run", &common::run_id("rclpy"), "--quiet"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm run")
}

#[test]
fn rclpy_on_fast_dds_sees_the_swarm_follows_sim_time_and_flies_uav_3() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scenario = common::forest5_cut(dir.path(), 15.0);
    let out = dir.path().join("run");
    let ns = LoopbackNs::new("dds");
    let args = ["--external", "3", "--dds", "--ros2-localhost", "--ros2-truth", "--time-mode", "realtime"];
    let swarm = run_in(&ns, &scenario, &out, &args);
    let client = rclpy_in(&ns, RCLPY_DDS).spawn().expect("rclpy");
    let o = common::wait_output(swarm, common::RUN_LIMIT, "swarm run --dds");
    let seen = json_of(&common::wait_output(client, CLIENT_LIMIT, "rclpy_dds.py"), "rclpy_dds.py");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // Every packet stayed on this machine: the namespace has loopback and nothing else.
    assert_eq!(ns.interfaces(), vec!["lo".to_string()], "the test's namespace");
    let packets = ns.loopback_packets();
    assert!(packets > 1000, "DDS and Zenoh crossed loopback: {packets} packets");

    for (what, n) in [("scans", 50), ("odoms", 50), ("clocks", 50), ("neighbour_msgs", 20)] {
        assert!(seen[what].as_u64().unwrap_or(0) >= n, "{what}: {seen}");
    }
    assert_eq!(seen["scan_frame"], "uav3/base_link");
    assert_eq!(seen["ranges"], 750, "{seen}");
    assert_eq!((&seen["odom_frame"], &seen["odom_child"]), (&Value::from("uav3/odom"), &Value::from("uav3/base_link")));
    assert_eq!(seen["clock_increasing"], true, "{seen}");
    assert_eq!(seen["neighbour_frame"], "uav3/base_link");
    assert!(seen["neighbours_max"].as_u64().unwrap_or(0) >= 1, "UAV 3 estimated no neighbour: {seen}");
    // The world as RViz gets it: every tree of the run's world, and the goal.
    let world: Value = serde_json::from_str(&common::read(&out.join("world.json"))).expect("world.json");
    let trees = world["trees"].as_array().expect("trees").len() as u64;
    assert_eq!(seen["markers"]["trees"].as_u64(), Some(trees), "{seen}");
    assert_eq!(seen["markers"]["goal"], 1, "{seen}");
    assert_eq!(seen["marker_frame"], "world");
    // use_sim_time: the node's clock is the sim's (seconds into the run), not the wall's.
    let (node_s, clock_s) =
        (seen["sim_time_s"][0].as_f64().expect("node"), seen["sim_time_s"][1].as_f64().expect("clock"));
    assert!((node_s - clock_s).abs() < 1e-6 && clock_s < 20.0, "node clock {node_s} s, /clock {clock_s} s");

    let g = &seen["graph"];
    let nodes = strs(&g["nodes"]);
    for n in ["/swarm_bridge", "/uav1/swarm", "/uav3/swarm", "/uav5/swarm"] {
        assert!(nodes.contains(&n.to_string()), "{n} not in {nodes:?}");
    }
    let topics = &g["topics"];
    for (t, ty) in [
        ("/uav3/scan", "sensor_msgs/msg/LaserScan"),
        ("/uav3/odom", "nav_msgs/msg/Odometry"),
        ("/uav3/goal", "geometry_msgs/msg/PoseStamped"),
        ("/uav3/neighbours", "geometry_msgs/msg/PoseArray"),
        ("/clock", "rosgraph_msgs/msg/Clock"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/tf_static", "tf2_msgs/msg/TFMessage"),
        ("/world/markers", "visualization_msgs/msg/MarkerArray"),
    ] {
        assert_eq!(types(topics, t), vec![ty], "{t}: {topics}");
    }
    // The RViz config we ship shows topics this graph has.
    let rviz = common::read(&common::root().join("docs/swarm.rviz"));
    for t in rviz.lines().filter_map(|l| l.trim().strip_prefix("Value: /")) {
        assert!(!types(topics, &format!("/{t}")).is_empty(), "docs/swarm.rviz shows /{t}, which no one publishes");
    }
    let cmd_vel = types(topics, "/uav3/cmd_vel");
    assert!(
        cmd_vel.contains(&"geometry_msgs/msg/Twist") && cmd_vel.contains(&"geometry_msgs/msg/TwistStamped"),
        "{cmd_vel:?}"
    );
    assert!(types(topics, "/uav2/cmd_vel").is_empty(), "UAV 2 is not external: {topics}");
    assert_eq!(types(&g["uav3_publishers"], "/uav3/scan"), vec!["sensor_msgs/msg/LaserScan"], "{g}");
    assert!(!types(&g["uav3_subscriptions"], "/uav3/cmd_vel").is_empty(), "{g}");
    assert_eq!(g["scan_publishers"], serde_json::json!([["swarm", "/uav3", "BEST_EFFORT"]]), "sensor data QoS");

    let dx = moved(&seen["odom_x"]);
    assert!(dx > 3.0, "UAV 3 moved {dx:.2} m ahead on a 0.8 m/s Twist: {seen}");
    let s = common::summary(&out);
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);
    report!(
        "rclpy over Fast DDS: {} scans, {} odometry, {} clock, {} neighbour arrays, markers {}; graph nodes {nodes:?}; \
         {} topics; UAV 3 moved {dx:.2} m on {} Twists; hub put -> rclpy callback p50 {} ms (scan), {} ms (clock); \
         {packets} loopback packets, interfaces {:?}",
        seen["scans"],
        seen["odoms"],
        seen["clocks"],
        seen["neighbour_msgs"],
        seen["markers"],
        topics.as_object().map_or(0, |m| m.len()),
        seen["cmd_vel_sent"],
        seen["latency_ms_p50"]["scan"],
        seen["latency_ms_p50"]["clock"],
        ns.interfaces()
    );
}

#[test]
fn rclpy_feeds_an_agent_on_ros_topics_and_gets_its_command_for_each_tick() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ns = LoopbackNs::new("agent");
    let run = common::run_id("rosagent");
    let started = |args: &[&str], log: &str| {
        let err = std::fs::File::create(dir.path().join(log)).expect("log");
        let mut c = ns.command(common::SWARM);
        c.args(args).stdin(Stdio::piped()).stdout(Stdio::null()).stderr(Stdio::from(err));
        let mut child = c.spawn().expect("spawn");
        let stdin = child.stdin.take();
        common::Proc { child, stdin }
    };
    // A fresh namespace: the default port is free.
    let _hub = started(
        &["hub", "forest-5", "--run", &run, "--insecure", "--listen", "tcp/127.0.0.1:7447", "--exit-with-stdin"],
        "hub.log",
    );
    let agent_args = [
        "agent",
        "--run",
        &run,
        "--id",
        "3",
        "--sensors",
        "ros2",
        "--dds",
        "--localhost",
        "--connect",
        "tcp/127.0.0.1:7447",
        "--exit-with-stdin",
    ];
    let _agent = started(&agent_args, "agent.log");
    let ticks = 20;
    let mut c = rclpy_in(&ns, RCLPY_AGENT);
    c.args(["3", &ticks.to_string()]);
    let seen =
        json_of(&common::wait_output(c.spawn().expect("rclpy"), CLIENT_LIMIT, "rclpy_agent.py"), "rclpy_agent.py");
    let log = || common::read(&dir.path().join("agent.log"));

    let sent: Vec<f64> = seen["sent"].as_array().expect("sent").iter().filter_map(Value::as_f64).collect();
    let cmds = seen["commands"].as_array().expect("commands");
    assert_eq!(cmds.len(), ticks, "one command per tick: {seen}\nagent log:\n{}", log());
    for (cmd, t) in cmds.iter().zip(&sent) {
        let stamp = cmd[0].as_f64().expect("stamp");
        assert!((stamp - t).abs() < 1e-9, "the command of the scan stamped {t} is stamped {stamp}");
        assert_eq!(cmd[4], "uav3/base_link", "{cmd}");
        let (x, y) = (cmd[1].as_f64().expect("x"), cmd[2].as_f64().expect("y"));
        assert!(x > 0.1 && y.abs() < 0.05, "the goal is 30 m straight ahead between two trunks: {cmd}");
    }
    let g = &seen["graph"];
    assert!(strs(&g["nodes"]).contains(&"/uav3/agent".to_string()), "{g}");
    for (t, ty) in [
        ("/uav3/scan", "sensor_msgs/msg/LaserScan"),
        ("/uav3/odom", "nav_msgs/msg/Odometry"),
        ("/uav3/goal", "geometry_msgs/msg/PoseStamped"),
    ] {
        assert_eq!(types(&g["agent_subscriptions"], t), vec![ty], "{g}");
    }
    assert_eq!(types(&g["agent_publishers"], "/uav3/cmd_vel"), vec!["geometry_msgs/msg/TwistStamped"], "{g}");
    report!(
        "an agent on ROS topics: {} warm-up tick(s) until discovery settled, then {} scans sent by rclpy, {} TwistStamped \
         back, each with its scan's stamp; first {}, last {}; graph {}",
        seen["warmup"],
        sent.len(),
        cmds.len(),
        cmds[0],
        cmds[cmds.len() - 1],
        g
    );
}

/// One forest-5 run's figures, for the table the test prints.
fn figures(out: &Path) -> (Value, String) {
    let s = common::summary(out);
    let loc = &s["localization"];
    let f = |v: &Value| v.as_f64().map_or("-".to_string(), |x| format!("{x:.3}"));
    let line = format!(
        "goal {} s, collisions {}, min distance to obstacles {} m, to UAVs {} m, localization error mean {} m, p95 {} m",
        f(&s["time_to_goal_s"]),
        s["collisions"],
        f(&s["min_obstacle_distance_m"]),
        f(&s["min_agent_distance_m"]),
        f(&loc["mean_error_m"]),
        f(&loc["p95_error_m"])
    );
    (s, line)
}

#[test]
fn forest_5_reaches_the_goal_with_uav_3_on_ros_topics_the_same_on_dds_and_rmw_zenoh() {
    let dir = tempfile::tempdir().expect("tempdir");
    let ns = LoopbackNs::new("loop");
    let runs = [
        ("dds", vec!["--dds", "--ros2-localhost", "--ros2-agents", "3"]),
        ("dds-again", vec!["--dds", "--ros2-localhost", "--ros2-agents", "3"]),
        ("rmw_zenoh", vec!["--ros2-agents", "3"]),
        ("hub keys", vec![]),
    ];
    let mut table = Vec::new();
    let mut tracks = Vec::new();
    for (name, args) in &runs {
        let out = dir.path().join(name.replace(' ', "-"));
        let o = common::wait_output(run_in(&ns, "forest-5", &out, args), common::RUN_LIMIT, name);
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        let (s, line) = figures(&out);
        assert_eq!(s["end_reason"], "goal", "{name}: {line}");
        assert_eq!(s["collisions"], 0, "{name}: {:#}", s["collision_events"]);
        table.push(format!("{name:>10}: {line}"));
        tracks.push(common::read(&out.join("trajectories.csv")));
    }
    assert!(tracks[0] == tracks[1], "two lockstep runs with UAV 3 on DDS topics differ");
    assert!(tracks[0] == tracks[2], "UAV 3 on rmw_zenoh topics flies otherwise than on DDS");
    report!("forest-5, UAV 3's agent fed only through ROS 2 topics (lockstep):\n{}", table.join("\n"));
}

#[test]
fn rclpy_reads_the_rmw_zenoh_side_and_zenoh_ros2_sdk_lists_and_echoes_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scenario = common::forest5_cut(dir.path(), 15.0);
    let out = dir.path().join("run");
    let args = ["run", &scenario, "--external", "3", "--ros2", "--time-mode", "realtime", "--quiet"];
    let swarm = Command::new(common::SWARM)
        .args(args)
        .args(["--out", out.to_str().expect("utf8"), "--run", &common::run_id("rmwz")])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm run");
    let loc = common::hub_locator(&out);
    let password = out.join("credentials/ros.password");
    let client = Command::new(ros_python())
        .args([RCLPY_ZENOH, &loc, password.to_str().expect("utf8"), ros_share().to_str().expect("utf8")])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python");
    let o = common::wait_output(swarm, common::RUN_LIMIT, "swarm run --ros2");
    let seen = json_of(&common::wait_output(client, CLIENT_LIMIT, "rclpy_zenoh.py"), "rclpy_zenoh.py");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for what in ["scans", "odoms", "clocks", "sdk_odoms"] {
        assert!(seen[what].as_u64().unwrap_or(0) >= 50, "{what}: {seen}");
    }
    assert_eq!(seen["scan_frame"], "uav3/base_link");
    assert_eq!(seen["ranges"], 750);
    assert_eq!(seen["sdk_odom_frame"], "uav3/odom", "zenoh-ros2-sdk decoded our odometry: {seen}");
    assert_eq!(seen["truth_samples"], 0, "a `ros` login read the world markers (truth): {seen}");
    let topics = &seen["sdk_topics"];
    for (t, ty) in [
        ("/uav3/scan", "sensor_msgs/msg/LaserScan"),
        ("/clock", "rosgraph_msgs/msg/Clock"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
    ] {
        assert_eq!(types(topics, t), vec![ty], "zenoh-ros2-sdk's topic list: {topics}");
    }
    let dx = moved(&seen["odom_x"]);
    assert!(dx > 3.0, "UAV 3 moved {dx:.2} m on rclpy's serialized Twist: {seen}");
    report!(
        "rmw_zenoh side: rclpy deserialized {} scans, {} odometry, {} clock; zenoh-ros2-sdk echoed {} odometry and lists {} topics; \
         UAV 3 moved {dx:.2} m on {} Twists serialized by rclpy; hub put -> client p50 {} ms (scan)",
        seen["scans"],
        seen["odoms"],
        seen["clocks"],
        seen["sdk_odoms"],
        topics.as_object().map_or(0, |m| m.len()),
        seen["cmd_vel_sent"],
        seen["latency_ms_p50"]["scan"]
    );
}

#[test]
fn our_type_hashes_are_the_installed_messages_own() {
    let mut checked = Vec::new();
    for t in swarm_ros2::types::ALL {
        let mut parts = t.ros.split('/');
        let (pkg, kind, name) = (parts.next().expect("pkg"), parts.next().expect("msg"), parts.next().expect("name"));
        let file = ros_share().join(pkg).join(kind).join(format!("{name}.json"));
        if pkg == "tf2_msgs" {
            // No wheel of tf2_msgs: its hash is checked against rosbags in ros2.rs.
            assert!(!file.exists(), "tf2_msgs is installed now: check it here");
            continue;
        }
        let desc: Value = serde_json::from_str(&common::read(&file)).expect("a type description");
        assert_eq!(desc["type_hashes"][0]["hash_string"], t.hash, "{}", t.ros);
        checked.push(t.ros);
    }
    assert_eq!(checked.len(), swarm_ros2::types::ALL.len() - 1);
    report!("type hashes equal the installed ROS 2 Jazzy messages' own: {checked:?}");
}
