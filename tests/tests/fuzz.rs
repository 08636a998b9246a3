//! `swarm fuzz` end to end (issue 15): a deliberately weakened swarm (K21 with its separation
//! turned off) is found within a small budget and shrunk to at most three UAVs, and the written
//! scenario file, flown again with `swarm run --check`, fails the same check.

mod common;

use common::{output_within, swarm_run, RUN_LIMIT, SWARM};
use std::process::Command;

#[test]
fn a_weakened_swarm_is_found_and_shrunk_to_a_scenario_of_at_most_three_uavs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("fuzz");
    let out_s = out.to_str().expect("utf-8 path");
    let args = [
        "fuzz",
        "--seed",
        "1",
        "--runs",
        "2",
        "--jobs",
        "2",
        "--controllers",
        "k21",
        "--max-uavs",
        "5",
        "--weaken",
        "separation",
    ];
    let o = output_within(Command::new(SWARM).args(args).args(["--out", out_s]), RUN_LIMIT * 3);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(2), "fuzz reports a failure: {stdout}\n{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("fuzz.json")).expect("fuzz.json")).expect("json");
    // The finding that started from the largest swarm: shrinking, not luck, made it small.
    let findings = report["findings"].as_array().expect("findings[]");
    let finding = findings.iter().max_by_key(|f| f["original"].as_str().map(uavs_in)).expect("a finding");
    let check = finding["check"].as_str().expect("a failed check").to_string();
    let file = finding["file"].as_str().expect("a scenario file").to_string();
    assert!(stdout.contains(&format!("`{check}` failed")), "the shrunk scenario is printed: {stdout}");

    let text = std::fs::read_to_string(&file).expect("the shrunk scenario");
    let sc: toml::Value = toml::from_str(&text).expect("the file is TOML");
    let count = sc["swarm"]["count"].as_integer().expect("swarm.count");
    assert!((1..=3).contains(&count), "shrunk to at most 3 UAVs, got {count}:\n{text}");
    assert_eq!(sc["controller"]["k21"]["ks"].as_float(), Some(0.0), "still the weakened swarm");

    // Anyone can fly it: the same check fails again.
    let again = dir.path().join("again");
    let o = swarm_run(&[&file, "--check", "--out", again.to_str().expect("utf-8 path")]);
    assert_eq!(o.status.code(), Some(2), "`swarm run --check` fails: {}", String::from_utf8_lossy(&o.stdout));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(again.join("summary.json")).expect("summary")).expect("json");
    let failed: Vec<&str> = s["checks"]
        .as_array()
        .expect("checks[]")
        .iter()
        .filter(|c| c["passed"] == false)
        .filter_map(|c| c["name"].as_str())
        .collect();
    assert!(failed.contains(&check.as_str()), "the same check `{check}` fails again: {failed:?}");
    let first =
        s["checks"].as_array().expect("checks[]").iter().find(|c| c["name"] == check.as_str()).expect("the check");
    assert!(
        first["first_failure"]["t_s"].as_f64().is_some()
            && !first["first_failure"]["uavs"].as_array().expect("uavs").is_empty()
    );
}

/// The UAV count in a case label (`k21/icp 5 uavs ...`).
fn uavs_in(label: &str) -> u32 {
    label.split_whitespace().nth(1).and_then(|n| n.parse().ok()).unwrap_or(0)
}
