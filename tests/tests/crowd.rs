//! End to end: K21 in a crowd (issue 11, item 1). Seed 000 section 6.4 flew 40 UAVs on the
//! controller alone with no collision, a minimum UAV distance of 1.31 m and a minimum obstacle
//! distance of 1.06 m; `forest-40` repeats that through `swarm run` with agent hosts, real Zenoh
//! and broadcast localization, in lockstep (so the outcome does not depend on the machine's
//! load). `forest-40-icp` flies the same swarm on the full stack: every UAV placing its
//! neighbours by ICP on shared obstacle sets. `forest-40-arrive` asks the swarm to settle at its
//! goal (issue 25). forest-100 is measured, not tested here (CI time; docs/results.md gives its numbers).

mod common;

use common::{run_id, summary, swarm_run};

/// Flies `scenario` through `swarm run` on two agent hosts of 20, checks they ran it, in
/// lockstep, with `localization`, and returns the run folder and the summary.
fn fly_forty(scenario: &str, localization: &str) -> (tempfile::TempDir, serde_json::Value) {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id(scenario);
    let out = swarm_run(&[
        scenario,
        "--agents-per-process",
        "20",
        "--out",
        dir.path().to_str().expect("utf8"),
        "--run",
        &run,
    ]);
    assert!(out.status.success(), "{scenario}: {}", String::from_utf8_lossy(&out.stderr));
    let hosts = std::fs::read_dir(dir.path().join("logs"))
        .expect("logs")
        .filter(|e| e.as_ref().expect("entry").file_name().to_string_lossy().starts_with("agents-"))
        .count();
    assert_eq!(hosts, 2, "two agent hosts of 20 flew the run");
    let s = summary(dir.path());
    assert_eq!(s["uav_count"], 40, "{s:#}");
    assert_eq!(s["time_mode"], "lockstep", "{s:#}");
    assert_eq!(s["localization"]["mode"], localization, "{s:#}");
    (dir, s)
}

/// Seed 000 6.4's outcome: no collision, UAVs never closer than 1.0 m, trees never closer than
/// 0.9 m (but the swarm went among them: a UAV came within 2 m of a trunk), and every UAV
/// within the goal disc before the limit.
fn assert_crossed_without_contact(s: &serde_json::Value) {
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);
    let min = |k: &str| s[k].as_f64().unwrap_or(0.0);
    assert!(min("min_agent_distance_m") >= 1.0, "min UAV distance: {s:#}");
    assert!(min("min_obstacle_distance_m") >= 0.9, "min obstacle distance: {s:#}");
    assert!(min("min_obstacle_distance_m") < 2.0, "never near a tree: {s:#}");
    assert_eq!(s["reached_goal"], true, "{s:#}");
    assert_eq!(s["end_reason"], "goal", "{s:#}");
}

/// forest-40 in lockstep, broadcast localization (the controller alone), two agent hosts of 20.
#[test]
fn forty_uavs_cross_the_forest_without_contact() {
    assert_crossed_without_contact(&fly_forty("forest-40", "broadcast").1);
}

/// forest-40-icp: the same crossing with every neighbour placed by ICP, and the placements
/// right: at most 1 % of the scored estimates more than 1 m off (issue 11's bound), 95 % of them
/// within 0.1 m, and their mean error within 0.1 m (issue 11; met since issue 14's rules after
/// the first placement: 0.055 m).
#[test]
fn forty_uavs_cross_the_forest_on_icp_localization() {
    let (_dir, s) = fly_forty("forest-40-icp", "icp");
    assert_crossed_without_contact(&s);
    let l = &s["localization"];
    let scored = l["estimates_scored"].as_f64().expect("scored");
    let false_share = l["false_estimates"].as_f64().expect("false") / scored;
    assert!(scored > 100_000.0, "estimates were made all along: {l:#}");
    assert!(false_share <= 0.01, "false estimates {:.2} %: {l:#}", 100.0 * false_share);
    assert!(l["p95_error_m"].as_f64().expect("p95") <= 0.1, "{l:#}");
    assert!(l["mean_error_m"].as_f64().expect("mean") <= 0.1, "{l:#}");
}

/// Issue 25 item 4, arrival: forest-40-arrive asks every UAV within 8 m of the goal for 60 s
/// without a break (`hold_s`), which the orbiting swarm of seed 000's K21 never met. With the
/// arrival layer the swarm crosses and then settles: no contact and every invariant holds (the
/// packing at the goal brings neighbours closer than the flight does, to the barrier's 1 m and
/// a tick's motion, so the bound is the invariants' 0.8 m, not the crossing's 1 m), the goal is
/// met (the run ends 60 s after the whole swarm first held the disc), and at its last tick every
/// UAV is still inside 8 m and the centroid within 2 m of the goal.
#[test]
fn forty_uavs_settle_at_their_goal() {
    let (dir, s) = fly_forty("forest-40-arrive", "broadcast");
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);
    assert!(s["min_agent_distance_m"].as_f64().unwrap_or(0.0) >= 0.8, "{s:#}");
    let checks = s["checks"].as_array().expect("checks");
    assert!(!checks.is_empty() && checks.iter().all(|c| c["passed"] == true), "{checks:#?}");
    assert_eq!(s["end_reason"], "goal", "{s:#}");
    let arrived = s["time_to_goal_s"].as_f64().expect("time to goal");
    let ended = s["sim_time_s"].as_f64().expect("sim time");
    assert!(ended - arrived >= 60.0 - 1e-6, "held for 60 s: arrived {arrived} s, ended {ended} s");
    // What the recorder saw, read independently of the hub's goal rule (trajectories.csv:
    // tick,t_s,id,x_m,y_m,...): from the moment the hub says the swarm arrived, every UAV is
    // inside 8 m at every tick, and at the last tick the centroid is within 2 m of the goal.
    let csv = std::fs::read_to_string(dir.path().join("trajectories.csv")).expect("trajectories.csv");
    let rows: Vec<Vec<f64>> =
        csv.lines().skip(1).map(|l| l.split(',').take(5).map(|v| v.parse().unwrap_or(f64::NAN)).collect()).collect();
    let goal = (45.0, 0.0);
    let outside: Vec<&Vec<f64>> =
        rows.iter().filter(|r| r[1] >= arrived - 1e-6 && (r[3] - goal.0).hypot(r[4] - goal.1) > 8.0).collect();
    assert!(outside.is_empty(), "outside the disc after arriving: {:?}", &outside[..outside.len().min(5)]);
    let last = rows.iter().map(|r| r[0]).fold(f64::MIN, f64::max);
    let ends: Vec<(f64, f64)> = rows.iter().filter(|r| r[0] == last).map(|r| (r[3], r[4])).collect();
    assert_eq!(ends.len(), 40, "one row per UAV at the last tick");
    let centroid = ends.iter().fold((0.0, 0.0), |c, p| (c.0 + p.0 / 40.0, c.1 + p.1 / 40.0));
    assert!((centroid.0 - goal.0).hypot(centroid.1 - goal.1) <= 2.0, "centroid {centroid:?}");
}
