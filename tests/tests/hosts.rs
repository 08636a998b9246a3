//! End to end: agent hosts (`swarm agent --ids`, many agents in one process). Lockstep results
//! must not depend on how the agents are spread over processes; a host takes its UAVs' sensor
//! frames in one message a tick on its own key, which only its login may read, and in lockstep
//! puts their commands and states in one message each; a killed host
//! takes exactly its agents down and the swarm flies on; a bad id in a host is reported by id.

mod common;

use common::{
    alive_changes, output_within, run_id, start_hub, start_recorder, start_secure_hub, summary, swarm_run, tap,
    tap_listening, Creds, Proc, SWARM, TOOL_LIMIT,
};
use std::process::Command;
use std::time::{Duration, Instant};

/// forest-5 (ICP shares) in lockstep with one process per UAV, hosts of 2 (shares both inside a
/// session and across sessions) and one host of all 5: the same trajectories, byte for byte, and
/// the same localization figures from the agents' states.
#[test]
fn lockstep_trajectories_do_not_depend_on_agents_per_process() {
    let mut runs = Vec::new();
    for per in ["1", "2", "5"] {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = swarm_run(&[
            "forest-5",
            "--agents-per-process",
            per,
            "--out",
            dir.path().to_str().expect("utf8"),
            "--run",
            &run_id("per"),
        ]);
        assert!(out.status.success(), "--agents-per-process {per}: {}", String::from_utf8_lossy(&out.stderr));
        let logs: Vec<String> = std::fs::read_dir(dir.path().join("logs"))
            .expect("logs")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        let hosts = logs.iter().filter(|l| l.starts_with("agents-")).count();
        assert_eq!(hosts, [0, 2, 1][runs.len()], "agent hosts started with --agents-per-process {per}: {logs:?}");
        let s = summary(dir.path());
        assert_eq!(s["reached_goal"], true, "{s:#}");
        runs.push((std::fs::read(dir.path().join("trajectories.csv")).expect("csv"), s["localization"].clone()));
    }
    assert!(runs[0].0.len() > 1000);
    assert!(runs[0].0 == runs[1].0, "hosts of 2 fly differently from one process per UAV");
    assert!(runs[0].0 == runs[2].0, "one host of 5 flies differently from one process per UAV");
    // The hosts' states come in one message a tick: the recorder scores every estimate of them.
    assert!(runs[0].1["estimates_scored"].as_u64().is_some_and(|n| n > 1000), "{:#}", runs[0].1);
    for (per, (_, l)) in ["2", "5"].iter().zip(&runs[1..]) {
        assert_eq!(l, &runs[0].1, "hosts of {per}: the recorder scored other estimates");
    }
}

/// Five UAVs in a row, in realtime at 2x for 120 s of sim time, so the taps below find it flying.
const FIVE: &str = "name = \"five\"\n[swarm]\ncount = 5\nstart_positions = [[0.0, 0.0], [0.0, 2.0], [0.0, -2.0], [0.0, 4.0], [0.0, -4.0]]\ngoal = [100.0, 0.0]\n[time]\nmode = \"realtime\"\nrealtime_factor = 2.0\n[end]\ntime_limit_s = 120.0\n";

/// A secured hub flying a scenario of five UAVs, with the logins of a host of UAVs 1-4
/// (`uavs1-4`), of UAV 5 (`uav5`) and of an observer.
struct HostAndOne {
    dir: tempfile::TempDir,
    run: String,
    loc: String,
    creds: Creds,
    _hub: Proc,
}

impl HostAndOne {
    /// Starts the hub on `scenario` (TOML text) for a run named after `name`.
    fn start(name: &str, scenario: &str) -> HostAndOne {
        let dir = tempfile::tempdir().expect("tempdir");
        let run = run_id(name);
        let sc = dir.path().join("five.toml");
        std::fs::write(&sc, scenario).expect("scenario");
        let creds = Creds::make_with(dir.path(), 5, &["uavs1-4"]);
        let (hub, loc) = start_secure_hub(sc.to_str().expect("utf8"), &run, dir.path(), &creds);
        HostAndOne { dir, run, loc, creds, _hub: hub }
    }

    /// `swarm tap` as the observer of the first `count` messages on `swarm/{run}/*/*/{leaf}`,
    /// listening when this returns.
    fn tap_every(&self, leaf: &str, count: usize) -> common::Listening {
        let mut a = vec![format!("swarm/{}/*/*/{leaf}", self.run), "--connect".into(), self.loc.clone()];
        a.extend(["--count".into(), count.to_string(), "--duration".into(), "60".into()]);
        a.extend(self.creds.login("observer"));
        tap_listening(&a.iter().map(String::as_str).collect::<Vec<_>>())
    }

    /// The `count` messages a [`HostAndOne::tap_every`] printed, as JSON.
    fn tapped(tap: common::Listening, count: usize) -> Vec<serde_json::Value> {
        let lines: Vec<serde_json::Value> =
            tap.output().lines().map(|l| serde_json::from_str(l).expect("tap json")).collect();
        assert_eq!(lines.len(), count, "{lines:?}");
        lines
    }

    /// The host of UAVs 1-4 and UAV 5's agent alone, each logged in as itself.
    fn fly(&self) -> [Proc; 2] {
        let agent = |flag: &str, ids: &str, user: &str| {
            let mut a = vec!["agent".to_string(), "--run".into(), self.run.clone(), flag.into(), ids.into()];
            a.extend(["--connect".into(), self.loc.clone()]);
            a.extend(self.creds.login(user));
            Proc::start(&a.iter().map(String::as_str).collect::<Vec<_>>(), &self.dir.path().join(format!("{user}.log")))
        };
        [agent("--ids", "1-4", "uavs1-4"), agent("--id", "5", "uav5")]
    }
}

/// A secured hub, UAVs 1-4 in a host logged in as `uavs1-4` and UAV 5 alone as `uav5`: the hub
/// sends the host its four frames in one `Senses` message a tick on `host/1-4/sense`, each with
/// its UAV's id, and UAV 5's alone, and no frame of 1-4 alone. Only the host's login may read its
/// key, and not every host's.
#[test]
fn an_agent_host_gets_its_uavs_frames_in_one_message_only_it_may_read() {
    let f = HostAndOne::start("hostframes", FIVE);
    let (run, loc) = (&f.run, &f.loc);
    let login = |user: &str| f.creds.login(user);
    let frames = f.tap_every("sense", 12);
    let _agents = f.fly();
    let lines = HostAndOne::tapped(frames, 12);
    let (mut batched, mut alone) = (0, 0);
    for v in &lines {
        let key = v["key"].as_str().expect("key");
        if key == format!("swarm/{run}/host/1-4/sense") {
            assert_eq!(v["kind"], "senses", "{v}");
            let frames = v["msg"]["Senses"].as_array().expect("frames");
            let ids: Vec<u64> = frames.iter().map(|f| f["id"].as_u64().expect("id")).collect();
            assert_eq!(ids, [1, 2, 3, 4], "the host's four frames, in id order: {v}");
            let own: Vec<u64> = frames.iter().map(|f| f["frame"]["radio"]["id"].as_u64().expect("id")).collect();
            assert_eq!(own, ids, "each frame is its UAV's");
            let ticks: Vec<&serde_json::Value> = frames.iter().map(|f| &f["frame"]["scan"]["tick"]).collect();
            assert!(ticks.iter().all(|t| *t == ticks[0]), "one tick's frames: {ticks:?}");
            batched += 1;
        } else {
            assert_eq!(key, format!("swarm/{run}/uav/5/sense"), "no frame of the host's UAVs alone: {v}");
            assert_eq!(v["kind"], "sense");
            alone += 1;
        }
    }
    assert!(batched >= 5 && alone >= 5, "a message a tick each: {batched} to the host, {alone} to UAV 5");

    let tap_as = |user: &str, key: &str, args: &[&str]| {
        let o = output_within(
            Command::new(SWARM)
                .args(["tap", &format!("swarm/{run}/{key}"), "--connect", loc])
                .args(login(user))
                .args(args),
            TOOL_LIMIT,
        );
        assert!(o.status.success(), "tap {key} as {user}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8(o.stdout).expect("utf8").lines().count()
    };
    assert_eq!(tap_as("uavs1-4", "host/1-4/sense", &["--count", "2", "--duration", "30"]), 2, "the host's own key");
    assert_eq!(tap_as("uav5", "host/1-4/sense", &["--duration", "3"]), 0, "UAV 5 may not read the host's frames");
    assert_eq!(tap_as("uavs1-4", "host/*/sense", &["--duration", "3"]), 0, "nor the host every host's");
}

/// [`FIVE`] in lockstep, long enough (3000 s of sim time) that `swarm keys` finds it flying.
fn five_lockstep() -> String {
    FIVE.replace("mode = \"realtime\"\nrealtime_factor = 2.0\n", "mode = \"lockstep\"\n")
        .replace("time_limit_s = 120.0", "time_limit_s = 3000.0")
}

/// The UAV ids of an agent host's message as `swarm tap` prints it (`Cmds` or `States`, each
/// item naming its UAV), sorted.
fn ids_in(v: &serde_json::Value, variant: &str) -> Vec<u64> {
    let mut ids: Vec<u64> =
        v["msg"][variant].as_array().expect("a list").iter().map(|x| x["id"].as_u64().expect("id")).collect();
    ids.sort_unstable();
    ids
}

/// In lockstep, a secured hub, UAVs 1-4 in a host logged in as `uavs1-4` and UAV 5 alone as
/// `uav5`: the host puts its four commands of a tick as one `Cmds` message on `host/1-4/cmd` and
/// their states as one `States` message on `host/1-4/state`, UAV 5 its own alone, and no
/// command or state of 1-4 goes alone; `swarm keys` shows the host's families.
#[test]
fn in_lockstep_an_agent_host_puts_its_commands_and_states_in_one_message_each() {
    let f = HostAndOne::start("hostcmds", &five_lockstep());
    let (run, loc) = (&f.run, &f.loc);
    let login = |user: &str| f.creds.login(user);
    let (cmds, states) = (f.tap_every("cmd", 20), f.tap_every("state", 20));
    let _agents = f.fly();
    for (tapped, leaf, variant, one) in [(cmds, "cmd", "Cmds", "Cmd"), (states, "state", "States", "State")] {
        let lines = HostAndOne::tapped(tapped, 20);
        let (mut batched, mut alone) = (0, 0);
        for v in &lines {
            let key = v["key"].as_str().expect("key");
            if key == format!("swarm/{run}/host/1-4/{leaf}") {
                assert_eq!(ids_in(v, variant), [1, 2, 3, 4], "the host's four, once each: {v}");
                batched += 1;
            } else {
                assert!(key.starts_with(&format!("swarm/{run}/uav/5/")), "none of the host's UAVs alone: {v}");
                assert!(v["msg"][one].is_object(), "{v}");
                alone += 1;
            }
        }
        assert!(
            batched >= 8 && alone >= 8,
            "{variant}: a message a tick each, {batched} from the host, {alone} from UAV 5"
        );
    }
    // `swarm keys` shows the host's keys as families of their own, with the hub reading its
    // commands (its subscription to every host's, `host/*/cmd`, in the same family).
    let o = output_within(
        Command::new(SWARM)
            .args(["keys", "--run", run, "--connect", loc, "--json", "--window", "1"])
            .args(login("observer")),
        TOOL_LIMIT,
    );
    assert!(o.status.success(), "swarm keys: {}", String::from_utf8_lossy(&o.stderr));
    let k: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let family = |name: &str| k["families"].as_array().expect("families").iter().find(|r| r["family"] == name).cloned();
    let cmds = family("host/{ids}/cmd").expect("the hosts' commands");
    assert_eq!(
        (&cmds["publishers"], &cmds["subscribers"]),
        (&serde_json::json!(["uavs1-4"]), &serde_json::json!(["hub"])),
        "{cmds}"
    );
    assert!(cmds["msgs_per_s"].as_f64().expect("a rate") > 5.0, "{cmds}");
    let states = family("host/{ids}/state").expect("the hosts' states");
    assert_eq!(states["publishers"], serde_json::json!(["uavs1-4"]), "{states}");
    assert!(family("host/{id}/cmd").is_none(), "one family for a host's commands: {k}");
}

/// Sends `signal` (`STOP`, `CONT`, `KILL`) to a child.
fn signal(p: &Proc, signal: &str) {
    let st = Command::new("kill").args([&format!("-{signal}"), &p.child.id().to_string()]).status().expect("kill");
    assert!(st.success(), "kill -{signal}");
}

/// open-field-5 in lockstep, UAVs 1-3 (the informed ones among them) in processes of their own
/// and 4-5 in one host, which is killed outright mid-run. To act at a tick the run has surely
/// not finished, agent 1 is stopped (SIGSTOP) first, which holds the lockstep hub. Both agents
/// of the host disappear, the hub stops waiting for them, and the other three fly on; a new host
/// for 4-5 brings them back, localizing their neighbours again, and the swarm reaches the goal.
#[cfg(target_os = "linux")]
#[test]
fn a_killed_agent_host_takes_its_agents_down_and_a_new_one_brings_them_back() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("hostkill");
    let (mut hub, loc) = start_hub("open-field-5", &run, dir.path());
    let out = dir.path().join("rec");
    let mut rec = start_recorder(&run, &loc, &out, dir.path());
    let agent = |flag: &str, ids: &str, log: &str| {
        Proc::start(&["agent", "--run", &run, flag, ids, "--connect", &loc, "--exit-with-stdin"], &dir.path().join(log))
    };
    let solo: Vec<Proc> = (1..=3).map(|id| agent("--id", &id.to_string(), &format!("agent-{id}.log"))).collect();
    let mut host = agent("--ids", "4-5", "host.log");
    let ticks = |n: &str| {
        let got = tap(&[&format!("swarm/{run}/truth/step"), "--connect", &loc, "--count", n, "--duration", "60"]);
        assert_eq!(got.lines().count().to_string(), n, "the swarm flies: {got}");
    };
    // Wait until the swarm flies, then hold the hub by stopping agent 1, and kill the host.
    ticks("20");
    signal(&solo[0], "STOP");
    std::thread::sleep(Duration::from_millis(300));
    signal(&host, "KILL");
    assert!(host.wait_for(Duration::from_secs(10)).is_some(), "the killed host is gone");
    std::thread::sleep(Duration::from_millis(500));
    signal(&solo[0], "CONT");
    // The swarm flies on without them; then, holding the hub again, a new host takes them back.
    ticks("30");
    signal(&solo[0], "STOP");
    let _host_again = agent("--ids", "4-5", "host-again.log");
    for id in ["4", "5"] {
        let up = tap(&[
            &format!("swarm/{run}/alive/uav/{id}"),
            "--alive",
            "--connect",
            &loc,
            "--count",
            "1",
            "--duration",
            "30",
        ]);
        assert!(up.contains("\"alive\":true"), "UAV {id} is back: {up}");
    }
    signal(&solo[0], "CONT");

    let status = rec.wait_for(Duration::from_secs(120)).expect("the run ends without the host's agents");
    assert!(status.success());
    let s = summary(&out);
    assert_eq!(s["reached_goal"], true, "{s:#}");
    // The dead UAVs' bodies stay in the world with no agent to share their poses, so a living
    // UAV may touch one; the living ones must never touch each other.
    let events = s["collision_events"].as_array().expect("events");
    let alive_only =
        |e: &serde_json::Value| [&e["id"], &e["other_uav"]].iter().all(|v| v.as_u64().is_some_and(|id| id <= 3));
    assert!(!events.iter().any(alive_only), "living UAVs collided: {events:?}");
    for id in ["4", "5"] {
        let a = alive_changes(&out, id);
        assert_eq!(a.len(), 3, "UAV {id}: alive, dead with its host, alive with the new one: {a:?}");
        assert!(a[0].1 && !a[1].1 && a[2].1 && a[1].0 > 0.0, "UAV {id}: {a:?}");
    }
    let back_at = alive_changes(&out, "4")[2].0;
    let events = s["agents"][3]["contact_events"].as_array().expect("events");
    let regained = events.iter().any(|e| e["regained"] == true && e["t_s"].as_f64().expect("t") >= back_at);
    assert!(regained, "UAV 4 of the new host localized its neighbours: {events:?}");
    for id in ["1", "2", "3"] {
        let a = alive_changes(&out, id);
        assert!(a.len() == 1 && a[0].1, "UAV {id} in its own process lives on: {a:?}");
    }
    assert!(hub.wait_for(Duration::from_secs(20)).expect("hub exits after the run").success());
}

/// A host given an id outside the scenario flies the others, reports the bad one by id in its
/// log at once, and fails naming it when it stops.
#[test]
fn a_host_reports_an_agent_with_a_bad_id() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = run_id("hostbadid");
    let (_hub, loc) = start_hub("forest-5", &run, dir.path());
    let log = dir.path().join("host.log");
    let mut host = Proc::start(&["agent", "--run", &run, "--ids", "5-6", "--connect", &loc, "--exit-with-stdin"], &log);
    let alive =
        tap(&[&format!("swarm/{run}/alive/uav/5"), "--alive", "--connect", &loc, "--count", "1", "--duration", "30"]);
    assert!(alive.contains("\"alive\":true"), "UAV 5 of the host flies: {alive}");
    let deadline = Instant::now() + Duration::from_secs(30);
    while !std::fs::read_to_string(&log).expect("log").contains("UAV id 6 is not in this scenario") {
        assert!(Instant::now() < deadline, "the bad id is never reported");
        std::thread::sleep(Duration::from_millis(100));
    }
    drop(host.stdin.take());
    let st = host.wait_for(Duration::from_secs(20)).expect("host stops when told");
    assert!(!st.success(), "a host with a failed agent fails");
    let text = std::fs::read_to_string(&log).expect("log");
    assert!(text.contains("1 of the 2 agents of this host failed") && text.contains("UAV 6:"), "{text}");
}
