//! End to end over real Zenoh and real processes: the example's binary, the whole `swarm`
//! command line plus its `potential-field` controller, flies forest-5 with it, and refuses a
//! scenario naming a controller it does not know.

use std::path::Path;
use std::process::{Command, Output};
use std::sync::atomic::{AtomicU32, Ordering};

/// The example's binary.
const OWN: &str = env!("CARGO_BIN_EXE_own-controller");

/// The scenario docs/own-controller.md runs.
const SCENARIO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/forest-5-own.toml");

/// A run id no other test process uses.
fn run_id(tag: &str) -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!("own{}-{}-{tag}", std::process::id(), N.fetch_add(1, Ordering::Relaxed))
}

fn fly(scenario: &Path, out: &Path, tag: &str) -> Output {
    let run = run_id(tag);
    let args =
        ["run", scenario.to_str().expect("utf8"), "--out", out.to_str().expect("utf8"), "--run", &run, "--quiet"];
    Command::new(OWN).args(args).output().expect("own-controller runs")
}

#[test]
fn the_potential_field_flies_forest5_to_the_goal_without_collision() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("run");
    let o = fly(Path::new(SCENARIO), &out, "pf");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).expect("summary")).expect("json");
    assert_eq!(s["reached_goal"], true, "{s:#}");
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);
    assert!(
        s["agents"].as_array().expect("agents").iter().all(|a| a["late_ticks"] == 0),
        "every command on time: {s:#}"
    );
}

#[test]
fn a_controller_nobody_registered_is_refused_naming_the_known_ones() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = std::fs::read_to_string(SCENARIO).expect("scenario").replace("\"potential-field\"", "\"nobody\"");
    let path = dir.path().join("nobody.toml");
    std::fs::write(&path, text).expect("write");
    let o = fly(&path, &dir.path().join("run"), "nobody");
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("unknown controller `nobody`"), "{err}");
    assert!(err.contains("a21, k21, m23, p17, potential-field"), "{err}");
    assert!(!dir.path().join("run").exists(), "nothing flew: {err}");
}
