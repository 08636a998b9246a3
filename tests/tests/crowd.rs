//! End to end: K21 in a crowd (issue 11, item 1). Seed 000 section 6.4 flew 40 UAVs on the
//! controller alone with no collision, a minimum UAV distance of 1.31 m and a minimum obstacle
//! distance of 1.06 m; `forest-40` repeats that through `swarm run` with agent hosts, real Zenoh
//! and broadcast localization, in lockstep (so the outcome does not depend on the machine's
//! load). forest-100 is measured, not tested here (CI time; README gives its numbers).

mod common;

use common::{run_id, summary, swarm_run};

/// forest-40 in lockstep, broadcast localization (the controller alone), two agent hosts of 20:
/// no collision, UAVs never closer than 1.0 m, trees never closer than 0.9 m, and every UAV
/// within the 15 m goal disc before the 400 s limit, as the hosts really ran it.
#[test]
fn forty_uavs_cross_the_forest_without_contact() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("crowd40");
    let out = swarm_run(&[
        "forest-40",
        "--agents-per-process",
        "20",
        "--out",
        dir.path().to_str().expect("utf8"),
        "--run",
        &run,
    ]);
    assert!(out.status.success(), "forest-40: {}", String::from_utf8_lossy(&out.stderr));
    let hosts = std::fs::read_dir(dir.path().join("logs"))
        .expect("logs")
        .filter(|e| e.as_ref().expect("entry").file_name().to_string_lossy().starts_with("agents-"))
        .count();
    assert_eq!(hosts, 2, "two agent hosts of 20 flew the run");
    let s = summary(dir.path());
    assert_eq!(s["uav_count"], 40, "{s:#}");
    assert_eq!(s["time_mode"], "lockstep", "{s:#}");
    assert_eq!(s["localization"]["mode"], "broadcast", "{s:#}");
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);
    let min = |k: &str| s[k].as_f64().unwrap_or(0.0);
    assert!(min("min_agent_distance_m") >= 1.0, "min UAV distance: {s:#}");
    assert!(min("min_obstacle_distance_m") >= 0.9, "min obstacle distance: {s:#}");
    // The swarm went into the trees at all: a UAV came within 2 m of a trunk.
    assert!(min("min_obstacle_distance_m") < 2.0, "never near a tree: {s:#}");
    assert_eq!(s["reached_goal"], true, "{s:#}");
    assert_eq!(s["end_reason"], "goal", "{s:#}");
}
