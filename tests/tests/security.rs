//! Issue 13, item 1: only what is theirs. A hub started with `--users` lets in only those users
//! and its router enforces each role's rules: an agent reads its own sensors but never ground
//! truth, and its put on another UAV's command key never reaches the hub; an observer reads
//! everything and publishes nothing; an operator may also change the netem timeline; a session
//! without credentials (or with a wrong password) is refused. Checked with our own Rust clients
//! (`swarm tap`, `put`, `netem` logged in as each role) and with a client no one here wrote
//! (Python `eclipse-zenoh` 1.10 from PyPI, `security/client.py`).
//!
//! The hub's log line `hub done` carries its counts: `malformed_cmds` (payloads that are not a
//! command) and `ignored_cmds` (well-formed commands for a UAV outside the scenario or for a tick
//! not yet opened). A refused put leaves both untouched; an allowed one on the sender's own key
//! moves them, so each test also shows that the path it says is closed would have been counted.

mod common;

use common::{output_within, run_id, start_secure_hub, Creds, Proc, SWARM, TOOL_LIMIT};
use std::process::Command;
use std::time::Duration;

/// Three UAVs in realtime at 2x for 120 s of sim time: 60 s of wall time in which the checks tap
/// the live run.
const THREE: &str = "name = \"three\"\n[swarm]\ncount = 3\nstart_positions = [[0.0, 0.0], [0.0, 2.0], [0.0, -2.0]]\ngoal = [100.0, 0.0]\n[time]\nmode = \"realtime\"\nrealtime_factor = 2.0\n[end]\ntime_limit_s = 120.0\n";

/// A secured hub flying [`THREE`], its recorder (as `observer`) and agents (each as its own
/// `uav{id}`).
struct Flight {
    dir: tempfile::TempDir,
    run: String,
    loc: String,
    creds: Creds,
    hub: Proc,
    rec: Proc,
    _agents: Vec<Proc>,
}

impl Flight {
    fn start(tag: &str) -> Flight {
        let dir = tempfile::tempdir().expect("tempdir");
        let run = run_id(tag);
        let sc = dir.path().join("three.toml");
        std::fs::write(&sc, THREE).expect("scenario");
        let creds = Creds::make_with(dir.path(), 3, &["ext3", "ros", "bridge"]);
        let (hub, loc) = start_secure_hub(sc.to_str().expect("utf8"), &run, dir.path(), &creds);
        let out = dir.path().join("rec");
        let mut args =
            vec!["record".to_string(), "--run".into(), run.clone(), "--out".into(), out.to_str().expect("utf8").into()];
        args.extend(["--connect".into(), loc.clone()]);
        args.extend(creds.login("observer"));
        let rec = Proc::start(&args.iter().map(String::as_str).collect::<Vec<_>>(), &dir.path().join("rec.log"));
        let agents = (1..=3)
            .map(|id| {
                let mut a = vec![
                    "agent".to_string(),
                    "--run".into(),
                    run.clone(),
                    "--id".into(),
                    id.to_string(),
                    "--connect".into(),
                    loc.clone(),
                ];
                a.extend(creds.login(&format!("uav{id}")));
                Proc::start(&a.iter().map(String::as_str).collect::<Vec<_>>(), &dir.path().join(format!("a{id}.log")))
            })
            .collect();
        let f = Flight { dir, run, loc, creds, hub, rec, _agents: agents };
        let clock = f.tap_as("observer", "clock", &["--count", "5", "--duration", "60"]);
        assert_eq!(clock.lines().count(), 5, "the run flies with every piece logged in");
        f
    }

    /// Runs `swarm <cmd> --connect LOC <args>` logged in as `user` (none: no credentials).
    fn as_user(&self, user: Option<&str>, cmd: &str, args: &[&str]) -> std::process::Output {
        let login = user.map(|u| self.creds.login(u)).unwrap_or_default();
        output_within(Command::new(SWARM).arg(cmd).args(["--connect", &self.loc]).args(login).args(args), TOOL_LIMIT)
    }

    /// `swarm tap swarm/{run}/{key} ARGS` as `user`; fails the test if the tap fails.
    fn tap_as(&self, user: &str, key: &str, args: &[&str]) -> String {
        let o = self.as_user(Some(user), "tap", &[&[format!("swarm/{}/{key}", self.run).as_str()], args].concat());
        assert!(o.status.success(), "tap {key} as {user}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8(o.stdout).expect("utf8")
    }

    /// `swarm put swarm/{run}/{key} ARGS` as `user`; the put itself succeeds (the router drops
    /// what the user may not send without telling it).
    fn put_as(&self, user: &str, key: &str, args: &[&str]) {
        let o = self.as_user(Some(user), "put", &[&[format!("swarm/{}/{key}", self.run).as_str()], args].concat());
        assert!(o.status.success(), "put {key} as {user}: {}", String::from_utf8_lossy(&o.stderr));
    }

    /// Waits for the run's end and returns the hub's log.
    fn finish(self) -> String {
        self.finish_recorded().hub_log
    }

    /// Waits for the run's end and returns the hub's and the recorder's logs and the recorder's
    /// `agent_states.csv`.
    fn finish_recorded(mut self) -> Ended {
        assert!(self.rec.wait_for(Duration::from_secs(180)).expect("the run ends").success(), "recorder");
        assert!(self.hub.wait_for(Duration::from_secs(30)).expect("hub exits").success(), "hub");
        let read = |name: &str| std::fs::read_to_string(self.dir.path().join(name)).expect(name);
        let hub_log = read("hub.log");
        assert!(hub_log.contains("hub done"), "{hub_log}");
        Ended { hub_log, rec_log: read("rec.log"), agent_states: read("rec/agent_states.csv") }
    }
}

/// What a [`Flight`] leaves.
struct Ended {
    hub_log: String,
    rec_log: String,
    agent_states: String,
}

/// A well-formed velocity command for a tick the hub will not open for a long time: the hub
/// counts it in `ignored_cmds` if it ever arrives.
const FUTURE_CMD: &str = r#"{"Cmd": {"tick": 1000000000, "kind": "Velocity", "x": -1.0, "y": 0.0, "yaw_rate": 0.0}}"#;
/// An agent host's message with UAV 3's command of that tick and one for UAV 2.
const FUTURE_HOST_CMDS: &str = r#"{"Cmds": [
    {"id": 3, "cmd": {"tick": 1000000000, "kind": "Velocity", "x": -1.0, "y": 0.0, "yaw_rate": 0.0}},
    {"id": 2, "cmd": {"tick": 1000000000, "kind": "Hover", "x": 0.0, "y": 0.0, "yaw_rate": 0.0}}]}"#;

#[test]
fn each_role_touches_only_what_is_its_own_with_rust_clients() {
    let f = Flight::start("sec-rust");
    // No credentials, or a wrong password: the session is refused (quickly, with a short connect
    // timeout instead of our clients' default wait for a hub that is not up yet).
    let quick = ["--count", "1", "--duration", "5", "--cfg", "connect/timeout_ms:2000"];
    let key = format!("swarm/{}/clock", f.run);
    let anonymous = f.as_user(None, "tap", &[&[key.as_str()], &quick[..]].concat());
    assert!(
        !anonymous.status.success(),
        "a session without credentials is refused: {}",
        String::from_utf8_lossy(&anonymous.stdout)
    );
    let said = String::from_utf8_lossy(&anonymous.stderr);
    assert!(
        said.contains(&format!("error: the hub at {} refused this session: it wants a login", f.loc))
            && said.contains("--user observer --password-file <run folder>/credentials/observer.password"),
        "a refused tool says what to do: {said}"
    );
    let wrong = output_within(
        Command::new(SWARM)
            .args(["tap", &key, "--connect", &f.loc, "--user", "uav3", "--password-file"])
            .arg(f.creds.0.join("uav2.password"))
            .args(quick),
        TOOL_LIMIT,
    );
    assert!(!wrong.status.success(), "UAV 3 with UAV 2's password is refused");
    let said = String::from_utf8_lossy(&wrong.stderr);
    assert!(said.contains("refused to let \"uav3\" in: the user or its password is not this run's"), "{said}");

    // Agent: its own sensors, never truth, nor another UAV's sensors. A subscription broader
    // than its keys (`swarm/{run}/**`) is refused whole by the router: it receives nothing.
    assert_eq!(f.tap_as("uav3", "uav/3/sense", &["--count", "3", "--duration", "30"]).lines().count(), 3);
    assert_eq!(
        f.tap_as("uav3", "uav/2/sense", &["--duration", "3"]).lines().count(),
        0,
        "UAV 2's sensors are not UAV 3's"
    );
    assert_eq!(
        f.tap_as("uav3", "**", &["--duration", "3"]).lines().count(),
        0,
        "a subscription to everything is refused"
    );
    // The router forwards every agent's sensor data under one wildcard rule (node/src/auth.rs):
    // what keeps UAV 2's sensors from UAV 3 is that a subscription broader than UAV 3's own keys
    // is refused.
    assert_eq!(
        f.tap_as("uav3", "uav/*/sense", &["--duration", "3"]).lines().count(),
        0,
        "a subscription to every UAV's sensors is refused"
    );
    assert_eq!(f.tap_as("uav3", "truth/**", &["--duration", "3"]).lines().count(), 0, "UAV 3 reads no truth");
    // Observer: everything, truth included.
    assert_eq!(
        f.tap_as("observer", "truth/step", &["--count", "3", "--duration", "30"]).lines().count(),
        3,
        "truth was flowing"
    );
    assert!(f.tap_as("observer", "uav/2/sense", &["--count", "1", "--duration", "30"]).contains("Sense"));

    // UAV 3's puts on UAV 2's command key (garbage, and a command) are refused by the router;
    // the same on its own key reaches the hub (the counts below show both).
    f.put_as("uav3", "uav/2/cmd", &["--hex", "05 02"]);
    f.put_as("uav3", "uav/2/cmd", &["--json", FUTURE_CMD]);
    f.put_as("uav3", "uav/3/cmd", &["--json", FUTURE_CMD]);
    // Commands in one message on a host key: refused on a key that names another UAV; on its own
    // host key it reaches the hub, which takes only the UAVs the key names (UAV 2's is ignored).
    f.put_as("uav3", "host/2-3/cmd", &["--json", FUTURE_HOST_CMDS]);
    f.put_as("uav3", "host/3/cmd", &["--json", FUTURE_HOST_CMDS]);
    // A state counts only on a key that names its UAV: UAV 2's state, put again by UAV 3 on its
    // own key and in a host message on its own host key, reaches the recorder, which counts
    // both and records neither (the run's own copy of that state is recorded once).
    let tapped = f.tap_as("observer", "uav/2/state", &["--count", "1", "--duration", "30"]);
    let tapped: serde_json::Value = serde_json::from_str(tapped.trim()).expect("a state as JSON");
    let state = &tapped["msg"]["State"];
    let tick = state["tick"].as_u64().expect("a state's tick");
    f.put_as("uav3", "uav/3/state", &["--json", &serde_json::json!({ "State": state }).to_string()]);
    f.put_as("uav3", "host/3/state", &["--json", &serde_json::json!({ "States": [state] }).to_string()]);
    // An external controller, the ROS 2 bridge and a ROS machine read none of the run's data
    // keys but their own, and none of them may command a UAV through the hub's key.
    assert_eq!(f.tap_as("ext3", "clock", &["--duration", "3"]).lines().count(), 0, "ext3 reads only its view");
    assert_eq!(f.tap_as("ext3", "uav/3/sense", &["--duration", "3"]).lines().count(), 0, "ext3 reads no sensor");
    assert_eq!(f.tap_as("ros", "clock", &["--duration", "3"]).lines().count(), 0, "ros reads nothing of the run");
    assert_eq!(
        f.tap_as("bridge", "clock", &["--count", "1", "--duration", "30"]).lines().count(),
        1,
        "the bridge reads as an observer"
    );
    for user in ["ext3", "ros", "bridge"] {
        f.put_as(user, "uav/3/cmd", &["--json", FUTURE_CMD]);
        let o = f.as_user(Some(user), "netem", &["--run", &f.run, "--wait", "2", "freeze", "2"]);
        let said = String::from_utf8_lossy(&o.stderr);
        assert!(
            !o.status.success() && said.contains("no answer from the hub of run"),
            "{user}: the router drops it, and netem says so: {said}"
        );
    }
    // An observer publishes nothing: neither a command nor a netem timeline.
    f.put_as("observer", "uav/1/cmd", &["--hex", "05 02"]);
    let o = f.as_user(Some("observer"), "netem", &["--run", &f.run, "--wait", "2", "freeze", "2"]);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "the router drops it, and netem says so: {said}");
    assert!(said.contains("the change was not applied") && said.contains("--user operator"), "{said}");
    // An operator may change the netem timeline.
    let o = f.as_user(Some("operator"), "netem", &["--run", &f.run, "freeze", "1"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let ended = f.finish_recorded();
    let log = ended.hub_log;
    assert!(log.contains("malformed_cmds=0"), "no garbage reached the hub: {log}");
    assert!(
        log.contains("ignored_cmds=3"),
        "only UAV 3's command on its own key and its host message on its own host key reached the hub: {log}"
    );
    assert_eq!(log.matches("netem timeline added").count(), 1, "the operator's freeze only: {log}");
    assert!(
        ended.rec_log.contains("recorder dropped states whose key does not name their UAV unnamed=2"),
        "both of UAV 3's copies of UAV 2's state were dropped: {}",
        ended.rec_log
    );
    let recorded = |id: &str| {
        ended
            .agent_states
            .lines()
            .filter(|l| l.split(',').nth(2) == Some(id) && l.starts_with(&format!("{tick},")))
            .count()
    };
    assert_eq!(recorded("2"), 1, "UAV 2's state of tick {tick}, its own copy only");
}

#[test]
fn a_python_client_no_one_here_wrote_is_held_to_its_role() {
    let f = Flight::start("sec-py");
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/security/client.py");
    let o = output_within(
        Command::new(common::python()).arg(script).args([&f.loc, &f.run, &f.creds.password("uav3"), "5"]),
        TOOL_LIMIT,
    );
    assert!(o.status.success(), "client.py: {}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("one JSON line");
    assert_eq!(v["refused"], true, "no credentials: refused: {v}");
    assert_eq!(v["wrong_password_refused"], true, "{v}");
    assert!(v["frames"].as_u64().expect("n") > 0, "UAV 3 receives its sensor frames: {v}");
    assert_eq!(v["truth"], 0, "and nothing on truth/**: {v}");
    // Its subscription to `swarm/{run}/**` is refused by the router; the session still hands it
    // what reaches the session for its other subscriptions, and its own puts.
    let keys: Vec<&str> = v["keys"].as_array().expect("keys").iter().filter_map(|k| k.as_str()).collect();
    assert!(keys.iter().all(|k| !k.contains("/truth/") && !k.contains("/uav/2/sense")), "{keys:?}");
    let log = f.finish();
    assert!(log.contains("malformed_cmds=1"), "its garbage on uav/3/cmd arrived, on uav/2/cmd it did not: {log}");
    assert!(
        !log.contains("liveliness token of a UAV not in this scenario"),
        "its token for UAV 9 never reached the hub: {log}"
    );
}
