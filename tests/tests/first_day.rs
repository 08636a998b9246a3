//! A researcher's first day: the small ways a first session went wrong, each held to its exit
//! status and its message.
//!
//! - A tool with no login, or a wrong one, against a hub that wants one is told so, in bounded
//!   time; an endpoint where nothing listens is told apart.
//! - A tap that gets nothing says the router may have refused it (its role).
//! - `swarm run | head -c 10` ends without a panic.
//! - A SIGINT to `swarm run` alone ends the run `stopped`, as one to its process group does.
//! - `swarm check` says what overlapping and missing partition groups do.

mod common;

use common::{output_within, run_id, Creds, SWARM, TOOL_LIMIT};
use std::io::Read;
use std::process::{Command, Stdio};
use std::time::Duration;

#[test]
fn a_tool_without_the_runs_login_is_told_so_and_an_empty_tap_says_why() {
    let dir = tempfile::tempdir().expect("tempdir");
    let creds = Creds::make(dir.path(), 5);
    let run = run_id("login");
    let scenario = common::forest5_cut(dir.path(), 120.0);
    let (_hub, loc) = common::start_secure_hub(&scenario, &run, dir.path(), &creds);
    let clock = format!("swarm/{run}/clock");
    let tap = |login: &[String]| {
        output_within(
            Command::new(SWARM).args(["tap", &clock, "--connect", &loc, "--duration", "2"]).args(login),
            TOOL_LIMIT,
        )
    };

    let o = tap(&[]);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && said.contains("refused this session: it wants a login"), "no login: {said}");
    let wrong = dir.path().join("wrong.password");
    std::fs::write(&wrong, "not-this-runs\n").expect("write");
    let o = tap(&["--user".into(), "observer".into(), "--password-file".into(), wrong.to_str().expect("utf8").into()]);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && said.contains("refused to let \"observer\" in") && said.contains("password"),
        "a wrong password: {said}"
    );
    // Nothing at all listens on this port (one the hub just freed by listening elsewhere).
    let o = output_within(
        Command::new(SWARM).args(["keys", "--run", &run, "--connect", "tcp/127.0.0.1:9", "--window", "1"]),
        TOOL_LIMIT,
    );
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && said.contains("nothing accepts a connection there"), "no hub: {said}");

    // Logged in as UAV 1, another UAV's sensors: the router drops the subscription, and the tap says why.
    let o = output_within(
        Command::new(SWARM)
            .args(["tap", &format!("swarm/{run}/uav/2/sense"), "--connect", &loc, "--duration", "2"])
            .args(creds.login("uav1")),
        TOOL_LIMIT,
    );
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && o.stdout.is_empty(), "{said}");
    assert!(
        said.contains("nothing came on") && said.contains("refused the subscription") && said.contains("\"uav1\""),
        "{said}"
    );
    println!("first day: a tool without the run's login is told so; an empty tap says why: {}", said.trim());
}

#[test]
fn a_run_piped_into_head_ends_without_a_panic() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scenario = common::forest5_cut(dir.path(), 5.0);
    let mut child = Command::new(SWARM)
        .args(["run", &scenario, "--quiet", "--no-mcap", "--out", dir.path().join("run").to_str().expect("utf8")])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm run");
    let mut first = [0u8; 10];
    child.stdout.take().expect("stdout").read_exact(&mut first).expect("ten bytes");
    // The reader is gone (the pipe closed, as `head -c 10` closes it); the run goes on and ends.
    let o = common::wait_output(child, common::RUN_LIMIT, "swarm run | head -c 10");
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && !said.contains("panicked"), "exit {:?}: {said}", o.status);
}

#[test]
fn a_sigint_to_swarm_run_alone_ends_the_run_stopped() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("run");
    let child = Command::new(SWARM)
        .args([
            "run",
            "forest-5",
            "--time-mode",
            "realtime",
            "--quiet",
            "--no-mcap",
            "--out",
            out.to_str().expect("utf8"),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("swarm run");
    common::hub_locator(&out);
    std::thread::sleep(Duration::from_secs(2));
    let kill = Command::new("kill").args(["-INT", &child.id().to_string()]).status().expect("kill");
    assert!(kill.success());
    let o = common::wait_output(child, common::RUN_LIMIT, "swarm run after SIGINT");
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(!said.contains("hub did not exit"), "{said}");
    let s = common::summary(&out);
    assert_eq!(s["end_reason"], "stopped", "{said}");
}

#[test]
fn swarm_check_says_what_overlapping_and_missing_partition_groups_do() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = common::read(&common::root().join("scenarios/open-field-7-partition.toml"));
    let extra = "\n[[netem]]\nat_s = 50.0\npartition = { scheme = \"groups\", groups = [[1, 2, 3], [3, 4, 5]] }\n";
    let file = dir.path().join("overlap.toml");
    std::fs::write(&file, format!("{text}{extra}")).expect("write");
    let o = output_within(Command::new(SWARM).args(["check", file.to_str().expect("utf8")]), TOOL_LIMIT);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(said.contains("UAVs [3] in more than one group hear both, bridging them"), "{said}");
    assert!(said.contains("UAVs [6, 7] in no group are untouched by it"), "{said}");
    assert!(said.contains("faults (sim time):") && said.lines().count() < 25, "a short summary: {said}");
    let o = output_within(Command::new(SWARM).args(["check", file.to_str().expect("utf8"), "--json"]), TOOL_LIMIT);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).expect("--json is JSON");
    assert_eq!(json["swarm"]["count"], 7);
}
