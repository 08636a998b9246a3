//! End to end: `swarm sweep-seeds` flies a tiny sweep with real processes (3 seeds, 3 s each,
//! two at once), writes its table, JSON and pictures, and a second call with one more seed
//! flies only that one (resume); resuming into it with another localization mode is refused.
//! With `--floor` (each seed flown in the one process) the same seeds give the same outcomes,
//! and `--set` changes every run's scenario.

mod common;

use common::{output_within, RUN_LIMIT, SWARM};
use std::process::Command;

fn sweep(out: &std::path::Path, seeds: &str) -> (String, String) {
    sweep_with(out, seeds, &[])
}

fn sweep_with(out: &std::path::Path, seeds: &str, extra: &[&str]) -> (String, String) {
    let o = output_within(
        Command::new(SWARM)
            .args([
                "sweep-seeds",
                "forest-5",
                "--seeds",
                seeds,
                "--jobs",
                "2",
                "--time-limit",
                "3",
                "--localization",
                "broadcast",
            ])
            .args(extra)
            .arg("--out")
            .arg(out),
        RUN_LIMIT,
    );
    let (stdout, stderr) =
        (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned());
    assert!(o.status.success(), "{stderr}");
    (stdout, stderr)
}

#[test]
fn sweep_seeds_flies_each_seed_once_and_resumes() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("sweep");
    let (table, _) = sweep(&out, "1..3");
    // 3 s is too short to reach the goal: 0 of 3, Wilson 95 % upper bound 56.15 %.
    assert!(table.contains("| success (goal, no collision) % | 3 | 0.00 (0/3; Wilson 0.00–56.15) |"), "{table}");
    assert!(table.contains("| min UAV distance m | 3 |"), "{table}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("sweep.json")).expect("sweep.json")).expect("JSON");
    let seeds: Vec<u64> = report["runs"].as_array().expect("runs").iter().filter_map(|r| r["seed"].as_u64()).collect();
    assert_eq!(seeds, [1, 2, 3]);
    for seed in 1..=3 {
        let run = out.join(format!("seed-{seed:03}"));
        let scenario = std::fs::read_to_string(run.join("scenario.toml")).expect("the run's scenario");
        assert!(scenario.contains(&format!("seed = {seed}")), "seed {seed} flown with its own seed: {scenario}");
        assert!(run.join("summary.json").exists(), "each run's summary is kept");
    }
    for f in ["sweep.md", "sweep.svg", "sweep.png"] {
        assert!(std::fs::metadata(out.join(f)).is_ok_and(|m| m.len() > 100), "{f} written");
    }

    let first = std::fs::read(out.join("seed-001/summary.json")).expect("summary");
    let (table, stderr) = sweep(&out, "1..4");
    assert!(stderr.contains("3 seeds already flown"), "{stderr}");
    assert!(
        !stderr.contains("seed-001: running") && stderr.contains("seed-004: running"),
        "only the new seed flies: {stderr}"
    );
    assert_eq!(
        std::fs::read(out.join("seed-001/summary.json")).expect("summary"),
        first,
        "a flown run is not flown again"
    );
    assert!(table.contains("| collisions | 4 |"), "{table}");

    // The same folder for another experiment: refused, naming what the kept runs were.
    let o = output_within(
        Command::new(SWARM)
            .args(["sweep-seeds", "forest-5", "--seeds", "1..2", "--time-limit", "3", "--localization", "icp", "--out"])
            .arg(&out),
        RUN_LIMIT,
    );
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{said}");
    assert!(said.contains("seed-001 was flown as forest-5 (broadcast), not forest-5 (icp)"), "{said}");
    assert_eq!(std::fs::read(out.join("seed-001/summary.json")).expect("summary"), first, "nothing flown over it");
}

/// Every metric of a sweep but the wall-clock one, per seed: what two ways of flying the same
/// seeds must agree on.
fn outcomes(out: &std::path::Path) -> Vec<(u64, Vec<String>)> {
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("sweep.json")).expect("sweep.json")).expect("JSON");
    let keys: Vec<&str> =
        report["metrics"].as_array().expect("metrics").iter().filter_map(|m| m["key"].as_str()).collect();
    let runs = report["runs"].as_array().expect("runs");
    runs.iter()
        .map(|r| {
            let values = r["values"].as_array().expect("values");
            let kept = keys.iter().zip(values).filter(|(k, _)| **k != "x_real_time").map(|(_, v)| v.to_string());
            (r["seed"].as_u64().expect("seed"), kept.collect())
        })
        .collect()
}

#[test]
fn sweep_seeds_in_one_process_flies_the_same_outcomes_and_takes_settings() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (processes, floor) = (dir.path().join("processes"), dir.path().join("floor"));
    sweep(&processes, "1..2");
    let (table, _) = sweep_with(&floor, "1..2", &["--floor"]);
    assert!(table.contains("| collisions | 2 |"), "{table}");
    let want = outcomes(&processes);
    assert_eq!(want.len(), 2);
    assert_eq!(outcomes(&floor), want, "the floor flies each seed's lockstep flight");

    // A setting reaches every run's scenario (a shorter radio: other outcomes).
    let set = dir.path().join("set");
    sweep_with(&set, "1..2", &["--floor", "--set", "radio.range_m=3"]);
    for seed in 1..=2 {
        let text = std::fs::read_to_string(set.join(format!("seed-{seed:03}/scenario.toml"))).expect("scenario");
        let sc: toml::Value = toml::from_str(&text).expect("TOML");
        assert_eq!(sc["radio"]["range_m"].as_float(), Some(3.0), "{text}");
    }
    assert_ne!(outcomes(&set), want, "a 3 m radio flies otherwise");
}
