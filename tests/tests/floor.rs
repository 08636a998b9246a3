//! End to end: `swarm floor` flies the same flight as a lockstep `swarm run`, without a message.
//! Its per-tick cost is quoted as the floor under the distributed run's, which means something
//! only if it is the same computation: the test is that both write the same run folder (the
//! trajectories byte for byte), over netem loss and delay, a partition and a freeze, ICP and
//! broadcast.

mod common;

use common::{output_within, run_id, swarm_run, RUN_LIMIT, SWARM};
use std::path::Path;
use std::process::Command;

/// `swarm floor` of `scenario` for `seconds` of sim time, writing under `out`.
fn floor(scenario: &str, seconds: &str, out: &Path) -> std::process::Output {
    let out = out.to_str().expect("utf8");
    output_within(
        Command::new(SWARM).args(["floor", "--scenarios", scenario, "--time-limit", seconds, "--json", "--out", out]),
        RUN_LIMIT,
    )
}

/// `summary.json` without what only a distributed run has or only the wall clock sets: the run
/// id, wall time and speed, the hub's and agents' timing, step times, traffic.
fn comparable(mut s: serde_json::Value) -> serde_json::Value {
    let o = s.as_object_mut().expect("a summary object");
    for k in ["run_id", "wall_time_s", "sim_speed", "timing", "traffic"] {
        assert!(o.remove(k).is_some(), "summary.json has no {k}");
    }
    for a in o.get_mut("agents").and_then(serde_json::Value::as_array_mut).expect("agents") {
        let a = a.as_object_mut().expect("an agent");
        a.retain(|k, _| !k.contains("step_time"));
    }
    s
}

/// Flies `scenario` for `seconds` both ways and asserts the two flights are one: the same
/// trajectories byte for byte, the same localization rows (the recorder writes a tick's rows in
/// the order the states came), the same summary but for the wall clock's and the network's parts.
fn same_flight(scenario: &str, seconds: &str) {
    let dir = tempfile::tempdir().expect("tempdir");
    let got = floor(scenario, seconds, &dir.path().join("floor"));
    assert!(got.status.success(), "{}", String::from_utf8_lossy(&got.stderr));
    let rows: serde_json::Value = serde_json::from_slice(&got.stdout).expect("floor --json");
    let row = &rows[0];
    assert_eq!(row["scenario"], scenario, "{rows:#}");
    assert!(row["floor_ms_per_tick"].as_f64().is_some_and(|ms| ms > 0.0), "{rows:#}");
    let run = dir.path().join("run");
    let limit = format!("end.time_limit_s={seconds}");
    let args = [scenario, "--set", &limit, "--time-mode", "lockstep", "--no-mcap", "--run", &run_id("floor")];
    let flown = swarm_run(&[&args[..], &["--out", run.to_str().expect("utf8")]].concat());
    assert!(flown.status.code().is_some_and(|c| c <= 1), "{}", String::from_utf8_lossy(&flown.stderr));
    let floor = dir.path().join("floor").join(scenario);
    let read = |dir: &Path, f: &str| std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    let (distributed, in_process) = (read(&run, "trajectories.csv"), read(&floor, "trajectories.csv"));
    let ticks = distributed.lines().count();
    assert!(ticks > 100, "{ticks} lines");
    let first_difference = distributed.lines().zip(in_process.lines()).position(|(a, b)| a != b);
    assert_eq!(first_difference, None, "the flights part at line {first_difference:?}");
    assert_eq!(distributed, in_process);
    let sorted = |text: String| {
        let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
        lines.sort();
        lines
    };
    let estimates = sorted(read(&run, "localization.csv"));
    assert!(estimates.len() > 100, "{} estimate rows", estimates.len());
    assert_eq!(estimates, sorted(read(&floor, "localization.csv")));
    let summary = |dir: &Path| comparable(serde_json::from_str(&read(dir, "summary.json")).expect("summary.json"));
    assert_eq!(summary(&run), summary(&floor));
}

/// Broadcast over 30 % loss and normal delay: the netem link and its draws are the node's.
#[test]
fn the_floor_flies_the_lockstep_flight_over_a_lossy_link() {
    same_flight("forest-5-lossy", "25");
}

/// ICP through burst loss, a partition and a frozen informed UAV (each its own netem rule).
#[test]
fn the_floor_flies_the_lockstep_flight_over_icp_partitioned() {
    same_flight("forest-9-cut-off-icp", "35");
}

/// A scenario that kills an agent process is refused, by name, with the reason.
#[test]
fn the_floor_refuses_what_it_cannot_fly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let got = floor("open-field-5-restart", "5", dir.path());
    assert!(!got.status.success());
    let err = String::from_utf8_lossy(&got.stderr);
    assert!(err.contains("open-field-5-restart") && err.contains("freezes only"), "{err}");
}
