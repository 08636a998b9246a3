//! End to end: the pieces started by hand, as on several machines (hub with `--listen`, agents
//! (the lean `swarm-node` binary) and recorder with `--connect`), `swarm tap` on the key space,
//! and agents that outlive their hub exiting cleanly.

mod common;

use common::{output_within, run_id, start_hub, start_recorder, tap, wait_output, Proc, NODE, SWARM, TOOL_LIMIT};
use std::process::Command;
use std::time::Duration;

#[test]
fn pieces_by_hand_fly_and_tap_decodes_the_key_space() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("hand");
    let (mut hub, loc) = start_hub("open-field-5", &run, dir.path());

    // The scenario queryable answers the TOML text, printed as text.
    let got = tap(&[&format!("swarm/{run}/scenario"), "--get", "--connect", &loc, "--count", "1"]);
    let v: serde_json::Value = serde_json::from_str(got.lines().next().expect("a line")).expect("json line");
    assert!(v["text"].as_str().expect("text").contains("open-field-5"), "{v}");

    // Recorder first (it must see the whole run), then the five agents, each with only --connect,
    // from the lean `swarm-node` binary an agent host would carry.
    let out = dir.path().join("rec");
    let mut rec = start_recorder(&run, &loc, &out, dir.path());
    // A tap on the truth of the run, decoding postcard into JSON lines, while the swarm flies.
    let truth_tap = Command::new(SWARM)
        .args(["tap", &format!("swarm/{run}/truth/step"), "--connect", &loc, "--count", "3", "--duration", "60"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .expect("tap");
    std::thread::sleep(Duration::from_millis(300));
    let mut agents: Vec<Proc> = (1..=5)
        .map(|id| {
            Proc::start_program(
                NODE,
                &["agent", "--run", &run, "--id", &id.to_string(), "--connect", &loc, "--exit-with-stdin"],
                &dir.path().join(format!("agent-{id}.log")),
            )
        })
        .collect();

    let tapped = wait_output(truth_tap, TOOL_LIMIT, "tap of truth/step");
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&tapped.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("each line is JSON"))
        .collect();
    assert_eq!(lines.len(), 3, "tap stops after --count");
    assert_eq!(lines[0]["kind"], "truth_step");
    assert_eq!(lines[0]["msg"]["TruthStep"]["bodies"].as_array().expect("bodies").len(), 5);

    let status = rec.wait_for(Duration::from_secs(120)).expect("recorder finishes with the run");
    assert!(status.success());
    let s = common::summary(&out);
    assert_eq!(s["reached_goal"], true, "{s:#}");
    assert_eq!(s["collisions"], 0);

    // The hub ends the run by itself; every agent sees its token go and exits cleanly.
    assert!(hub.wait_for(Duration::from_secs(20)).expect("hub exits after the run").success());
    for a in &mut agents {
        let st = a.wait_for(Duration::from_secs(20)).expect("agent exits when its hub is gone");
        assert!(st.success(), "agent exit status {st:?}");
    }
}

#[test]
fn agent_whose_hub_dies_hovers_and_exits_cleanly() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("hubdies");
    let (mut hub, loc) = start_hub("forest-5", &run, dir.path());
    let mut agent =
        Proc::start(&["agent", "--run", &run, "--id", "1", "--connect", &loc], &dir.path().join("agent.log"));
    // The agent is alive when a liveliness tap sees its token.
    let alive =
        tap(&[&format!("swarm/{run}/alive/uav/1"), "--alive", "--connect", &loc, "--count", "1", "--duration", "30"]);
    assert!(alive.contains("\"alive\":true"), "{alive}");
    assert!(agent.child.try_wait().expect("try_wait").is_none(), "agent still running");
    // Close the hub's stdin: it stops; the agent must notice and exit with success.
    drop(hub.stdin.take());
    assert!(hub.wait_for(Duration::from_secs(20)).is_some(), "hub stops when told");
    let st = agent.wait_for(Duration::from_secs(20)).expect("agent exits instead of hanging");
    assert!(st.success(), "{st:?}");
    let log = std::fs::read_to_string(dir.path().join("agent.log")).expect("log");
    assert!(log.contains("hub gone"), "{log}");
}

#[test]
fn agent_with_an_id_outside_the_scenario_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("badid");
    let (_hub, loc) = start_hub("forest-5", &run, dir.path());
    let out =
        output_within(Command::new(SWARM).args(["agent", "--run", &run, "--id", "9", "--connect", &loc]), TOOL_LIMIT);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("UAV id 9 is not in this scenario"), "{err}");
}

/// Processes whose command line mentions `needle` (Linux /proc), other than this test process.
#[cfg(target_os = "linux")]
fn processes_with(needle: &str) -> usize {
    let me = std::process::id().to_string();
    std::fs::read_dir("/proc")
        .expect("procfs")
        .filter_map(Result::ok)
        .filter(|e| e.file_name().to_string_lossy().chars().all(|c| c.is_ascii_digit()) && e.file_name() != me.as_str())
        .filter_map(|e| std::fs::read(e.path().join("cmdline")).ok())
        .filter(|cmd| String::from_utf8_lossy(cmd).contains(needle))
        .count()
}

/// Kill the launcher outright (SIGKILL: no cleanup code runs) and its hub and agents still go:
/// each watches the stdin pipe the launcher held.
#[cfg(target_os = "linux")]
#[test]
fn children_die_with_a_killed_launcher() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("orphans");
    let mut launcher = Command::new(SWARM)
        .args([
            "run",
            "forest-5",
            "--time-mode",
            "realtime",
            "--quiet",
            "--run",
            &run,
            "--out",
            dir.path().to_str().expect("utf8"),
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("launcher");
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    while processes_with(&run) < 7 {
        assert!(std::time::Instant::now() < deadline, "launcher, hub and 5 agents never all ran");
        std::thread::sleep(Duration::from_millis(50));
    }
    launcher.kill().expect("SIGKILL");
    launcher.wait().expect("reaped");
    let deadline = std::time::Instant::now() + Duration::from_secs(20);
    while processes_with(&run) > 0 {
        assert!(std::time::Instant::now() < deadline, "{} children outlived the launcher", processes_with(&run));
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A sensor frame that decodes but whose parts are of different ticks (scan 1, odometry 2).
const MIXED_TICKS: &str = r#"{"Sense": {
    "radio": {"tick": 1, "id": 1, "in_range": [], "loss": []},
    "odom": {"tick": 2, "t_s": 0.2, "x": 0.0, "y": 0.0, "yaw": 0.0, "vx": 0.0, "vy": 0.0, "goal": null, "goal_vel": null},
    "gnss": null, "uvdar": null,
    "scan": {"tick": 1, "t_s": 0.1, "angle_min": 0.0, "angle_increment": 0.1, "max_range_m": 12.0, "ranges_m": []}}}"#;

/// Garbage on the wire is counted and dropped, never a panic: malformed payloads on an agent's
/// sensor key (bytes that do not decode, and a frame whose parts disagree on the tick) and on
/// the hub's command keys (including id 0, which has no body, and an agent host's message with a
/// command for a UAV its key does not name), mid-flight.
#[test]
fn malformed_messages_are_counted_and_dropped() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("garbage");
    let sc = dir.path().join("g.toml");
    std::fs::write(
        &sc,
        // Realtime at 4x: the run lasts 5 s of wall time, so the garbage surely lands mid-flight.
        "name = \"g\"\n[swarm]\ncount = 1\nstart_positions = [[0.0, 0.0]]\ngoal = [100.0, 0.0]\n[end]\ntime_limit_s = 20.0\n[time]\nmode = \"realtime\"\nrealtime_factor = 4.0\n",
    )
    .expect("scenario");
    let (mut hub, loc) = start_hub(sc.to_str().expect("utf8"), &run, dir.path());
    let out = dir.path().join("rec");
    let mut rec = start_recorder(&run, &loc, &out, dir.path());
    let mut agent =
        Proc::start(&["agent", "--run", &run, "--id", "1", "--connect", &loc], &dir.path().join("agent.log"));
    assert_eq!(
        tap(&[&format!("swarm/{run}/clock"), "--connect", &loc, "--count", "5", "--duration", "60"]).lines().count(),
        5
    );
    let put = |key: String, payload: &[&str]| {
        let o = output_within(Command::new(SWARM).args(["put", &key, "--connect", &loc]).args(payload), TOOL_LIMIT);
        assert!(o.status.success(), "put: {}", String::from_utf8_lossy(&o.stderr));
    };
    put(format!("swarm/{run}/uav/1/sense"), &["--hex", "ff ff ff ff 01"]);
    put(format!("swarm/{run}/uav/1/sense"), &["--json", MIXED_TICKS]);
    put(format!("swarm/{run}/uav/1/cmd"), &["--hex", "05 02"]);
    put(
        format!("swarm/{run}/uav/0/cmd"),
        &["--json", r#"{"Cmd": {"tick": 1, "kind": "Hover", "x": 0.0, "y": 0.0, "yaw_rate": 0.0}}"#],
    );
    put(
        format!("swarm/{run}/uav/77/cmd"),
        &["--json", r#"{"Cmd": {"tick": 1, "kind": "Hover", "x": 0.0, "y": 0.0, "yaw_rate": 0.0}}"#],
    );
    // An agent host's commands: a malformed message, and one naming a UAV its key does not.
    put(format!("swarm/{run}/host/1/cmd"), &["--hex", "0f 02"]);
    put(
        format!("swarm/{run}/host/1/cmd"),
        &[
            "--json",
            r#"{"Cmds": [{"id": 1, "cmd": {"tick": 1, "kind": "Hover", "x": 0.0, "y": 0.0, "yaw_rate": 0.0}}, {"id": 2, "cmd": {"tick": 1, "kind": "Hover", "x": 0.0, "y": 0.0, "yaw_rate": 0.0}}]}"#,
        ],
    );

    assert!(rec.wait_for(Duration::from_secs(120)).expect("the run ends").success());
    let s = common::summary(&out);
    assert_eq!(s["end_reason"], "time_limit", "the run went on to its end: {s:#}");
    assert_eq!(s["agents"][0]["malformed_messages"], 2, "the garbage and the mixed frame counted: {s:#}");
    assert!(s["agents"][0]["path_length_m"].as_f64().expect("n") > 5.0, "the agent kept flying: {s:#}");
    assert!(hub.wait_for(Duration::from_secs(20)).expect("hub exits").success(), "hub did not panic");
    assert!(agent.wait_for(Duration::from_secs(20)).expect("agent exits").success(), "agent did not panic");
    let hub_log = std::fs::read_to_string(dir.path().join("hub.log")).expect("log");
    assert!(hub_log.contains("malformed_cmds=2"), "the bad command and host message were counted: {hub_log}");
    assert!(
        hub_log.contains("ignored_cmds=3"),
        "the commands for UAVs 0 and 77, and the host's for UAV 2, were counted: {hub_log}"
    );
}

/// An agent that claims an id the hub's scenario does not have (it was given its own scenario
/// file) is ignored by the hub: no crash, no waiting for it; the real agent flies the run.
#[test]
fn a_foreign_uav_id_is_ignored_by_the_hub() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("foreign");
    let one = dir.path().join("one.toml");
    let body = |n: u32| {
        let starts: Vec<String> = (0..n).map(|i| format!("[0.0, {}.0]", 2 * i)).collect();
        format!("name = \"n{n}\"\n[swarm]\ncount = {n}\nstart_positions = [{}]\ngoal = [100.0, 0.0]\n[end]\ntime_limit_s = 10.0\n", starts.join(", "))
    };
    std::fs::write(&one, body(1)).expect("write");
    let two = dir.path().join("two.toml");
    std::fs::write(&two, body(2)).expect("write");
    let (mut hub, loc) = start_hub(one.to_str().expect("utf8"), &run, dir.path());
    let mut foreign = Proc::start(
        &["agent", "--run", &run, "--id", "2", "--scenario", two.to_str().expect("utf8"), "--connect", &loc],
        &dir.path().join("foreign.log"),
    );
    let alive =
        tap(&[&format!("swarm/{run}/alive/uav/2"), "--alive", "--connect", &loc, "--count", "1", "--duration", "30"]);
    assert!(alive.contains("true"), "the foreign agent is up: {alive}");
    let out = dir.path().join("rec");
    let mut rec = start_recorder(&run, &loc, &out, dir.path());
    let mut agent =
        Proc::start(&["agent", "--run", &run, "--id", "1", "--connect", &loc], &dir.path().join("agent.log"));
    assert!(rec.wait_for(Duration::from_secs(60)).expect("run ends").success());
    let s = common::summary(&out);
    assert_eq!(s["end_reason"], "time_limit", "{s:#}");
    assert_eq!(s["ticks"], 100);
    assert_eq!(s["agents"].as_array().expect("agents").len(), 1, "no phantom agent: {s:#}");
    assert!(hub.wait_for(Duration::from_secs(20)).expect("hub exits").success(), "hub did not crash");
    assert!(agent.wait_for(Duration::from_secs(20)).expect("agent exits").success());
    assert!(foreign.wait_for(Duration::from_secs(20)).is_some(), "the foreign agent leaves with the hub");
}

/// A run named `uav` (a word of the key space) flies like any other.
#[test]
fn a_run_named_uav_flies() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = common::swarm_run(&["open-field-5", "--run", "uav", "--out", dir.path().to_str().expect("utf8")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s = common::summary(dir.path());
    assert_eq!(s["reached_goal"], true, "{s:#}");
}

/// A hub that vanishes mid-run (SIGKILL: no last step) is noticed by the recorder through the
/// hub's liveliness token: it writes what it has, marked `incomplete`, and exits with failure.
#[test]
fn recorder_notices_a_vanished_hub() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("vanish");
    let sc = dir.path().join("long.toml");
    std::fs::write(
        &sc,
        "name = \"long\"\n[swarm]\ncount = 1\nstart_positions = [[0.0, 0.0]]\ngoal = [100.0, 0.0]\n[time]\nmode = \"realtime\"\n[end]\ntime_limit_s = 1000.0\n",
    )
    .expect("write");
    let (hub, loc) = start_hub(sc.to_str().expect("utf8"), &run, dir.path());
    let out = dir.path().join("rec");
    let mut rec = start_recorder(&run, &loc, &out, dir.path());
    let _agent = Proc::start(&["agent", "--run", &run, "--id", "1", "--connect", &loc], &dir.path().join("agent.log"));
    assert_eq!(
        tap(&[&format!("swarm/{run}/truth/step"), "--connect", &loc, "--count", "3", "--duration", "30"])
            .lines()
            .count(),
        3
    );
    drop(hub); // SIGKILL
    let st = rec.wait_for(Duration::from_secs(20)).expect("the recorder does not hang");
    assert!(!st.success(), "an incomplete run is a failure: {st:?}");
    let s = common::summary(&out);
    assert_eq!(s["end_reason"], "incomplete", "{s:#}");
    assert!(s["ticks"].as_u64().expect("n") >= 3);
}

/// Issue 4: `swarm netem` changes the faults of a running swarm. UAV 3 is isolated mid-flight,
/// then UAV 2 frozen: the hub takes each timeline and republishes the one in force, every agent
/// applies it (UAV 3 loses all its neighbours and hears nothing more), the hub freezes UAV 2
/// (it stops while UAV 1 flies on), and the summary counts the cut messages.
#[test]
fn netem_command_isolates_a_uav_of_a_running_swarm() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("netemcli");
    let sc = dir.path().join("three.toml");
    std::fs::write(
        &sc,
        "name = \"three\"\n[swarm]\ncount = 3\nstart_positions = [[0.0, 0.0], [0.0, 2.0], [0.0, -2.0]]\ngoal = [100.0, 0.0]\n[time]\nmode = \"realtime\"\nrealtime_factor = 4.0\n[end]\ntime_limit_s = 40.0\n",
    )
    .expect("write");
    let (mut hub, loc) = start_hub(sc.to_str().expect("utf8"), &run, dir.path());
    let out = dir.path().join("rec");
    let mut rec = start_recorder(&run, &loc, &out, dir.path());
    let _agents: Vec<Proc> = (1..=3)
        .map(|id| {
            Proc::start(
                &["agent", "--run", &run, "--id", &id.to_string(), "--connect", &loc],
                &dir.path().join(format!("a{id}.log")),
            )
        })
        .collect();
    assert_eq!(
        tap(&[&format!("swarm/{run}/clock"), "--connect", &loc, "--count", "20", "--duration", "60"]).lines().count(),
        20
    );
    let o = output_within(
        Command::new(SWARM).args(["netem", "--run", &run, "--connect", &loc, "isolate", "3"]),
        TOOL_LIMIT,
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(said.contains("\"scheme\":\"isolate\""), "{said}");
    assert!(said.starts_with("applied from sim t = "), "the hub's sim time, in words: {said}");
    let o =
        output_within(Command::new(SWARM).args(["netem", "--run", &run, "--connect", &loc, "freeze", "2"]), TOOL_LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o =
        output_within(Command::new(SWARM).args(["netem", "--run", &run, "--connect", &loc, "freeze", "9"]), TOOL_LIMIT);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && said.contains("the hub refused the change:"),
        "UAV 9 does not exist, and netem says so: {said}"
    );
    assert!(rec.wait_for(Duration::from_secs(60)).expect("the run ends").success());
    assert!(hub.wait_for(Duration::from_secs(20)).is_some());
    let hub_log = std::fs::read_to_string(dir.path().join("hub.log")).expect("log");
    assert_eq!(hub_log.matches("netem timeline added").count(), 2, "isolate and freeze: {hub_log}");
    assert_eq!(hub_log.matches("netem timeline refused").count(), 1, "UAV 9 does not exist: {hub_log}");
    let s = common::summary(&out);
    let uav3 = &s["agents"][2];
    let lost = uav3["contact_events"].as_array().expect("events").iter().any(|e| e["regained"] == false);
    assert!(lost, "UAV 3 lost its neighbours once isolated: {uav3:#}");
    let (rx, delivered) =
        (uav3["messages_received"].as_u64().expect("n"), uav3["messages_delivered"].as_u64().expect("n"));
    assert!(delivered < rx / 2, "most of what reached UAV 3 after the cut was dropped: {uav3:#}");
    let (p1, p2) =
        (s["agents"][0]["path_length_m"].as_f64().expect("n"), s["agents"][1]["path_length_m"].as_f64().expect("n"));
    assert!(p2 < 0.8 * p1, "UAV 2 stopped when frozen, UAV 1 flew on: {p2} vs {p1}");
    let cut = &s["network"][2];
    assert_eq!(cut["class"], "cut");
    assert!(cut["dropped"].as_u64().expect("n") > 50 && cut["delivered"] == 0, "{cut:#}");
}

#[test]
fn a_uav_starting_inside_a_tree_is_refused_before_anything_starts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let forest5 =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenarios/forest-5.toml")).expect("forest-5");
    // An explicit trunk on UAV 2's start, and a dense forest drawn over the whole start area.
    let listed = forest5.replace("[world.forest]", "[[world.trees]]\nx = 0.1\ny = 2.0\nr = 0.3\n\n[world.forest]");
    let drawn = forest5
        .replace("x_min = 3.0", "x_min = -4.0")
        .replace("density_per_100m2 = 5.0", "density_per_100m2 = 40.0")
        .replace("min_spacing_m = 2.5", "min_spacing_m = 0.8")
        .replace("keep_clear = [{ x = 0.0, y = 0.0, r = 4.0 }, ", "keep_clear = [");
    for (name, text, said) in [
        ("listed", listed, "UAV 2 starts at (0.00, 2.00), -0.20 m from the tree at (0.10, 2.00)"),
        ("drawn", drawn, "starts at ("),
    ] {
        let file = dir.path().join(format!("{name}.toml"));
        std::fs::write(&file, text).expect("write scenario");
        let file = file.to_str().expect("utf-8 path");
        let out = output_within(Command::new(SWARM).args(["check", file]), TOOL_LIMIT);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name}: swarm check refuses it");
        assert!(
            err.contains("swarm.start_positions: UAV") && err.contains(said) && err.contains("world.forest.keep_clear"),
            "{name}: {err}"
        );
        let run_dir = dir.path().join(format!("{name}-run"));
        let out = output_within(
            Command::new(SWARM).args(["run", file, "--out", run_dir.to_str().expect("utf-8")]),
            TOOL_LIMIT,
        );
        assert!(
            !out.status.success() && String::from_utf8_lossy(&out.stderr).contains(said),
            "{name}: swarm run refuses it"
        );
        assert!(!run_dir.exists(), "{name}: nothing was started or written");
    }
}
