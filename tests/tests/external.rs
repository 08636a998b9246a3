//! End to end over real Zenoh and real processes: UAV 3 of forest-5 flown by a controller
//! outside our processes, `examples/python/external_uav.py` on eclipse-zenoh alone, logged in as
//! `ext3`. Its agent still perceives, localizes and shares, so its neighbours localize it.

mod common;

use common::{hub_locator, python, run_id, summary, wait_output, RUN_LIMIT, SWARM};
use std::process::{Command, Stdio};
use std::time::Duration;

/// The example a user runs.
const EXTERNAL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/python/external_uav.py");

#[test]
fn an_external_python_controller_flies_uav_3_through_forest5() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("run");
    let run = run_id("ext");
    let args = ["run", "forest-5", "--external", "3", "--out", out.to_str().expect("utf8"), "--run", &run, "--quiet"];
    let swarm =
        Command::new(SWARM).args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("swarm run");
    let loc = hub_locator(&out);
    let password = out.join("credentials/ext3.password");
    let ext_args = [
        "--run",
        &run,
        "--id",
        "3",
        "--connect",
        &loc,
        "--user",
        "ext3",
        "--password-file",
        password.to_str().expect("utf8"),
    ];
    let ext = Command::new(python())
        .arg(EXTERNAL)
        .args(ext_args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python");
    let o = wait_output(swarm, RUN_LIMIT, "swarm run --external 3");
    let e = wait_output(ext, Duration::from_secs(60), "external_uav.py");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(e.status.success(), "the controller ended badly: {}", String::from_utf8_lossy(&e.stderr));
    let s = summary(&out);
    assert_eq!(s["reached_goal"], true, "{s:#}");
    assert_eq!(s["collisions"], 0, "{:#}", s["collision_events"]);
    let agents = s["agents"].as_array().expect("agents");
    let three = agents.iter().find(|a| a["id"] == 3).expect("UAV 3");
    assert_eq!(three["late_ticks"], 0, "every external command in time: {three:#}");
    let ticks = s["ticks"].as_u64().expect("ticks");
    let placed = three["placed_by_others"].as_u64().expect("placed_by_others");
    assert!(
        placed > ticks,
        "its neighbours localized UAV 3 ({placed} estimates within 1 m over {ticks} ticks): {three:#}"
    );
    let k21_step = agents
        .iter()
        .filter(|a| a["id"] != 3)
        .map(|a| a["mean_step_time_ms"].as_f64().expect("step"))
        .fold(0.0, f64::max);
    eprintln!(
        "external UAV 3: mean step {:.3} ms (view out, command back) vs the K21 UAVs' at most {k21_step:.3} ms; placed by others {placed} times in {ticks} ticks",
        three["mean_step_time_ms"].as_f64().expect("step")
    );
}

/// Without its controller the UAV's agent gives up after the startup timeout, saying why; the
/// hub starts without it, as without any agent that never came, and its body stays where it is.
#[test]
fn an_external_uav_whose_controller_never_comes_says_so_and_stays_put() {
    let dir = tempfile::tempdir().expect("tempdir");
    let sc = std::path::PathBuf::from(common::forest5_cut(dir.path(), 20.0));
    let text = std::fs::read_to_string(&sc).expect("forest-5 cut");
    let short = text.replace("[time]\n", "[time]\nstartup_timeout_s = 3.0\n");
    assert_ne!(short, text, "forest-5's [time] table moved");
    std::fs::write(&sc, short).expect("write");
    let out = dir.path().join("run");
    let run = run_id("noext");
    let args = [
        "run",
        sc.to_str().expect("utf8"),
        "--external",
        "2",
        "--out",
        out.to_str().expect("utf8"),
        "--run",
        &run,
        "--quiet",
    ];
    let swarm =
        Command::new(SWARM).args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("swarm run");
    let o = wait_output(swarm, RUN_LIMIT, "swarm run --external 2 with no controller");
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(printed.contains("WARNING: the agents of UAVs [2] never joined"), "the terminal says so: {printed}");
    let logs: String = std::fs::read_dir(out.join("logs"))
        .expect("logs")
        .map(|e| std::fs::read_to_string(e.expect("entry").path()).unwrap_or_default())
        .collect();
    assert!(
        logs.contains("UAV 2 waits for its external controller (alive/ext/2), which did not come within 3 s"),
        "{logs}"
    );
    let s = summary(&out);
    assert_eq!(s["never_joined"], serde_json::json!([2]), "summary.json says so");
    let two = s["agents"].as_array().expect("agents").iter().find(|a| a["id"] == 2).expect("UAV 2");
    assert!(two["path_length_m"].as_f64().expect("path") < 0.05, "UAV 2 moved without a controller: {two:#}");
    let others = s["agents"]
        .as_array()
        .expect("agents")
        .iter()
        .filter(|a| a["id"] != 2)
        .map(|a| a["path_length_m"].as_f64().expect("path"));
    assert!(others.clone().all(|p| p > 5.0), "the others flew: {s:#}");
}
